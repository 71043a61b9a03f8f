"""What the erc-lint commands share: their options, opening a tree, the configuration, one-line
failures (exit 2) and the report (exit 1 when it holds an error)."""

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, TypeVar

import click

from erc_codec import CodecError
from erc_codec.schema import TreeSource, proto_files

from .._config import Config, find_config, read_config
from .._errors import LintError
from .._finding import Finding
from .._inputs import open_input
from .._report import FORMATS, render
from ..rules import CATEGORIES, RULES

__all__ = [
    "FILE",
    "FORMAT_OPTION",
    "LEDGER_OPTION",
    "Failure",
    "common_options",
    "guard",
    "opened",
    "report",
    "settings",
]

_Command = TypeVar("_Command", bound=Callable[..., Any])


class Failure(click.ClickException):
    """The command could not run: one line on stderr, exit status 2."""

    exit_code = 2


_FOLDER = click.Path(exists=True, file_okay=False, path_type=Path)
FILE = click.Path(dir_okay=False, path_type=Path)


def common_options(command: _Command) -> _Command:
    """The options every linting command takes."""
    for option in reversed(
        [
            click.option(
                "-I",
                "--include",
                "includes",
                multiple=True,
                type=_FOLDER,
                help="Another folder imports are resolved against (repeatable).",
            ),
            click.option(
                "--config",
                type=FILE,
                help="A pyproject.toml with [tool.erc-lint]. Default: the tree's, else the "
                "working directory's.",
            ),
        ]
    ):
        command = option(command)
    return command


LEDGER_OPTION = click.option(
    "--ledger",
    type=FILE,
    help="The number ledger. Default: erc-lint.lock beside the (NEW) tree's protos, if any.",
)
FORMAT_OPTION = click.option(
    "--format", "output", type=click.Choice(FORMATS), default="text", show_default=True
)


@contextmanager
def opened(text: str, role: str = "") -> Iterator[TreeSource]:
    """The tree ``text`` names; a wrong path is an error rather than an empty, passing tree."""
    with open_input(text) as source:
        if not source.folder.is_dir():
            raise Failure(f"{text}: not a folder holding a proto tree")
        if role and not proto_files(source.folder):
            raise Failure(f"{text}: no .proto file in {role} (a wrong path would pass every check)")
        yield source


def settings(config: Path | None, folder: Path | None) -> Config:
    """``--config``, else the configuration in the tree's folder (if it has one), else here."""
    folders = [folder] if folder is not None and folder.is_dir() else []
    found = config or find_config(*folders, Path.cwd())
    return read_config(found, set(RULES), explicit=config is not None, categories=set(CATEGORIES))


@contextmanager
def guard() -> Iterator[None]:
    """Every failure to run as one line and exit 2, never a traceback."""
    try:
        yield
    except click.ClickException:
        raise
    except (LintError, OSError, CodecError) as error:
        raise Failure(" ".join(str(error).split())) from None
    except Exception as error:
        # a bug of ours must not read as "errors found" (exit 1)
        raise Failure(f"internal error ({type(error).__name__}): {error}") from None


def report(findings: list[Finding], output: str) -> None:
    """Print the findings; exit 1 when one of them is an error. A file name that is not UTF-8
    is printed as the bytes it is (as ``ls`` prints it), whatever the locale's encoding."""
    click.echo(render(findings, output).encode("utf-8", "surrogateescape"), nl=False)
    if any(finding.severity == "error" for finding in findings):
        raise SystemExit(1)
