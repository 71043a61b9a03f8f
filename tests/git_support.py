"""Git repositories for the tests: histories scripted commit by commit (``Repo``), and objects no
git command writes, made with git's own plumbing (``hash-object --literally``, ``commit-tree``,
``update-ref``), as a fetch hands them over unchecked (fetching runs no fsck)."""

import hashlib
import subprocess
import zlib
from collections.abc import Sequence
from pathlib import Path

HEADER = 'syntax = "proto3";\n'

Entry = tuple[str, bytes | str, str]  # (mode, name, object id)


class Repo:
    """A git repository the test writes history into, one commit at a time."""

    def __init__(self, root: Path) -> None:
        self.root = root
        root.mkdir(parents=True, exist_ok=True)
        self.git("init", "-q", "-b", "main")

    def git(self, *args: str, data: bytes | None = None) -> str:
        done = subprocess.run(
            ["git", "-c", "user.name=t", "-c", "user.email=t@t.invalid", *args],
            cwd=self.root,
            input=data,
            capture_output=True,
            check=True,
        )
        return done.stdout.decode().strip()

    def commit(self, message: str, **files: str | None) -> str:
        """Write (or, for None, delete) ``proto/<name>.proto`` files and commit; the id."""
        for name, text in files.items():
            path = self.root / "proto" / f"{name}.proto"
            if text is None:
                path.unlink()
            else:
                path.parent.mkdir(parents=True, exist_ok=True)
                path.write_text(HEADER + text)
        self.git("add", "-A")
        self.git("commit", "-q", "--allow-empty", "-m", message)
        return self.git("rev-parse", "HEAD")

    def spec(self, ref: str) -> str:
        return f"{self.root}#ref={ref},subdir=proto"

    def blob(self, data: bytes | str) -> str:
        """A blob of ``data``, written with ``git hash-object``; its id."""
        raw = data.encode() if isinstance(data, str) else data
        return self.git("hash-object", "-w", "--stdin", data=raw)

    def tree(self, entries: Sequence[Entry]) -> str:
        """A tree object of ``entries`` exactly as given (any name, mode, order or repetition),
        written with ``git hash-object -t tree --literally``; its id."""
        command = ("hash-object", "-w", "-t", "tree", "--literally", "--stdin")
        return self.git(*command, data=tree(entries))

    def branch(self, name: str, tree_id: str) -> str:
        """A commit of ``tree_id`` (``git commit-tree``) on branch ``name`` (``update-ref``)."""
        commit = self.git("commit-tree", tree_id, "-m", name)
        self.git("update-ref", f"refs/heads/{name}", commit)
        return commit


def tree(entries: Sequence[Entry]) -> bytes:
    """The bytes of a tree object: ``MODE NAME\\0`` and the binary id, per entry."""
    return b"".join(
        mode.encode()
        + b" "
        + (name.encode() if isinstance(name, str) else name)
        + b"\0"
        + bytes.fromhex(oid)
        for mode, name, oid in entries
    )


def loose(repo: Path, kind: str, data: bytes) -> str:
    """Write an object as git stores a loose one (what ``hash-object --literally`` does,
    without a process per object: the fuzz test writes hundreds); its id."""
    raw = f"{kind} {len(data)}\0".encode() + data
    oid = hashlib.sha1(raw).hexdigest()
    path = repo / ".git" / "objects" / oid[:2] / oid[2:]
    if not path.exists():
        path.parent.mkdir(exist_ok=True)
        path.write_bytes(zlib.compress(raw))
    return oid


def loose_commit(repo: Path, tree_id: str) -> str:
    """A commit of ``tree_id``, written as a loose object; its id."""
    who = "t <t@t.invalid> 0 +0000"
    return loose(repo, "commit", f"tree {tree_id}\nauthor {who}\ncommitter {who}\n\nx\n".encode())
