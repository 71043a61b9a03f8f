"""A git repository's objects, read the way ``git`` stores them: no checkout, no working tree.

Guarantees:
- Nothing in the repository changes: every read goes through one long-lived
  ``git cat-file --batch`` process, which only reads objects.
- Objects are not trusted: fetching runs no fsck, so a pull request's revision may hold objects
  no git command writes. Every entry of every tree read is one file name (not empty, no ``/``,
  not ``.`` or ``..``, not ``.git`` in any spelling git's fsck refuses: any case, the trailing
  dots and spaces NTFS drops, the invisible code points HFS+ ignores) and appears once in its
  tree; anything else, or a tree that does not parse, is a ``GitError`` naming the entry and the
  tree. A path made of entries therefore never leaves the folder it is joined to. A file listed
  whose path holds a control character, or a ``.proto`` at the top beginning with ``-`` or
  ``@``, refuses the listing: protoc would misread it (``compile_files`` refuses it too).
- Symlinks are resolved in the commit's own trees, never on a file system: one leaving the
  repository, dangling, or going through more than 40 links (Linux's limit) is left out, as a
  checkout's would dangle. Each link's end is found once per folder in a listing (a chain
  many links share is walked once), and a listing walking more than ``MAX_LINK_STEPS`` parts
  of link targets in all is refused.
- Bounded: an object over its size limit is refused from its header, before it is read (a
  tree or a ``.proto`` 16 MiB, a symlink 4 KiB); a tree holding more than ``MAX_FILES``
  ``.proto`` and ``.options`` files (a few small trees can nest to billions of paths), one
  more than ``MAX_DEPTH`` folders deep, or one whose paths of those files add up to more than
  ``MAX_PATH_TEXT`` characters, is refused before a path is made: each tree is measured once,
  to three numbers, without recursion. A listing's memory is its result's, whatever the trees
  share.
- A tree object is parsed and measured once, whatever the number of commits that share it:
  walking a history parses what changed in it, not its length times its size.
- Refs are resolved by git itself (``main``, ``origin/main``, ``HEAD~3``, a tag, an object id).

``subprocess`` is imported when a repository is opened: a caller that reads only folders never
loads it.
"""

import os
from collections.abc import Collection, Generator
from pathlib import Path
from typing import IO, TYPE_CHECKING

from ._errors import SchemaError
from ._files import SOURCE_LIMIT, has_control, size_text

if TYPE_CHECKING:
    import subprocess

__all__ = [
    "MAX_DEPTH",
    "MAX_FILES",
    "MAX_LINK_STEPS",
    "MAX_PATH_TEXT",
    "SUFFIXES",
    "GitError",
    "Repository",
]

SUFFIXES = (".proto", ".options")  # the files of a proto tree
MAX_FILES = 100_000  # of SUFFIXES in one tree
MAX_DEPTH = 256  # folders above a file of SUFFIXES in a tree
MAX_PATH_TEXT = 16 * 1024 * 1024  # characters of those files' paths, added up
MAX_LINK_STEPS = 1_000_000  # parts of symlink targets walked in one listing of a tree

_LINK_LIMIT = 4096  # PATH_MAX: a longer link's target is no path
_MAX_LINKS = 40
# Code points HFS+ ignores in file names, so that ".g\u200cit" is ".git" there (git's utf8.c).
_HFS_IGNORED = dict.fromkeys(map(ord, "\u200c\u200d\u200e\u200f\u202a\u202b\u202c\u202d\u202e"))
_HFS_IGNORED.update(dict.fromkeys(map(ord, "\u206a\u206b\u206c\u206d\u206e\u206f\ufeff")))

_Entry = tuple[str, str]  # (kind: "tree", "file", "link" or "gitlink"; object id)
# Where a symlink leads: a file's blob, a folder (the folders from the root to it), or nowhere.
_Target = str | tuple[str, ...] | None
_Link = tuple[tuple[str, ...], str]  # a symlink: the folders from the root to its own, its blob
# A walk down a link's target: yields each link it meets, is sent where that leads and through
# how many links, returns where its own link leads and through how many.
# (Sent None first, as a generator starts.)
_Walk = Generator[_Link, tuple[_Target, int] | None, tuple[_Target, int]]


