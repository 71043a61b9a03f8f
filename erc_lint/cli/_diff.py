"""``erc-lint diff OLD NEW`` (also plain ``erc-lint OLD NEW``), ``erc-lint check TREE`` and
``erc-lint baseline``, which writes what they find to a baseline file."""

from collections.abc import Sequence
from pathlib import Path

import click

from .._baseline import BASELINE, render_baseline
from .._run import compare
from ._shared import (
    BASELINE_OPTION,
    FILE,
    FORMAT_OPTION,
    LEDGER_OPTION,
    SEVERITY_OPTION,
    baseline_keys,
    common_options,
    guard,
    opened,
    report,
    settings,
)

__all__ = ["baseline", "check", "diff"]

_ALLOW_EMPTY_OLD = click.option(
    "--allow-empty-old",
    is_flag=True,
    help="Accept an OLD with no .proto file (a first version), which is otherwise an error.",
)


@click.command()
@click.argument("old")
@click.argument("new")
@FORMAT_OPTION
@SEVERITY_OPTION
@BASELINE_OPTION
@_ALLOW_EMPTY_OLD
@common_options
@LEDGER_OPTION
def diff(
    old: str,
    new: str,
    output: str,
    severity: str,
    baseline: Path | None,
    allow_empty_old: bool,
    config: Path | None,
    includes: Sequence[Path],
    options_file: str | None,
    generator_settings: Sequence[str],
    nanopb_version: str | None,
    ledger: Path | None,
) -> None:
    """Compare two revisions of a proto tree and report what breaks the wire."""
    generator = (includes, options_file, generator_settings, nanopb_version)
    with guard():
        accepted, given = baseline_keys(baseline)
        with opened(old, "OLD", allow_empty_old) as before, opened(new, "NEW") as after:
            outcome = compare(
                before,
                after,
                settings(config, after.folder, *generator, shown=after.shown),
                includes,
                ledger,
                accepted,
            )
        report(outcome, output, severity, given)


@click.command()
@click.argument("tree")
@FORMAT_OPTION
@SEVERITY_OPTION
@BASELINE_OPTION
@common_options
@LEDGER_OPTION
def check(
    tree: str,
    output: str,
    severity: str,
    baseline: Path | None,
    config: Path | None,
    includes: Sequence[Path],
    options_file: str | None,
    generator_settings: Sequence[str],
    nanopb_version: str | None,
    ledger: Path | None,
) -> None:
    """Lint one tree on its own: compile errors, name collisions, what embedded roots reach
    (fixed sizes), and reused numbers if there is a ledger."""
    generator = (includes, options_file, generator_settings, nanopb_version)
    with guard():
        accepted, given = baseline_keys(baseline)
        with opened(tree, "TREE") as source:
            outcome = compare(
                None,
                source,
                settings(config, source.folder, *generator, shown=source.shown),
                includes,
                ledger,
                accepted,
            )
        report(outcome, output, severity, given)


@click.command(name="baseline")
@click.argument("trees", nargs=-1, required=True, metavar="[OLD] NEW")
@click.option(
    "--output",
    "-o",
    "target",
    type=FILE,
    default=Path(BASELINE),
    show_default=True,
    help="The baseline file to write.",
)
@_ALLOW_EMPTY_OLD
@common_options
@LEDGER_OPTION
def baseline(
    trees: tuple[str, ...],
    target: Path,
    allow_empty_old: bool,
    config: Path | None,
    includes: Sequence[Path],
    options_file: str | None,
    generator_settings: Sequence[str],
    nanopb_version: str | None,
    ledger: Path | None,
) -> None:
    """Write every current finding of `erc-lint OLD NEW` (or of `erc-lint check TREE`) to a
    baseline file: later runs given it report only findings it does not hold."""
    if len(trees) > 2:
        raise click.UsageError("give NEW, or OLD and NEW")
    generator = (includes, options_file, generator_settings, nanopb_version)
    with guard():
        if len(trees) == 1:
            with opened(trees[0], "TREE") as source:
                outcome = compare(
                    None,
                    source,
                    settings(config, source.folder, *generator, shown=source.shown),
                    includes,
                    ledger,
                )
        else:
            with (
                opened(trees[0], "OLD", allow_empty_old) as before,
                opened(trees[1], "NEW") as after,
            ):
                outcome = compare(
                    before,
                    after,
                    settings(config, after.folder, *generator, shown=after.shown),
                    includes,
                    ledger,
                )
        target.write_text(render_baseline(outcome.keys), encoding="utf-8")
    count = len(set(outcome.keys))
    click.echo(f"{target}: {count} finding{'s' * (count != 1)} baselined", err=True)
