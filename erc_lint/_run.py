"""One lint run: load the trees, find the ledger, run the rules, leave out what the baseline
accepted, name files as the user did; and one ledger update, a tree or a history added."""

import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple

from erc_schema import (
    NANOPB_VERSIONS,
    GitSpec,
    Repository,
    TreeSource,
    file_exists,
    parse_tree_spec,
    resolve_options,
)

from ._config import DEFAULT_OPTIONS_FILE, LEDGER, Config, check_config
from ._errors import ConfigError, LintError
from ._finding import Finding
from ._inputs import baseline_keys, missing_folder, missing_in_git, opened, relocate
from ._loader import LoadedTree, load_tree
from ._model import build
from ._pairing import Change
from .rules import run

if TYPE_CHECKING:
    from ._ledger import Entry, Ledger

__all__ = ["LedgerUpdate", "Outcome", "check", "compare", "find_ledger", "lint", "update_ledger"]


class Outcome(NamedTuple):
    """What one run found: the findings to report, how many the baseline accepted, how many
    .proto files NEW (or TREE) has, and every finding's baseline key (baselined ones too)."""

    findings: list[Finding]
    baselined: int
    files: int
    keys: list[str]


def lint(
    old: str | Path,
    new: str | Path,
    config: Config | None = None,
    includes: Sequence[str | Path] = (),
    ledger: str | Path | None = None,
) -> list[Finding]:
    """Compare two revisions of a proto tree, each a folder or ``GITDIR#ref=REF[,subdir=PATH]``;
    every finding of every rule ``config`` does not ignore. The ledger is ``ledger``, else the
    ``erc-lint.lock`` beside NEW's protos, if there is one. A wrong path, a subdir a revision
    lacks, or a tree with no .proto is a ``LintError`` (an empty OLD passes only before a
    repository's first commit: a first version is ``check``'s), never an empty tree that
    passes every check."""
    with opened(str(old), "OLD") as before, opened(str(new), "NEW") as after:
        return compare(before, after, config or Config(), includes, ledger).findings


def check(
    tree: str | Path,
    config: Config | None = None,
    includes: Sequence[str | Path] = (),
    ledger: str | Path | None = None,
) -> list[Finding]:
    """Lint one tree on its own: the rules over one revision (compile errors, name collisions,
    what embedded roots reach, the ledger), every finding an error. A tree that is not there
    is a ``LintError``, as for ``lint``."""
    with opened(str(tree), "TREE") as source:
        return compare(None, source, config or Config(), includes, ledger).findings


def compare(
    old: TreeSource | None,
    new: TreeSource,
    config: Config,
    includes: Sequence[str | Path] = (),
    ledger: str | Path | None = None,
    baseline: frozenset[str] = frozenset(),
) -> Outcome:
    """The findings of NEW against OLD (``None``: against nothing, which only tree rules see),
    less those ``baseline`` holds. Both are loaded with ``includes`` (else the configuration's
    ``include`` folders) and its nanopb ``options_file`` and ``settings``, sized by the rules
    of its ``nanopb_version``; a setting nanopb cannot read, or an options file found nowhere,
    is a ``SchemaError``; a ``config`` a ``[tool.erc-lint]`` table could not hold (a budget for
    no root, or of no bytes) is a ``ConfigError``."""
    check_config(config)
    roots = [Path(folder) for folder in includes or config.include]
    nanopb = (config.options_file, config.settings)
    if nanopb != (DEFAULT_OPTIONS_FILE, ()):  # checked now: sizes that cannot be are no finding
        resolve_options(new.folder, (), roots, *nanopb)
    version = config.nanopb_version
    if version not in NANOPB_VERSIONS:  # checked now: a size by no generator's rules is none
        raise ConfigError(
            f"nanopb_version {version!r}: erc-lint knows the generator rules of "
            f"{' and '.join(NANOPB_VERSIONS)}"
        )
    loaded = load_tree(new.folder, roots, config.exclude)
    after = build(loaded, *nanopb, version)
    if old is None:
        before = build(LoadedTree(new.folder), *nanopb, version)
    else:
        before = build(load_tree(old.folder, roots, config.exclude), *nanopb, version)
    change = Change(before, after, config, find_ledger(new, ledger))
    found = run(change)
    sources = [new] if old is None else [old, new]
    keys = baseline_keys(found, old or new, new, sources)
    kept = [f for f, key in zip(found, keys, strict=True) if key not in baseline]
    files = len(loaded.texts.keys() | loaded.failed)
    return Outcome(relocate(kept, sources), len(found) - len(kept), files, keys)


