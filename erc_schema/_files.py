"""A tree's files read without trusting them: only regular files, never more than a limit.

Guarantees:
- ``read_file`` reads a regular file and nothing else: a FIFO (which would block for ever), a
  device (``/dev/zero`` never ends; opening some, a watchdog or a tape, acts on the hardware), a
  socket or a directory is refused before it is opened, and again by ``fstat`` on the descriptor
  it opened (``O_NONBLOCK``, so not even a FIFO swapped in between can block the open): what is
  read is what was checked. It reads at most ``limit + 1`` bytes; a longer file is refused.
- Every refusal is a ``FileError`` naming the file and why, in one line.
- ``proto_files`` lists a folder's ``*.proto`` files without entering a symlinked folder: no
  folder outside the tree is walked, and a symlink cycle is never followed, on every Python.

The limits: ``SOURCE_LIMIT`` (16 MiB) for a ``.proto`` or ``.options`` file; a caller passes its
own for any other file. The largest file of the rover's tree is some 4 KiB.
"""

import os
import re
import stat
from pathlib import Path

from ._errors import SchemaError

__all__ = [
    "SOURCE_LIMIT",
    "FileError",
    "file_exists",
    "has_control",
    "proto_files",
    "read_file",
    "read_text",
    "shown",
    "size_text",
]

SOURCE_LIMIT = 16 * 1024 * 1024

_CONTROL = re.compile("[\x00-\x1f\x7f-\x9f]")  # Unicode's control characters (Cc)
_KINDS = {
    stat.S_IFIFO: "a FIFO",
    stat.S_IFCHR: "a character device",
    stat.S_IFBLK: "a block device",
    stat.S_IFSOCK: "a socket",
    stat.S_IFDIR: "a directory",
}


class FileError(SchemaError):
    """A file that cannot be read, or is refused (not a regular file, or over a size limit):
    ``path`` is the file, ``reason`` why."""

    def __init__(self, path: str | os.PathLike[str], reason: str) -> None:
        super().__init__(f"{os.fspath(path)}: {reason}")
        self.path = os.fspath(path)
        self.reason = reason


def read_file(path: str | os.PathLike[str], limit: int = SOURCE_LIMIT) -> bytes:
    """The bytes of the regular file ``path`` (symlinks followed), at most ``limit`` of them."""
    try:
        _check(path, os.stat(path), limit)  # a device is never opened: opening one may act
        handle = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_NOCTTY | os.O_CLOEXEC)
    except OSError as error:
        raise FileError(path, f"cannot read: {error.strerror}") from None
    try:
        found = os.fstat(handle)
        _check(path, found, limit)
        # As much as fstat said, and one byte more to see whether it grew; never limit + 1
        # bytes at once (a buffer that large for every small file).
        chunks = [os.read(handle, found.st_size + 1)]
        total = len(chunks[0])
        while found.st_size < total <= limit and chunks[-1]:  # it grew: read on to see how far
            chunks.append(os.read(handle, min(limit + 1 - total, 1 << 20)))
            total += len(chunks[-1])
    except OSError as error:
        raise FileError(path, f"cannot read: {error.strerror}") from None
    finally:
        os.close(handle)
    if total > limit:  # it grew after fstat
        raise FileError(path, f"larger than {size_text(limit)}, the limit for this file")
    return b"".join(chunks)


def file_exists(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` names something other than a folder, symlinks followed (one that
    dangles names nothing): a file to read, or one ``read_file`` refuses (a FIFO, a device)."""
    try:
        return not stat.S_ISDIR(os.stat(path).st_mode)
    except (OSError, ValueError):
        return False


def read_text(
    path: str | os.PathLike[str], limit: int = SOURCE_LIMIT, errors: str = "strict"
) -> str:
    """``read_file`` as UTF-8 text; with ``errors="strict"`` a file that is not UTF-8 is a
    ``FileError`` (``"replace"``: each bad byte becomes U+FFFD)."""
    data = read_file(path, limit)
    try:
        return data.decode("utf-8", errors)
    except UnicodeDecodeError as error:
        raise FileError(path, f"not UTF-8 text (byte {error.start})") from None


def _check(path: str | os.PathLike[str], found: os.stat_result, limit: int) -> None:
    kind = stat.S_IFMT(found.st_mode)
    if kind != stat.S_IFREG:
        raise FileError(path, f"not a regular file ({_KINDS.get(kind, 'of an unknown kind')})")
    if found.st_size > limit:
        raise FileError(path, f"larger than {size_text(limit)}, the limit for this file")


def size_text(limit: int) -> str:
    """A size as the limits are written: ``16 MiB``, ``4 KiB``, ``100 bytes``."""
    for unit, scale in (("MiB", 1 << 20), ("KiB", 1 << 10)):
        if limit >= scale and limit % scale == 0:
            return f"{limit // scale} {unit}"
    return f"{limit} bytes"


def proto_files(root: Path, suffix: str = ".proto") -> list[str]:
    """The ``*.proto`` files under ``root`` as paths relative to it (``a/b.proto``), sorted as
    their parts sort. Symlinked folders are not entered (what ``**`` does on every Python);
    a symlinked file counts, one that dangles does not; a FIFO or device named so is listed,
    for ``read_file`` to refuse rather than pass over in silence, and a folder inside that
    cannot be listed is a ``FileError``."""
    found: list[str] = []
    pending = [""] if os.path.isdir(root) else []  # no folder, no files (as ``**`` finds)
    while pending:
        prefix = pending.pop()
        try:
            entries = list(os.scandir(os.path.join(root, prefix) if prefix else root))
        except OSError as error:
            raise FileError(root / prefix, f"cannot list: {error.strerror}") from None
        for entry in entries:
            name = f"{prefix}{entry.name}"
            if entry.is_dir(follow_symlinks=False):
                pending.append(f"{name}/")
            elif entry.name.endswith(suffix) and _listed(entry):
                found.append(name)
    return sorted(found, key=lambda name: name.split("/"))


def _listed(entry: os.DirEntry[str]) -> bool:
    """Whether a file entry is one to read: not a symlink to a folder or to nothing."""
    if not entry.is_symlink():
        return True
    try:
        return not stat.S_ISDIR(os.stat(entry.path).st_mode)
    except OSError:  # it dangles, or loops
        return False


def has_control(name: str) -> bool:
    """Whether ``name`` holds a control character (U+0000-U+001F, U+007F-U+009F)."""
    return _CONTROL.search(name) is not None


def shown(name: str) -> str:
    """``name`` with each control character escaped as Python writes it (``\\n``, ``\\x1b``),
    so that printing it cannot move the cursor or start a line."""
    return _CONTROL.sub(lambda found: repr(found[0])[1:-1], name)