class GitError(SchemaError):
    """A repository, or an object in it, cannot be read, or holds what git never writes."""


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
        self._trees: dict[str, dict[str, _Entry]] = {}  # tree id → its entries by name
        # tree id → SUFFIXES files below it, their paths' characters, their deepest folder
        self._sizes: dict[str, tuple[int, int, int]] = {}

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

    def files(
        self, commit: str, subdir: str = "", missing_ok: bool = False, top: Collection[str] = ()
    ) -> dict[str, str]:
        """``{path relative to subdir: blob id}`` of every ``.proto`` and ``.options`` file
        under ``subdir`` at ``commit``, and of each file ``top`` names directly in ``subdir``;
        a symlink stands for the file it points to. Empty when the commit has no such folder
        (or, with ``missing_ok``, something else there)."""
        here = [self._root(commit)]
        for part in subdir.strip("/").split("/") if subdir.strip("/") else []:
            entry = self._entries(here[-1]).get(part)
            if entry is None:
                return {}
            if entry[0] != "tree" and missing_ok:
                return {}
            if entry[0] != "tree":
                raise GitError(f"{self.folder}: {subdir!r} at {commit[:12]} is not a folder")
            here.append(entry[1])
        self._measure(here[-1])
        entries = self._entries(here[-1])
        found = [(name, tuple(here), entries[name]) for name in top if name in entries]
        found += self._walk_tree(here)
        files: dict[str, str] = {}
        links: dict[_Link, tuple[_Target, int]] = {}
        steps = _Steps(f"{self.folder}: symlinks take more than {MAX_LINK_STEPS} steps to resolve")
        for path, folders, (kind, blob) in found:
            _check_name(path, f"{self.folder}: {commit[:12]}")
            if kind == "link":
                target = self._resolve(folders, blob, links, steps)
                if isinstance(target, str):
                    files[path] = target
            elif kind == "file":
                files[path] = blob
        return files

    def read(self, blob: str, limit: int = SOURCE_LIMIT, name: str = "") -> bytes:
        """A blob's bytes; one over ``limit`` is refused unread (``name``: the file it is, to
        name in errors)."""
        shown = name or f"{self.folder}: object {blob}"
        found = self._object(blob, limit, shown)
        if found is None:
            raise GitError(f"{shown}: no such object ({blob})")
        if found[0] != "blob":
            raise GitError(f"{shown}: a {found[0]}, not a file")
        return found[2]

    def _root(self, commit: str) -> str:
        """The id of a commit's tree (its object's first line)."""
        found = self._object(commit, SOURCE_LIMIT, f"{self.folder}: commit {commit}")
        if found is None or found[0] != "commit" or not found[2].startswith(b"tree "):
            raise GitError(f"{self.folder}: {commit} is not a commit")
        return found[2].split(b"\n", 1)[0][5:].decode("ascii", "replace")

    def _entries(self, tree_id: str) -> dict[str, _Entry]:
        """A tree's entries by name, each name checked (see the module's guarantees)."""
        entries = self._trees.get(tree_id)
        if entries is not None:
            return entries
        found = self._object(tree_id, SOURCE_LIMIT, f"{self.folder}: tree {tree_id}")
        if found is None:
            raise GitError(f"{self.folder}: no tree {tree_id}")
        if found[0] != "tree":
            raise GitError(f"{self.folder}: {tree_id} is a {found[0]}, not a tree")
        entries = {}
        data, width, at = found[2], len(tree_id) // 2, 0
        while at < len(data):
            space, nul = data.find(b" ", at), data.find(b"\0", at)
            if not at < space < nul or nul + 1 + width > len(data):
                raise GitError(f"{self.folder}: tree {tree_id} is corrupt at byte {at}")
            mode, raw = data[at:space], data[space + 1 : nul]
            name = raw.decode("utf-8", "surrogateescape")
            kind = _kind(mode)
            if kind is None:
                raise GitError(
                    f"{self.folder}: tree {tree_id} gives {name!r} the mode "
                    f"{mode.decode('ascii', 'replace')!r}, which "
                    "git never writes: refused"
                )
            if not _single_name(name):
                raise GitError(
                    f"{self.folder}: tree {tree_id} holds an entry named {name!r}, which is "
                    "not one file name: refused (git never writes such a tree)"
                )
            if name in entries:
                raise GitError(f"{self.folder}: tree {tree_id} holds {name!r} twice: refused")
            entries[name] = (kind, data[nul + 1 : nul + 1 + width].hex())
            at = nul + 1 + width
        self._trees[tree_id] = entries
        return entries

    def _measure(self, tree_id: str) -> None:
        """Refuse a tree holding more than MAX_FILES SUFFIXES files, more than MAX_PATH_TEXT
        characters of their paths in all, or any of them more than MAX_DEPTH folders deep; each
        tree below is measured once (depth first, without recursion: git lets trees nest
        thousands deep), to three numbers, before a single path is made."""
        sizes = self._sizes
        pending = [tree_id]
        while pending:
            current = pending[-1]
            if current in sizes:
                pending.pop()
                continue
            entries = self._entries(current)
            below = [
                blob for kind, blob in entries.values() if kind == "tree" and blob not in sizes
            ]
            if below:
                pending.extend(below)
                continue
            pending.pop()
            files = text = depth = 0
            for name, (kind, blob) in entries.items():
                if kind == "tree" and sizes[blob][0]:
                    inner, inner_text, inner_depth = sizes[blob]
                    files += inner
                    text += inner_text + inner * (len(name) + 1)
                    depth = max(depth, inner_depth + 1)
                elif kind in ("file", "link") and name.endswith(SUFFIXES):
                    files += 1
                    text += len(name)
            # capped: the numbers of a tree stay small, however many paths it nests to
            sizes[current] = (
                min(files, MAX_FILES + 1),
                min(text, MAX_PATH_TEXT + 1),
                min(depth, MAX_DEPTH + 1),
            )
        files, text, depth = sizes[tree_id]
        if files > MAX_FILES:
            raise GitError(
                f"{self.folder}: tree {tree_id} holds more than {MAX_FILES} .proto and .options "
                "files: refused"
            )
        if depth > MAX_DEPTH:
            raise GitError(
                f"{self.folder}: tree {tree_id} nests files more than {MAX_DEPTH} folders "
                "deep: refused"
            )
        if text > MAX_PATH_TEXT:
            raise GitError(
                f"{self.folder}: the paths of tree {tree_id}'s .proto and .options files add up "
                f"to more than {size_text(MAX_PATH_TEXT)}: refused"
            )

    def _walk_tree(self, here: list[str]) -> list[tuple[str, tuple[str, ...], _Entry]]:
        """The SUFFIXES files and links below the measured tree ``here[-1]`` (``here``: the
        folders from the root to it): each path with the folders from the root to its own
        folder, in the order of the entries (folders skipped that hold none)."""
        found = []
        folders = list(here)
        prefixes = [""]
        stack = [iter(self._entries(here[-1]).items())]
        while stack:
            for name, (kind, blob) in stack[-1]:
                if kind == "tree" and self._sizes[blob][0]:
                    folders.append(blob)
                    prefixes.append(f"{prefixes[-1]}{name}/")
                    stack.append(iter(self._entries(blob).items()))
                    break
                if kind in ("file", "link") and name.endswith(SUFFIXES):
                    found.append((f"{prefixes[-1]}{name}", tuple(folders), (kind, blob)))
            else:
                stack.pop()
                folders.pop()
                prefixes.pop()
        return found

    def _resolve(
        self,
        folders: tuple[str, ...],
        link: str,
        links: dict[_Link, tuple[_Target, int]],
        steps: "_Steps",
    ) -> _Target:
        """Where the symlink ``link`` in the folder ``folders[-1]`` (``folders``: those from
        the root to it) leads, followed the way Linux does: the blob of a file, the folders to
        a folder, or None (it leaves the repository, dangles, or passes more than 40 links).

        ``links`` remembers each link's end, by folder, with the links passed on the way, for
        the rest of the call: a chain many links share is walked once. A link met again while
        it is being resolved is a loop. Links are resolved on a stack of walks, not by
        recursion: a chain may be long before its 41st link is known to be too many."""
        stack: list[tuple[_Link, _Walk]] = []
        request: _Link | None = (folders, link)
        answer: tuple[_Target, int] | None = None
        while True:
            if request is not None:
                answer = links.get(request)
                if answer is None:
                    links[request] = (None, 0)  # while it is resolved: a loop, if met
                    parts = self._link_parts(request[1])
                    if parts is None:
                        answer = links[request] = (None, 0)
                    else:
                        stack.append((request, self._walk_link(list(request[0]), parts, steps)))
                if answer is not None and not stack:
                    return answer[0]
                request = None
            key, walk = stack[-1]
            try:
                request = walk.send(answer)
                answer = None
            except StopIteration as done:
                stack.pop()
                result: tuple[_Target, int] = done.value
                answer = links[key] = result
                if not stack:
                    return result[0]

    def _walk_link(self, folders: list[str], pending: list[str], steps: "_Steps") -> _Walk:
        """Walk a link's target (``pending``: its parts, last first) from ``folders``; yield
        each link met on the way (its folders and blob), to be sent back where it leads and
        through how many links; return where this link leads and through how many links,
        itself included ((None, 0): nowhere)."""
        hops = 1
        while pending:
            steps.take()
            part = pending.pop()
            if part in ("", "."):
                continue
            if part == "..":
                if len(folders) == 1:
                    return None, 0  # out of the repository
                folders.pop()
                continue
            entry = self._entries(folders[-1]).get(part)
            if entry is None:
                return None, 0
            kind, blob = entry
            if kind == "tree":
                folders.append(blob)
                continue
            if kind != "link":  # a file ("file/" is none), or a submodule
                return (blob if kind == "file" and not pending else None), hops
            answer = yield tuple(folders), blob
            assert answer is not None
            target, passed = answer
            hops += passed
            if target is None or hops > _MAX_LINKS:
                return None, 0
            if isinstance(target, str):
                return (None if pending else target), hops
            folders = list(target)
        return tuple(folders), hops  # a folder

    def _link_parts(self, link: str) -> list[str] | None:
        """A symlink's target as path parts, last first; None when it leaves any repository
        (absolute) or is no path at all (empty, or a NUL in it)."""
        target = self.read(link, _LINK_LIMIT, f"{self.folder}: symlink {link}")
        if not target or target.startswith(b"/") or b"\0" in target:
            return None
        return target.decode("utf-8", "surrogateescape").split("/")[::-1]

    def _object(
        self,
        name: str,
        limit: int,
        shown: str,
    ) -> tuple[str, str, bytes] | None:
        """``(type, id, content)`` of the object ``name`` names, ``None`` if there is none;
        content over ``limit`` bytes is never read, but refused (``shown`` names the object,
        its repository too)."""
        if "\n" in name or "\0" in name:
            raise GitError(f"{self.folder}: {name!r} is not an object name")
        batch = self._process()
        assert batch.stdin is not None
        assert batch.stdout is not None
        batch.stdin.write(name.encode("utf-8", "surrogateescape") + b"\n")
        batch.stdin.flush()
        header = batch.stdout.readline()
        if not header:
            raise GitError(f"{self.folder}: git cat-file stopped")
        if header.endswith((b" missing\n", b" ambiguous\n")):  # the name may hold spaces
            return None
        fields = header.split()
        if len(fields) != 3 or not fields[2].isdigit():
            raise GitError(f"{self.folder}: git cat-file answered {header!r}")
        kind, found, size = fields[1].decode(), fields[0].decode(), int(fields[2])
        if size > limit:
            self._drop()  # the content is never read: a new process serves the next object
            raise GitError(f"{shown}: {size} bytes, over the limit of {size_text(limit)}: refused")
        content = _read_exactly(batch.stdout, size + 1)[:-1]  # the object, then a newline
        return kind, found, content

    def _drop(self) -> None:
        """End the batch process in the middle of an answer."""
        if self._batch is not None:
            self._batch.kill()
            self.close()

    def _process(self) -> "subprocess.Popen[bytes]":
        if self._batch is None:
            import subprocess

            try:
                self._batch = subprocess.Popen(
                    ["git", "--git-dir", str(self.git_dir), "cat-file", "--batch"],
                    stdin=subprocess.PIPE,
                    stdout=subprocess.PIPE,
                    stderr=subprocess.DEVNULL,
                )
            except OSError as error:
                raise GitError(f"git cannot run: {error.strerror}") from None
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


