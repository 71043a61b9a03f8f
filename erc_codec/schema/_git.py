"""A git repository's objects, read the way ``git`` stores them: no checkout, no working tree.

Guarantees:
- Nothing in the repository changes: every read goes through one long-lived
  ``git cat-file --batch`` process, which only reads objects.
- A tree object is parsed once, whatever the number of commits that share it, and a blob is read
  once, whatever the number of revisions that hold it: walking a history costs what changed in
  it, not its length times its size.
- Refs are resolved by git itself (``main``, ``origin/main``, ``HEAD~3``, a tag, an object id).

``subprocess`` is imported when a repository is opened: linting folders does not pay for it
(bench_lint's 30-file ratio: about 3.5 ms of start-up).
"""

import os
import posixpath
from pathlib import Path
from typing import IO, TYPE_CHECKING

from .._errors import SchemaError

if TYPE_CHECKING:
    import subprocess

__all__ = ["GitError", "Repository"]


_LINK = "link:"  # marks a symlink's blob in a parsed tree


class GitError(SchemaError):
    """A repository, or an object in it, cannot be read."""


class Repository:
    """The objects of the repository holding ``folder`` (a working tree, ``.git`` or bare repo)."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        found = self._git(
            "rev-parse",
            "--absolute-git-dir",
            "--is-bare-repository",
            "--is-inside-git-dir",
            "--show-prefix",
        ).split("\n")
        self.git_dir = Path(found[0])
        # Where ``folder`` sits in the repository's trees ("proto/" when it is that folder of
        # the working tree), and the working tree's top as ``folder`` is spelled (None: bare).
        self.prefix = found[3] if found[2] == "false" else ""
        self.worktree: Path | None = None
        if found[1] == "false" and found[2] == "true":  # the .git folder of a working tree
            top = self.git_dir.parent  # spelled as absolutely or relatively as ``folder`` was
            self.worktree = top if folder.is_absolute() else Path(os.path.relpath(top))
        elif found[1] == "false":
            self.worktree = folder
        self._batch: subprocess.Popen[bytes] | None = None
        self._trees: dict[str, dict[str, str]] = {}  # tree id → {path: blob id}, recursive
        self._blobs: dict[str, bytes] = {}

    def __enter__(self) -> "Repository":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        if self._batch is not None:
            assert self._batch.stdin is not None
            assert self._batch.stdout is not None
            self._batch.stdin.close()
            self._batch.wait()
            self._batch.stdout.close()
            self._batch = None

    def where(self, subdir: str = "") -> tuple[str, Path | None]:
        """``subdir`` of ``folder`` as a path in the repository's trees (``folder`` may be a
        folder inside the working tree, or ``.git``), and where it sits in the working tree
        (None: a bare repository)."""
        inside = f"{self.prefix}{subdir}".strip("/")
        if self.worktree is None:
            return inside, None
        return inside, self.worktree / subdir if subdir else self.worktree

    def commit(self, ref: str) -> str:
        """The id of the commit ``ref`` names."""
        if ref.startswith("-"):
            raise GitError(f"{self.folder}: {ref!r} is not a revision")
        try:
            return self._git(
                "rev-parse", "--verify", "--quiet", "--end-of-options", f"{ref}^{{commit}}"
            ).strip()
        except GitError:
            raise GitError(f"{self.folder}: no commit named {ref!r}") from None

    def unborn(self) -> bool:
        """Whether HEAD names a branch that has no commit yet (a repository's first commit)."""
        try:
            self._git("symbolic-ref", "--quiet", "HEAD")
        except GitError:
            return False  # a detached HEAD always points at a commit
        try:
            self._git("rev-parse", "--verify", "--quiet", "HEAD")
        except GitError:
            return True
        return False

    def history(self, ref: str) -> list[str]:
        """Every commit reachable from ``ref``, each after its parents (oldest first)."""
        commit = self.commit(ref)
        return self._git("rev-list", "--topo-order", "--reverse", commit).split()

    def files(self, commit: str, subdir: str = "", missing_ok: bool = False) -> dict[str, str]:
        """``{path relative to subdir: blob id}`` of every file under ``subdir`` at ``commit``
        (empty when the commit has no such folder, or with ``missing_ok`` something else)."""
        found = self._object(f"{commit}:{subdir.strip('/')}" if subdir else f"{commit}^{{tree}}")
        if found is None:
            return {}
        kind, tree_id, _ = found
        if kind != "tree" and missing_ok:
            return {}
        if kind != "tree":
            raise GitError(f"{self.folder}: {subdir!r} at {commit[:12]} is not a folder")
        files = self._tree(tree_id)
        if any(blob.startswith(_LINK) for blob in files.values()):
            files = self._follow(commit, subdir.strip("/"), files)
        return files

    def _follow(self, commit: str, subdir: str, files: dict[str, str]) -> dict[str, str]:
        """``files`` with each symlink replaced by the blob it points to in the same commit;
        a link leaving the repository, or to nothing, is left out (as a checkout's would
        dangle)."""
        followed = {}
        for path, blob in files.items():
            if not blob.startswith(_LINK):
                followed[path] = blob
                continue
            link = self.read(blob.removeprefix(_LINK)).decode("utf-8", "surrogateescape")
            here = posixpath.dirname(posixpath.join(subdir, path))
            target = posixpath.normpath(posixpath.join(here, link))
            if link.startswith("/") or target.startswith("../") or target == "..":
                continue
            found = self._object(f"{commit}:{target}")
            if found is not None and found[0] == "blob":
                followed[path] = found[1]
                self._blobs.setdefault(found[1], found[2])
        return followed

    def read(self, blob: str) -> bytes:
        """A blob's bytes."""
        data = self._blobs.get(blob)
        if data is None:
            found = self._object(blob)
            if found is None:
                raise GitError(f"{self.folder}: no object {blob}")
            data = self._blobs[blob] = found[2]
        return data

    def _tree(self, tree_id: str) -> dict[str, str]:
        files = self._trees.get(tree_id)
        if files is not None:
            return files
        found = self._object(tree_id)
        if found is None:
            raise GitError(f"{self.folder}: no tree {tree_id}")
        files = {}
        data, width, at = found[2], len(tree_id) // 2, 0
        while at < len(data):
            space = data.index(b" ", at)
            nul = data.index(b"\0", space)
            mode, name = data[at:space], data[space + 1 : nul].decode("utf-8", "surrogateescape")
            entry = data[nul + 1 : nul + 1 + width].hex()
            at = nul + 1 + width
            if mode == b"40000":
                for path, blob in self._tree(entry).items():
                    files[f"{name}/{path}"] = blob
            elif mode in (b"100644", b"100755"):
                files[name] = entry
            elif mode == b"120000":  # a symlink: resolved against a commit by files()
                files[name] = _LINK + entry
        self._trees[tree_id] = files
        return files

    def _object(self, name: str) -> tuple[str, str, bytes] | None:
        """``(type, id, content)`` of the object ``name`` names, ``None`` if there is none."""
        if "\n" in name:
            raise GitError(f"{self.folder}: {name!r} is not an object name")
        batch = self._process()
        assert batch.stdin is not None
        assert batch.stdout is not None
        batch.stdin.write(name.encode() + b"\n")
        batch.stdin.flush()
        header = batch.stdout.readline()
        if not header:
            raise GitError(f"{self.folder}: git cat-file stopped")
        fields = header.split()
        if len(fields) != 3 or fields[1] == b"missing":
            return None
        size = int(fields[2])
        content = _read_exactly(batch.stdout, size + 1)[:-1]  # the object, then a newline
        return fields[1].decode(), fields[0].decode(), content

    def _process(self) -> "subprocess.Popen[bytes]":
        if self._batch is None:
            import subprocess

            self._batch = subprocess.Popen(
                ["git", "--git-dir", str(self.git_dir), "cat-file", "--batch"],
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=subprocess.DEVNULL,
            )
        return self._batch

    def _git(self, *args: str) -> str:
        import subprocess

        try:
            done = subprocess.run(
                ["git", "-C", str(self.folder), *args],
                capture_output=True,
                text=True,
                check=False,
            )
        except FileNotFoundError:
            raise GitError("git is not installed (it reads GITDIR#ref=… inputs)") from None
        if done.returncode != 0:
            reason = done.stderr.strip().splitlines()
            raise GitError(f"{self.folder}: {reason[-1] if reason else 'not a git repository'}")
        return done.stdout


def _read_exactly(stream: IO[bytes], size: int) -> bytes:
    chunks = []
    while size > 0:
        chunk = stream.read(size)
        if not chunk:
            raise GitError("git cat-file stopped in the middle of an object")
        chunks.append(chunk)
        size -= len(chunk)
    return b"".join(chunks)
