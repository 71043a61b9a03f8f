"""``erc-lint ledger update``: add a tree, a git revision or a whole history to the ledger."""

from collections.abc import Sequence
from pathlib import Path

import click

from erc_schema import read_file

from .._config import LEDGER_LIMIT
from .._run import LedgerUpdate, update_ledger
from ._shared import FILE, common_options, guard, settings

__all__ = ["ledger"]


@click.group()
def ledger() -> None:
    """Keep the number ledger (erc-lint.lock) up to date."""


@ledger.command()
@click.argument("tree")
@click.option(
    "--history",
    is_flag=True,
    help="Add every revision reachable from TREE's git ref, oldest first (TREE must be "
    "GITDIR#ref=REF[,subdir=PATH]).",
)
@click.option("--ledger", "path", type=FILE, help="Default: erc-lint.lock beside TREE's protos.")
@click.option(
    "--check",
    is_flag=True,
    help="Change nothing; print the entries the ledger lacks (and files that do not compile) "
    "and exit 1 if there are any.",
)
@common_options
def update(
    tree: str,
    history: bool,
    path: Path | None,
    check: bool,
    config: Path | None,
    includes: Sequence[Path],
    options_file: str | None,
    generator_settings: Sequence[str],
    nanopb_version: str | None,
) -> None:
    """Record every number TREE's messages and enums use (a folder or GITDIR#ref=REF)."""
    with guard():
        done = update_ledger(
            tree,
            path,
            history,
            includes,
            lambda f: settings(
                config, f, includes, options_file, generator_settings, nanopb_version
            ),
        )
        for name in done.failed:
            click.echo(f"{tree}: {name} does not compile; nothing of it recorded", err=True)
        for name in done.collided:
            click.echo(
                f"{tree}: {name} is defined more than once (NAME_COLLISION); none of its numbers "
                "recorded",
                err=True,
            )
        if check:
            _check(done)
            return
        if done.added:
            done.ledger.write(done.target)
    click.echo(
        f"{done.target}: {len(done.added)} entries added from {done.source} "
        f"({len(done.ledger.entries)} in all)"
    )


def _check(done: LedgerUpdate) -> None:
    """Exit 1, saying why, when an update would change the ledger file or could not record a
    file that does not compile or a name two files define."""
    target = done.target
    before = read_file(target, LEDGER_LIMIT) if target.exists() else None
    reordered = before is not None and before.decode("utf-8", "replace") != done.ledger.render()
    for entry in done.added:
        click.echo(f"{target}: missing entry: {entry.render().rstrip()}")
    if reordered and not done.added:
        click.echo(f"{target}: not in canonical form (order or spacing): run ledger update")
    if done.added or reordered or done.failed or done.collided:
        raise SystemExit(1)