def find_ledger(tree: TreeSource, path: str | Path | None = None) -> "Ledger | None":
    """The ledger at ``path``, else the one beside ``tree``'s protos, else none."""
    beside = tree.folder / LEDGER
    if path is None and not file_exists(beside):  # a FIFO there is refused by the reader
        return None
    # Imported on first use: a run that needs no ledger never loads it.
    from ._ledger import Ledger

    if path is not None:
        return Ledger.read(Path(path))
    return Ledger.read(beside, str(tree.shown / LEDGER))


class LedgerUpdate(NamedTuple):
    """What adding a tree (or a history) to a ledger did, not yet written: ``ledger.write``."""

    ledger: "Ledger"
    target: Path
    added: "list[Entry]"
    source: str  # what was added: a folder, or "N revisions"
    failed: list[str]  # files (of the last revision) that did not compile: nothing recorded
    collided: list[str]  # names (of the last revision) two files define: none of their numbers


def update_ledger(
    tree: str,
    path: Path | None,
    history: bool,
    includes: Sequence[Path],
    settings: Callable[[Path | None], Config],
) -> LedgerUpdate:
    """Add every number of ``tree`` (a folder or a git revision; with ``history``, every revision
    reachable from its ref) to the ledger at ``path``, else the one beside the tree's protos.
    ``settings`` gives the configuration for the folder holding the tree (its ``exclude``, and
    the leftovers ``ignore_only`` names for NAME_COLLISION, whose definitions do not count)."""
    from ._history import History, recorded
    from ._ledger import Ledger

    spec = parse_tree_spec(tree)
    if isinstance(spec, GitSpec):
        with Repository(spec.folder) as repository:
            inside, shown = repository.where(spec.subdir)
            if shown is None and path is None:
                raise LintError(
                    f"{tree}: a bare repository has no folder for the ledger; give --ledger FILE"
                )
            target = path or (shown or spec.shown) / LEDGER
            book = Ledger.read(target) if _exists(target) else Ledger(str(target))
            commits = repository.history(spec.ref) if history else [repository.commit(spec.ref)]
            if not repository.files(commits[-1], inside):
                why = missing_in_git(repository, commits[-1], inside)
                raise LintError(f"{tree}: no .proto file: {why}")
            config = settings(shown)
            includes = includes or [Path(folder) for folder in config.include]
            leftovers = config.ignore_only.get("NAME_COLLISION", ())
            walker = History(repository, spec, includes, config.exclude, leftovers)
            added = walker.update(book, commits)
        source = f"{len(commits)} revision{'s' * (len(commits) != 1)}"
        return LedgerUpdate(
            book, target, added, source, sorted(walker.failed), sorted(walker.collided)
        )
    if history:
        raise LintError(f"{tree}: --history needs a git input, GITDIR#ref=REF[,subdir=PATH]")
    problem = missing_folder(spec)
    if problem:
        raise LintError(f"{tree}: {problem} in TREE (a wrong path would pass every check)")
    target = path or spec / LEDGER
    book = Ledger.read(target) if _exists(target) else Ledger(str(target))
    config = settings(spec)
    includes = includes or [Path(folder) for folder in config.include]
    loaded = load_tree(spec, list(includes), config.exclude)
    found, collided = recorded(
        loaded.files.values(), lambda path: config.ignored_at("NAME_COLLISION", path)
    )
    added = book.add(found, "-")
    return LedgerUpdate(book, target, added, str(spec), sorted(loaded.failed), sorted(collided))


def _exists(target: Path) -> bool:
    return os.path.lexists(target)  # a device or a FIFO is one: refused, and so never replaced
