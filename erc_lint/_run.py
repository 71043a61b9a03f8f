"""One lint run: load the trees, find the ledger, run the rules, name files as the user did."""

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from erc_codec.schema import TreeSource, file_exists

from ._config import LEDGER, Config
from ._finding import Finding
from ._inputs import open_input, relocate
from ._loader import LoadedTree, load_tree
from ._model import build
from ._pairing import Change
from .rules import run

if TYPE_CHECKING:
    from ._ledger import Ledger

__all__ = ["check", "compare", "find_ledger", "lint"]


def lint(
    old: str | Path,
    new: str | Path,
    config: Config | None = None,
    includes: Sequence[str | Path] = (),
    ledger: str | Path | None = None,
) -> list[Finding]:
    """Compare two revisions of a proto tree, each a folder or ``GITDIR#ref=REF[,subdir=PATH]``;
    every finding of every rule ``config`` does not ignore. The ledger is ``ledger``, else the
    ``erc-lint.lock`` beside NEW's protos, if there is one."""
    with open_input(str(old)) as before, open_input(str(new)) as after:
        return compare(before, after, config or Config(), includes, ledger)


def check(
    tree: str | Path,
    config: Config | None = None,
    includes: Sequence[str | Path] = (),
    ledger: str | Path | None = None,
) -> list[Finding]:
    """Lint one tree on its own: the rules over one revision (compile errors, name collisions,
    what embedded roots reach, the ledger), every finding an error."""
    with open_input(str(tree)) as source:
        return compare(None, source, config or Config(), includes, ledger)


def compare(
    old: TreeSource | None,
    new: TreeSource,
    config: Config,
    includes: Sequence[str | Path] = (),
    ledger: str | Path | None = None,
) -> list[Finding]:
    """The findings of NEW against OLD (``None``: against nothing, which only tree rules see)."""
    roots = [Path(folder) for folder in includes]
    after = build(load_tree(new.folder, roots, config.exclude))
    if old is None:
        before = build(LoadedTree(new.folder))
    else:
        before = build(load_tree(old.folder, roots, config.exclude))
    change = Change(before, after, config, find_ledger(new, ledger))
    return relocate(run(change), [new] if old is None else [old, new])


def find_ledger(tree: TreeSource, path: str | Path | None = None) -> "Ledger | None":
    """The ledger at ``path``, else the one beside ``tree``'s protos, else none."""
    beside = tree.folder / LEDGER
    if path is None and not file_exists(beside):  # a FIFO there is refused by the reader
        return None
    # Only a run with a ledger pays for its import: for bench_lint's 30-file ratio, as the
    # module's dataclasses cost about 9 ms of start-up.
    from ._ledger import Ledger

    if path is not None:
        return Ledger.read(Path(path))
    return Ledger.read(beside, str(tree.shown / LEDGER))
