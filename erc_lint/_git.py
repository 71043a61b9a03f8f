"""A git repository's objects, read the way ``git`` stores them: no checkout, no working tree.

Guarantees:
- Nothing in the repository changes: every read goes through one long-lived
  ``git cat-file --batch`` process, which only reads objects.
- A tree object is parsed once, whatever the number of commits that share it, and a blob is read
  once, whatever the number of revisions that hold it: walking a history costs what changed in
  it, not its length times its size.
- Refs are resolved by git itself (``main``, ``origin/main``, ``HEAD~3``, a tag, an object id).
"""

import subprocess
from collections.abc import Iterator
from pathlib import Path
from typing import IO

__all__ = ["GitError", "Repository"]


class GitError(Exception):
    """The repository or an object in it cannot be read."""


class Repository:
    """The objects of the repository holding ``folder`` (a working tree, ``.git`` or bare repo)."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self.git_dir = Path(self._git("rev-parse", "--absolute-git-dir").strip())
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
            self._batch.stdin.close()
            self._batch.wait()
            self._batch = None

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

    def history(self, ref: str) -> list[str]:
        """Every commit reachable from ``ref``, each after its parents (oldest first)."""
        commit = self.commit(ref)
        return self._git("rev-list", "--topo-order", "--reverse", commit).split()

    def files(self, commit: str, subdir: str = "") -> dict[str, str]:
        """``{path relative to subdir: blob id}`` of every file under ``subdir`` at ``commit``
        (empty when the commit has no such folder)."""
        found = self._object(f"{commit}:{subdir.strip('/')}" if subdir else f"{commit}^{{tree}}")
        if found is None:
            return {}
        kind, tree_id, _ = found
        if kind != "tree":
            raise GitError(f"{self.folder}: {subdir!r} at {commit[:12]} is not a folder")
        return self._tree(tree_id)

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
            elif mode in (b"100644", b"100755"):  # symlinks and submodules hold no protos
                files[name] = entry
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
            self._batch = subprocess.Popen(
                ["git", "--git-dir", str(self.git_dir), "cat-file", "--batch"],
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=subprocess.DEVNULL,
            )
        return self._batch

    def _git(self, *args: str) -> str:
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


def walk(files: dict[str, str], suffixes: tuple[str, ...]) -> Iterator[tuple[str, str]]:
    """The ``(path, blob)`` entries whose names end with one of ``suffixes``, sorted."""
    for path in sorted(files):
        if path.endswith(suffixes):
            yield path, files[path]