def _check_name(path: str, where: str) -> None:
    """Refuse a file name protoc would misread: one with a control character (protoc prints
    names raw, so a newline in one splits its diagnostics into findings of their own), or a
    ``.proto`` at the top beginning with ``-`` or ``@`` (protoc would take it for an option).
    git's fsck allows them; no tree that builds holds one."""
    if has_control(path):
        what = "a control character"
    elif path.endswith(".proto") and path.startswith(("-", "@")):
        what = f"a leading {path[0]!r}"
    else:
        return
    raise GitError(
        f"{where} holds {path!r}, a file name with {what}, which protoc would misread: refused"
    )


class _Steps:
    """A budget of steps, taken one at a time; the last one over it is a ``GitError``."""

    def __init__(self, refusal: str) -> None:
        self.left = MAX_LINK_STEPS
        self.refusal = refusal

    def take(self) -> None:
        self.left -= 1
        if self.left < 0:
            raise GitError(f"{self.refusal}: refused")


def _kind(mode: bytes) -> str | None:
    """What a tree entry's mode makes it, as a checkout reads modes (any regular file's
    permissions are a file's; git wrote 100664 once); None for a mode git never writes."""
    if not mode or any(digit not in b"01234567" for digit in mode):
        return None
    kind = int(mode, 8) & 0o170000
    return {0o040000: "tree", 0o100000: "file", 0o120000: "link", 0o160000: "gitlink"}.get(kind)


def _single_name(name: str) -> bool:
    """Whether a tree entry's name is one file name that is not ``.git`` anywhere (git's fsck
    rules: ``has_dot``, ``has_dotdot``, ``has_full_path``, ``has_empty_name``, ``has_dotgit``
    with the HFS+ and NTFS spellings of ``.git``)."""
    if name in ("", ".", "..") or "/" in name:
        return False
    folded = name.translate(_HFS_IGNORED).lower().split(":", 1)[0].rstrip(" .")
    return folded not in (".git", "git~1")


def _read_exactly(stream: IO[bytes], size: int) -> bytes:
    chunks = []
    while size > 0:
        chunk = stream.read(size)
        if not chunk:
            raise GitError("git cat-file stopped in the middle of an object")
        chunks.append(chunk)
        size -= len(chunk)
    return b"".join(chunks)
