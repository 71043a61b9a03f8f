"""``erc-lint``: the linter's command line. Exit 0: no errors; 1: errors found; 2: could not run."""

from collections.abc import Sequence
from pathlib import Path

import click

from erc_codec import CodecError

from . import lint
from ._config import ConfigError, find_config, read_config
from ._report import FORMATS, render
from .rules import RULES

__all__ = ["main"]


class _Failure(click.ClickException):
    exit_code = 2


class _LintGroup(click.Group):
    """A group whose default command is ``diff``: ``erc-lint OLD NEW`` means ``erc-lint diff``."""

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        if args and args[0] not in self.commands and args[0] not in ("-h", "--help", "--version"):
            args = ["diff", *args]
        return super().parse_args(ctx, args)


@click.group(cls=_LintGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="erc-codec")
def main() -> None:
    """Wire-compatibility linter for proto trees: erc-lint OLD NEW."""


_TREE = click.Path(file_okay=False, path_type=Path)
_FOLDER = click.Path(exists=True, file_okay=False, path_type=Path)


@main.command()
@click.argument("old", type=_TREE)
@click.argument("new", type=_TREE)
@click.option("--format", "output", type=click.Choice(FORMATS), default="text", show_default=True)
@click.option(
    "-I",
    "--include",
    "includes",
    multiple=True,
    type=_FOLDER,
    help="Another folder imports are resolved against (repeatable).",
)
@click.option(
    "--config",
    type=click.Path(dir_okay=False, path_type=Path),
    help="A pyproject.toml with [tool.erc-lint]. Default: NEW's, else the working directory's.",
)
def diff(old: Path, new: Path, output: str, includes: Sequence[Path], config: Path | None) -> None:
    """Compare two revisions of a proto tree (folders) and report what breaks the wire."""
    for tree in (old, new):
        if not tree.is_dir():
            raise _Failure(f"{tree}: not a folder holding a proto tree")
    if not any(new.rglob("*.proto")):
        raise _Failure(f"{new}: no .proto file in NEW (a wrong path would pass every check)")
    try:
        settings = read_config(
            config or find_config(new, Path.cwd()), set(RULES), config is not None
        )
        findings = lint(old, new, settings, includes)
    except (ConfigError, OSError, CodecError) as error:
        raise _Failure(" ".join(str(error).split())) from None
    except Exception as error:  # a bug of ours must not read as "errors found" (exit 1)
        raise _Failure(f"internal error ({type(error).__name__}): {error}") from None
    click.echo(render(findings, output), nl=False)
    if any(finding.severity == "error" for finding in findings):
        raise SystemExit(1)


@main.command(name="rules")
def list_rules() -> None:
    """List every rule: ID, default severity and purpose."""
    for rule in RULES.values():
        severity = rule.severity if rule.pair else "error (warning if OLD has it)"
        click.echo(f"{rule.id:<26} {severity:<30} {rule.purpose}")
