"""``erc-lint ledger update``: add a tree, a git revision or a whole history to the ledger."""

import os
import tempfile
from collections.abc import Sequence
from pathlib import Path

import click

from erc_codec.schema import GitSpec, Repository, parse_tree_spec, read_file

from .._config import LEDGER, LEDGER_LIMIT
from .._errors import LedgerError
from .._history import History, keys
from .._ledger import Entry, Ledger
from .._loader import load_tree
from ._shared import FILE, Failure, common_options, guard, settings

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
    help="Change nothing; print the entries the ledger lacks and exit 1 if there are any.",
)
@common_options
def update(
    tree: str,
    history: bool,
    path: Path | None,
    check: bool,
    includes: Sequence[Path],
    config: Path | None,
) -> None:
    """Record every number TREE's messages and enums use (a folder or GITDIR#ref=REF)."""
    with guard():
        spec = parse_tree_spec(tree)
        if isinstance(spec, GitSpec):
            with Repository(spec.folder) as repository:
                shown = repository.where(spec.subdir)[1]
                if shown is None and path is None:
                    raise Failure(
                        f"{tree}: a bare repository has no folder for the ledger; "
                        "give --ledger FILE"
                    )
                target = path or (shown or spec.shown) / LEDGER
                book = _open(target)
                exclude = settings(config, shown).exclude
                commits = repository.history(spec.ref) if history else [repository.commit(spec.ref)]
                walker = History(repository, spec, includes, exclude)
                added = walker.update(book, commits)
            source = f"{len(commits)} revision{'s' * (len(commits) != 1)}"
        elif history:
            raise Failure(f"{tree}: --history needs a git input, GITDIR#ref=REF[,subdir=PATH]")
        elif not spec.is_dir():
            raise Failure(f"{tree}: not a folder holding a proto tree")
        else:
            target = path or spec / LEDGER
            book = _open(target)
            loaded = load_tree(spec, [Path(p) for p in includes], settings(config, spec).exclude)
            for name in sorted(loaded.failed):
                click.echo(f"{spec / name}: does not compile; nothing of it recorded", err=True)
            added = book.add(keys(loaded.files.values()), "-")
            source = str(spec)
        if check:
            _check(book, added, target)
            return
        if added:
            _write(target, book.render())
        click.echo(
            f"{target}: {len(added)} entries added from {source} ({len(book.entries)} in all)"
        )


def _open(target: Path) -> Ledger:
    """The ledger at ``target``; an empty one if there is no file yet (a device or a FIFO is
    one: refused, and so never replaced)."""
    return Ledger.read(target) if os.path.lexists(target) else Ledger(str(target))


def _check(book: Ledger, added: list[Entry], target: Path) -> None:
    """Exit 1, saying why, when an update would change the ledger file."""
    before = read_file(target, LEDGER_LIMIT) if os.path.lexists(target) else None
    reordered = before is not None and before.decode("utf-8", "replace") != book.render()
    for entry in added:
        click.echo(f"{target}: missing entry: {entry.render().rstrip()}")
    if reordered and not added:
        click.echo(f"{target}: not in canonical form (order or spacing): run ledger update")
    if added or reordered:
        raise SystemExit(1)


def _write(target: Path, text: str) -> None:
    """Replace ``target`` at once, so an interrupted or failed update (a full disk) never
    leaves half a ledger: the old one stays, and the failure is a ``LedgerError``."""
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        handle, scratch = tempfile.mkstemp(prefix=f".{target.name}.", dir=target.parent)
    except OSError as error:
        raise LedgerError(f"{target}: cannot write: {error.strerror}") from None
    try:
        with os.fdopen(handle, "w", encoding="utf-8", newline="\n") as stream:
            stream.write(text)
        os.replace(scratch, target)
    except BaseException as error:
        Path(scratch).unlink(missing_ok=True)
        if isinstance(error, OSError):
            raise LedgerError(f"{target}: cannot write: {error.strerror}") from None
        raise
