"""What the erc-lint commands share: their options, opening a tree, the configuration, one-line
failures (exit 2) and the report (exit 1 when it holds an error)."""

import os
import sys
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any, TypeVar

import click

from erc_schema import CodecError, file_exists
from erc_schema.cli import generator_options

from .._baseline import BASELINE, read_baseline
from .._config import Config, find_config, read_config
from .._errors import LintError
from .._inputs import opened
from .._report import FORMATS, render
from .._run import Outcome
from ..rules import CATEGORIES, RULES, select

__all__ = [
    "BASELINE_OPTION",
    "FILE",
    "FORMAT_OPTION",
    "LEDGER_OPTION",
    "SEVERITY_OPTION",
    "Failure",
    "baseline_keys",
    "common_options",
    "guard",
    "opened",  # erc_lint._inputs's, for the commands
    "report",
    "settings",
    "summary",
]

_Command = TypeVar("_Command", bound=Callable[..., Any])


class Failure(click.ClickException):
    """The command could not run: one line on stderr, exit status 2."""

    exit_code = 2


FILE = click.Path(dir_okay=False, path_type=Path)


def common_options(command: _Command) -> _Command:
    """The options every linting command takes: ``--config`` and nanopb's generator inputs
    (``-I``, ``-f``, ``-s``, ``--nanopb-version``: ``includes``, ``options_file``,
    ``generator_settings``, ``nanopb_version``), which replace the configuration's ``include``,
    ``options_file``, ``settings`` and ``nanopb_version`` (``settings``)."""
    command = click.option(
        "--config",
        type=FILE,
        help="A pyproject.toml with [tool.erc-lint]. Default: the tree's, else the "
        "working directory's.",
    )(command)
    return generator_options()(command)


LEDGER_OPTION = click.option(
    "--ledger",
    type=FILE,
    help="The number ledger. Default: erc-lint.lock beside the (NEW) tree's protos, if any.",
)
FORMAT_OPTION = click.option(
    "--format", "output", type=click.Choice(FORMATS), default="text", show_default=True
)


def settings(
    config: Path | None,
    folder: Path | None,
    includes: Sequence[Path] = (),
    options_file: str | None = None,
    generator_settings: Sequence[str] = (),
    nanopb_version: str | None = None,
    shown: Path | None = None,
) -> Config:
    """``--config``, else the configuration in the tree's folder (if it has one), else here;
    with the ``-I``, ``-f``, ``-s`` and ``--nanopb-version`` given in place of its own.
    ``shown`` is where the tree's folder is shown (a git revision's scratch copy: in the
    repository), which the paths of a configuration found in it are relative to."""
    folders = [folder] if folder is not None and folder.is_dir() else []
    found = config or find_config(*folders, Path.cwd())
    copied = found is not None and shown is not None and found.parent == folder
    read = read_config(
        found,
        set(RULES),
        explicit=config is not None,
        categories=set(CATEGORIES),
        base=shown if copied else None,
    )
    if read.budget and "ENVELOPE_OVER_BUDGET" not in select(read):
        # ruff's way with settings that contradict each other: a warning, and the run goes on
        where = f"{read.source}:{read.budget_line}: " if read.source else ""
        click.echo(
            f"{where}warning: budget is set, but use/except leave out ENVELOPE_OVER_BUDGET: "
            "no budget is checked",
            err=True,
        )
    return read._replace(
        include=tuple(map(str, includes)) or read.include,
        options_file=read.options_file if options_file is None else options_file,
        settings=tuple(generator_settings) or read.settings,
        nanopb_version=nanopb_version or read.nanopb_version,
    )


SEVERITY_OPTION = click.option(
    "--severity",
    type=click.Choice(["warning", "error"]),
    default="warning",
    show_default=True,
    help="The least severe finding to print: error prints errors only (the summary counts all).",
)
BASELINE_OPTION = click.option(
    "--baseline",
    type=FILE,
    help=f"Report only findings this baseline does not hold (`erc-lint baseline` writes one). "
    f"Default: {BASELINE} in the working directory, if there is one.",
)


def baseline_keys(path: Path | None) -> tuple[frozenset[str], bool]:
    """The keys of ``--baseline``, else of ./erc-lint.baseline; and whether there was one."""
    chosen = path or Path(BASELINE)
    if path is None and not file_exists(chosen):
        return frozenset(), False
    return read_baseline(chosen), True


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


def report(
    outcome: Outcome, output: str, severity: str = "warning", baseline: bool = False
) -> None:
    """Print the findings (``severity`` error: errors only), then the summary line on stderr;
    exit 1 when an error was found. A file name that is not UTF-8 is printed as the bytes it is
    (as ``ls`` prints it), whatever the locale's encoding. A reader that stops early (``| head``)
    ends the run quietly with the status the findings give, as ``git log | head`` does. Run it
    inside ``guard``: a failure to render is one line, exit 2."""
    if sys.stdout is None:  # started with stdout closed (`>&-`)
        raise Failure("standard output is closed: nowhere to write the findings")
    findings = outcome.findings
    shown = [f for f in findings if severity == "warning" or f.severity == "error"]
    failed = any(finding.severity == "error" for finding in findings)
    try:
        click.echo(render(shown, output).encode("utf-8", "surrogateescape"), nl=False)
        sys.stdout.flush()
    except BrokenPipeError:
        # Python flushes stdout again at exit: point it at nothing, so that flush is silent.
        sink = os.open(os.devnull, os.O_WRONLY)
        os.dup2(sink, sys.stdout.fileno())
        os.close(sink)
    click.echo(summary(outcome, baseline), err=True)
    if failed:
        raise SystemExit(1)


def summary(outcome: Outcome, baseline: bool) -> str:
    """``2 errors, 1 warning (1 new since baseline, 4 baselined) in 41 files``."""
    errors = sum(f.severity == "error" for f in outcome.findings)
    warnings = len(outcome.findings) - errors
    counted = f"{_plural(errors, 'error')}, {_plural(warnings, 'warning')}"
    if baseline:
        counted += f" ({len(outcome.findings)} new since baseline, {outcome.baselined} baselined)"
    return f"{counted} in {_plural(outcome.files, 'file')}"


def _plural(count: int, word: str) -> str:
    return f"{count} {word}{'s' * (count != 1)}"
