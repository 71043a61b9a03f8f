"""What a command names as a proto tree: a folder, or a revision of a git repository in buf's
spelling, ``GITDIR#ref=REF[,subdir=PATH]`` (``branch=`` or ``tag=`` instead of ``ref=``).

A revision is read from the repository's objects (``Repository``) into a scratch folder that
lives as long as ``open_tree``'s ``with`` block; the repository and its working tree are never
touched. Spaces work in every part of the spelling but the ref (a ref name cannot hold one).

Guarantees:
- The scratch folder is the only place written: a new folder in the system's temporary folder
  (``TMPDIR``), readable by its owner only, removed when the block ends. Every path written
  there is made of tree entries the reader checked (each one file name), every file is created
  new (never through a symlink, never over another file) and no symlink is ever made.
- What is written: the ``.proto`` and ``.options`` files, each at most ``SOURCE_LIMIT``; the
  files ``extra`` names at the tree's top, each within its own limit; ``TREE_LIMIT`` in all (a
  commit's objects compress a thousandfold: a small fetch must not fill a disk).
"""

import os
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import NamedTuple

from ._errors import SchemaError
from ._files import SOURCE_LIMIT, size_text
from ._git import GitError, Repository

__all__ = ["TREE_LIMIT", "GitSpec", "TreeSource", "open_tree", "parse_tree_spec"]

TREE_LIMIT = 256 * 1024 * 1024


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
    if subdir and any(part in ("", ".", "..") for part in subdir.split("/")):
        raise GitError(f"{text}: subdir must be a plain path inside the repository")
    return GitSpec(Path(folder or "."), refs[0], subdir)


@contextmanager
def open_tree(text: str, extra: Mapping[str, int] | None = None) -> Iterator[TreeSource]:
    """The tree ``text`` names, as a folder, for the duration of the ``with`` block. For a git
    revision, ``extra`` maps names of files at the tree's top to copy beside the protos (a
    configuration, say) to their size limits."""
    spec = parse_tree_spec(text)
    if isinstance(spec, Path):
        yield TreeSource(spec, spec)
        return
    import tempfile  # only for a git revision: opening a folder never loads it

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
        shown = worktree or spec.shown
        limits = dict(extra or {})
        files = repository.files(commit, inside, top=limits)
        with tempfile.TemporaryDirectory(prefix="erc-tree-") as scratch:
            _materialize(repository, files, limits, Path(scratch), shown)
            yield TreeSource(Path(scratch), shown, commit)


def _materialize(
    repository: Repository,
    files: dict[str, str],
    limits: dict[str, int],
    folder: Path,
    shown: Path,
) -> None:
    """Write ``files`` (``{path: blob}``) into ``folder``; ``shown`` names them in errors."""
    total = 0
    for path, blob in files.items():
        data = repository.read(blob, limits.get(path, SOURCE_LIMIT), str(shown / path))
        total += len(data)
        if total > TREE_LIMIT:
            raise GitError(
                f"{shown}: the tree's files pass {size_text(TREE_LIMIT)} in all at {path}: refused"
            )
        target = folder / path  # each part a tree entry's name: one file name
        try:
            target.parent.mkdir(parents=True, exist_ok=True)
            flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC
            with open(os.open(target, flags, 0o644), "wb") as stream:
                stream.write(data)
        except OSError as error:
            raise SchemaError(f"{shown / path}: cannot be copied out: {error.strerror}") from None
