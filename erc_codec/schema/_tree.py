"""What a command names as a proto tree: a folder, or a revision of a git repository in buf's
spelling, ``GITDIR#ref=REF[,subdir=PATH]`` (``branch=`` or ``tag=`` instead of ``ref=``).

A revision is read from the repository's objects (``Repository``) into a scratch folder that
lives as long as ``open_tree``'s ``with`` block; the repository and its working tree are never
touched. The scratch folder holds the ``.proto`` and ``.options`` files, and the files ``extra``
names at the tree's top.
"""

import tempfile
from collections.abc import Collection, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import NamedTuple

from ._git import GitError, Repository

__all__ = ["GitSpec", "TreeSource", "open_tree", "parse_tree_spec"]

_SUFFIXES = (".proto", ".options")


class GitSpec(NamedTuple):
    """A revision of a repository's tree, as ``GITDIR#ref=REF[,subdir=PATH]`` spells it."""

    folder: Path  # GITDIR
    ref: str
    subdir: str = ""

    @property
    def shown(self) -> Path:
        """Where the tree sits in a checkout of the repository, as GITDIR spells it."""
        return self.folder / self.subdir if self.subdir else self.folder


class TreeSource(NamedTuple):
    """A tree ready to load: ``folder`` holds it; messages name its files under ``shown``."""

    folder: Path
    shown: Path
    revision: str | None = None  # the commit, for a git revision


def parse_tree_spec(text: str) -> Path | GitSpec:
    """A folder, or the git revision ``text`` spells (``GITDIR#ref=REF[,subdir=PATH]``)."""
    if "#" not in text or Path(text).is_dir():
        return Path(text)
    folder, _, options = text.partition("#")
    values: dict[str, str] = {}
    for option in options.split(","):
        key, equals, value = option.partition("=")
        if not equals or not value or key not in ("ref", "branch", "tag", "subdir"):
            raise GitError(
                f"{text}: expected GITDIR#ref=REF[,subdir=PATH], not the option {option!r}"
            )
        if key in values:
            raise GitError(f"{text}: {key} given twice")
        values[key] = value
    refs = [values[key] for key in ("ref", "branch", "tag") if key in values]
    if len(refs) != 1:
        raise GitError(f"{text}: give exactly one of ref=, branch= or tag=")
    subdir = values.get("subdir", "").strip("/")
    if any(part in ("", ".", "..") for part in subdir.split("/")) and subdir:
        raise GitError(f"{text}: subdir must be a plain path inside the repository")
    return GitSpec(Path(folder or "."), refs[0], subdir)


@contextmanager
def open_tree(text: str, extra: Collection[str] = ()) -> Iterator[TreeSource]:
    """The tree ``text`` names, as a folder, for the duration of the ``with`` block; for a git
    revision, the files ``extra`` names at the tree's top (a configuration, say) are copied
    beside the protos."""
    spec = parse_tree_spec(text)
    if isinstance(spec, Path):
        yield TreeSource(spec, spec)
        return
    with Repository(spec.folder) as repository:
        try:
            commit = repository.commit(spec.ref)
        except GitError:
            if spec.ref != "HEAD" or not repository.unborn():
                raise
            # Before the first commit there was no tree: an empty one.
            with tempfile.TemporaryDirectory(prefix="erc-tree-") as scratch:
                yield TreeSource(Path(scratch), spec.shown)
            return
        inside, worktree = repository.where(spec.subdir)
        files = repository.files(commit, inside)
        with tempfile.TemporaryDirectory(prefix="erc-tree-") as scratch:
            _materialize(repository, files, extra, Path(scratch))
            yield TreeSource(Path(scratch), worktree or spec.shown, commit)


def _materialize(
    repository: Repository, files: dict[str, str], extra: Collection[str], folder: Path
) -> None:
    """Write the protos and options of a tree's files (``{path: blob}``), and ``extra``'s
    files at its top, into ``folder``."""
    for path, blob in files.items():
        if path.endswith(_SUFFIXES) or path in extra:
            target = folder / path
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_bytes(repository.read(blob))
