"""``erc-lint``: the linter's command line. Exit 0: no errors; 1: errors found; 2: could not run."""

from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any, TypeVar

import click

from erc_codec import CodecError
from erc_codec.cli import OneLineGroup

from ._config import Config, find_config, read_config
from ._errors import LintError
from ._finding import Finding
from ._inputs import Source, open_input
from ._report import FORMATS, render
from ._run import compare
from .rules import RULES

__all__ = ["main"]

_Command = TypeVar("_Command", bound=Callable[..., Any])


class _Failure(click.ClickException):
    exit_code = 2


class _LintGroup(OneLineGroup):
    """A group whose default command is ``diff``: ``erc-lint OLD NEW`` means ``erc-lint diff``.
    ``ledger`` loads on first use, so linting does not pay for the history walker's imports."""

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        if args and args[0] not in self.list_commands(ctx) and args[0] not in _OPTIONS:
            args = ["diff", *args]
        return super().parse_args(ctx, args)

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted({*super().list_commands(ctx), "ledger"})

    def get_command(self, ctx: click.Context, name: str) -> click.Command | None:
        if name == "ledger":
            from . import _cli_ledger  # noqa: F401 - registers the command

        return super().get_command(ctx, name)


_OPTIONS = ("-h", "--help", "--version")


@click.group(cls=_LintGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="erc-codec")
def main() -> None:
    """Wire-compatibility linter for proto trees: erc-lint OLD NEW.

    A tree is a folder, or a git revision in buf's spelling, GITDIR#ref=REF[,subdir=PATH],
    read from the repository's objects without a checkout.
    """


_FOLDER = click.Path(exists=True, file_okay=False, path_type=Path)
_FILE = click.Path(dir_okay=False, path_type=Path)


def _common(command: _Command) -> _Command:
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
                type=_FILE,
                help="A pyproject.toml with [tool.erc-lint]. Default: the tree's, else the "
                "working directory's.",
            ),
        ]
    ):
        command = option(command)
    return command


_LEDGER = click.option(
    "--ledger",
    type=_FILE,
    help="The number ledger. Default: erc-lint.lock beside the (NEW) tree's protos, if any.",
)
_FORMAT = click.option(
    "--format", "output", type=click.Choice(FORMATS), default="text", show_default=True
)


@main.command()
@click.argument("old")
@click.argument("new")
@_FORMAT
@_common
@_LEDGER
def diff(
    old: str,
    new: str,
    output: str,
    includes: Sequence[Path],
    config: Path | None,
    ledger: Path | None,
) -> None:
    """Compare two revisions of a proto tree and report what breaks the wire."""
    with _guard(), _opened(old) as before, _opened(new, "NEW") as after:
        settings = _settings(config, after.folder)
        findings = compare(before, after, settings, includes, ledger)
    _report(findings, output)


@main.command()
@click.argument("tree")
@_FORMAT
@_common
@_LEDGER
def check(
    tree: str, output: str, includes: Sequence[Path], config: Path | None, ledger: Path | None
) -> None:
    """Lint one tree on its own: compile errors, name collisions, what embedded roots reach
    (fixed sizes), and reused numbers if there is a ledger."""
    with _guard(), _opened(tree, "TREE") as source:
        findings = compare(None, source, _settings(config, source.folder), includes, ledger)
    _report(findings, output)


@main.command(name="rules")
def list_rules() -> None:
    """List every rule: ID, default severity and purpose."""
    for rule in RULES.values():
        severity = rule.severity if rule.pair else "error (warning if OLD has it)"
        click.echo(f"{rule.id:<26} {severity:<30} {rule.purpose}")


@contextmanager
def _opened(text: str, role: str = "") -> Iterator[Source]:
    """The tree ``text`` names; a wrong path is an error rather than an empty, passing tree."""
    with open_input(text) as source:
        if not source.folder.is_dir():
            raise _Failure(f"{text}: not a folder holding a proto tree")
        if role and not any(source.folder.rglob("*.proto")):
            raise _Failure(
                f"{text}: no .proto file in {role} (a wrong path would pass every check)"
            )
        yield source


def _settings(config: Path | None, folder: Path | None) -> Config:
    """``--config``, else the configuration in the tree's folder (if it has one), else here."""
    folders = [folder] if folder is not None and folder.is_dir() else []
    found = config or find_config(*folders, Path.cwd())
    return read_config(found, set(RULES), explicit=config is not None)


@contextmanager
def _guard() -> Iterator[None]:
    """Every failure to run as one line and exit 2, never a traceback."""
    try:
        yield
    except click.ClickException:
        raise
    except (LintError, OSError, CodecError) as error:
        raise _Failure(" ".join(str(error).split())) from None
    except Exception as error:
        # a bug of ours must not read as "errors found" (exit 1)
        raise _Failure(f"internal error ({type(error).__name__}): {error}") from None


def _report(findings: list[Finding], output: str) -> None:
    click.echo(render(findings, output), nl=False)
    if any(finding.severity == "error" for finding in findings):
        raise SystemExit(1)
