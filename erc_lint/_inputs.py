"""What OLD, NEW or TREE name: a folder, or a revision of a git repository in buf's spelling.

``GITDIR#ref=REF[,subdir=PATH]`` (also ``branch=`` or ``tag=`` instead of ``ref=``) is read from
the repository's objects into a scratch folder that lives as long as the comparison; the
repository and its working tree are never touched. Findings about files of a git input name them
as the repository does (``GITDIR/PATH/file.proto``), so a CI annotation or an editor opens the
same file a plain folder would have named.
"""

import os
import tempfile
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import NamedTuple

from ._errors import GitError
from ._finding import Finding
from ._git import Repository

__all__ = ["GitInput", "Source", "locate", "materialize", "open_input", "parse", "relocate"]

# What a tree holds for the linter: the protos, their nanopb options, the configuration and
# the ledger (these two only at the tree's top).
_SUFFIXES = (".proto", ".options")
_TOP = ("pyproject.toml", "erc-lint.lock")


class GitInput(NamedTuple):
    folder: Path  # GITDIR
    ref: str
    subdir: str = ""

    @property
    def shown(self) -> Path:
        """Where the tree sits in a checkout of the repository."""
        return self.folder / self.subdir if self.subdir else self.folder


def locate(spec: GitInput, repository: Repository) -> tuple[str, Path | None]:
    """The tree's folder in the repository's commits (``GITDIR`` may be a folder inside the
    working tree, or ``.git``), and where it sits in the working tree (None: a bare repository)."""
    inside = f"{repository.prefix}{spec.subdir}".strip("/")
    if repository.worktree is None:
        return inside, None
    return inside, repository.worktree / spec.subdir if spec.subdir else repository.worktree


def parse(text: str) -> Path | GitInput:
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
    return GitInput(Path(folder or "."), refs[0], subdir)


class Source(NamedTuple):
    """A tree ready to load: ``folder`` holds it; findings name it ``shown``."""

    folder: Path
    shown: Path
    revision: str | None = None  # the commit, for a git input


@contextmanager
def open_input(text: str) -> Iterator[Source]:
    """The tree ``text`` names, as a folder, for the duration of the ``with`` block."""
    spec = parse(text)
    if isinstance(spec, Path):
        yield Source(spec, spec)
        return
    with Repository(spec.folder) as repository:
        try:
            commit = repository.commit(spec.ref)
        except GitError:
            if spec.ref != "HEAD" or not repository.unborn():
                raise
            # Before the first commit there was no tree: nothing can have been broken.
            with tempfile.TemporaryDirectory(prefix="erc-lint-git-") as scratch:
                yield Source(Path(scratch), spec.shown)
            return
        inside, shown = locate(spec, repository)
        files = repository.files(commit, inside)
        with tempfile.TemporaryDirectory(prefix="erc-lint-git-") as scratch:
            folder = Path(scratch)
            materialize(repository, files, folder)
            yield Source(folder, shown or spec.shown, commit)


def materialize(repository: Repository, files: dict[str, str], folder: Path) -> None:
    """Write what the linter reads of a tree's files (``{path: blob}``) into ``folder``."""
    for path, blob in files.items():
        if path.endswith(_SUFFIXES) or path in _TOP:
            target = folder / path
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_bytes(repository.read(blob))


def relocate(findings: Sequence[Finding], sources: Sequence[Source]) -> list[Finding]:
    """The findings with every scratch folder's path replaced by the name its tree is shown as."""
    moves = [
        (str(source.folder) + os.sep, "" if str(source.shown) == "." else f"{source.shown}{os.sep}")
        for source in sources
        if source.folder != source.shown
    ]
    if not moves:
        return list(findings)
    moved = []
    for finding in findings:
        path, message = finding.path, finding.message
        for scratch, shown in moves:
            path = shown + path.removeprefix(scratch) if path.startswith(scratch) else path
            message = message.replace(scratch, shown)
        moved.append(finding._replace(path=path, message=message))
    return moved
