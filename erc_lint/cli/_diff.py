"""``erc-lint diff OLD NEW`` (also plain ``erc-lint OLD NEW``) and ``erc-lint check TREE``."""

from collections.abc import Sequence
from pathlib import Path

import click

from .._run import compare
from ._shared import FORMAT_OPTION, LEDGER_OPTION, common_options, guard, opened, report, settings

__all__ = ["check", "diff"]


@click.command()
@click.argument("old")
@click.argument("new")
@FORMAT_OPTION
@common_options
@LEDGER_OPTION
def diff(
    old: str,
    new: str,
    output: str,
    includes: Sequence[Path],
    config: Path | None,
    ledger: Path | None,
) -> None:
    """Compare two revisions of a proto tree and report what breaks the wire."""
    with guard(), opened(old) as before, opened(new, "NEW") as after:
        findings = compare(before, after, settings(config, after.folder), includes, ledger)
    report(findings, output)


@click.command()
@click.argument("tree")
@FORMAT_OPTION
@common_options
@LEDGER_OPTION
def check(
    tree: str, output: str, includes: Sequence[Path], config: Path | None, ledger: Path | None
) -> None:
    """Lint one tree on its own: compile errors, name collisions, what embedded roots reach
    (fixed sizes), and reused numbers if there is a ledger."""
    with guard(), opened(tree, "TREE") as source:
        findings = compare(None, source, settings(config, source.folder), includes, ledger)
    report(findings, output)
