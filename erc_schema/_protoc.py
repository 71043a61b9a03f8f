"""protoc, run in-process through grpcio-tools, turning .proto files into a FileDescriptorSet.

Guarantees: no generated code is written anywhere; protoc's own diagnostics (``path:line:col:
message``) come back as the text of a ``SchemaError``. protoc reads whatever its search folders
hold under an imported name, so every file it will read from disk is found first as protoc finds
it and must be a regular file within ``SOURCE_LIMIT`` (a FIFO would block it for ever, a link to
``/dev/zero`` fill memory): ``read_file`` refuses anything else, naming it. Only erc-codec's own
include folders are taken on trust. protoc reports on the process's standard
error descriptor, so compilation briefly points fd 2 at a scratch file; a lock keeps two
compilations in this process from interleaving. Nothing a tree holds is read as one of protoc's
options: a file to compile whose name begins with ``-`` or ``@`` (protoc would take it for an
option or a response file: ``--plugin=...`` folders run a program) and a search folder protoc
would split (``:`` in it) are refused before protoc runs, as is any name with a
control character (protoc prints names raw: a newline in one splits its diagnostics into
findings of their own). Scratch files (protoc's output, its diagnostics,
descriptors it is given) are gone when the compilation ends, failed or not: in memory where the
system has anonymous memory files protoc can open by name (Linux's ``memfd_create``), else in a
temporary folder.
"""

import contextlib
import functools
import os
import re
import stat
import threading
from collections.abc import Iterable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import grpc_tools
from google.protobuf import descriptor_pb2

from ._errors import SchemaError
from ._files import FileError, has_control, read_text, shown
from ._text import imports as imported

if TYPE_CHECKING:
    import tempfile

try:
    # protoc's own entry point, which grpc_tools.protoc.main calls with the arguments encoded;
    # called directly, so importing this module does not import importlib.resources too.
    from grpc_tools._protoc_compiler import run_main as _run_main
except ImportError:  # pragma: no cover - a grpcio-tools that moved it: its public wrapper
    from grpc_tools import protoc as _wrapper

    def _run_main(args: list[bytes]) -> int:
        return int(_wrapper.main([arg.decode() for arg in args]))


__all__ = ["ProtocError", "compile_files"]

_LOCK = threading.Lock()
# protoc's warnings go through absl logging: a notice that logging is not set up, then lines
# prefixed with severity, time, thread and source (``W0000 00:00:1795.2   10577 parser.cc:659] ``).
_LOG_NOTICE = (
    "WARNING: All log messages before absl::InitializeLog() is called are written to STDERR"
)
# Read only when protoc refused: compiled on first use (re caches it).
_LOG_PREFIX = r"[IWEF]\d{4} [\d:.]+ +\d+ [\w.]+:\d+\] "
# google/protobuf/*.proto, shipped with grpcio-tools.
_WELL_KNOWN = str(Path(grpc_tools.__file__).parent / "_proto")
# A nanopb.proto of our own, used only when a tree imports "nanopb.proto" without shipping it.
FALLBACK_INCLUDE = str(Path(__file__).parent / "_include")


class ProtocError(SchemaError):
    """protoc refused to compile; ``lines`` holds its diagnostics, ``path:line:col: message``."""

    def __init__(self, lines: list[str]) -> None:
        super().__init__("; ".join(lines))
        self.lines = lines


def compile_files(
    root: Path,
    files: Sequence[str],
    includes: Sequence[Path] = (),
    known: descriptor_pb2.FileDescriptorSet | None = None,
    locations: bool = True,
    defaults: bool = True,
    imports: bool = True,
    read: Mapping[str, Iterable[str]] | None = None,
    retain_options: bool = False,
) -> descriptor_pb2.FileDescriptorSet:
    """Compile ``files`` (paths relative to ``root``) with their imports and, unless told
    otherwise, source locations.

    ``includes`` are further import roots, searched after ``root``; imports that ``known``
    (compiled before) holds are taken from it and not parsed again. protoc prefers files it can
    parse to known ones, so when ``known`` has its own copy of a well-known file or of
    nanopb.proto, ours come as known files too, after the caller's (which win). The result
    lists every file once, each after the files it imports (``imports=False``: ``files``
    alone). ``defaults=False`` leaves our well-known files and nanopb.proto out altogether:
    ``known`` holds what the files import. ``retain_options`` keeps the options protoc strips
    from its output by default, those of source retention (an extension range's
    ``declaration``s among them).

    Every file protoc will read from disk is read first, where protoc will find it, and must
    be a regular file within ``SOURCE_LIMIT`` (else ``FileError``); ``read`` spares that for
    files under ``root`` the caller has read with ``read_file`` itself: their names, each with
    the import spellings protoc will find in it.

    A name protoc would read as something else (see the module's guarantees) is a
    ``FileError`` naming it.
    """
    search = [str(root), *map(str, includes)]
    for name in files:
        if name.startswith(("-", "@")):
            # protoc has no end of options: "-I.proto" is an include folder, "@x" a response
            # file, "--plugin=protoc-gen-e=x/evil.proto" a program to run. nanopb's generator
            # reads such names as options too; no tree that builds holds one.
            raise FileError(
                os.path.join(root, name),
                f"a file name beginning with {name[0]!r}, which protoc reads as an option: refused",
            )
    for folder in search:
        if ":" in folder:  # protoc splits --proto_path=a:b into two folders, whatever we do
            raise FileError(
                folder, "a folder name holding ':', which protoc reads as a separator: refused"
            )
    if defaults and known is not None and {file.name for file in known.file} & _default_names():
        known = descriptor_pb2.FileDescriptorSet(file=[*known.file, *_defaults().file])
    elif defaults:
        search += [_WELL_KNOWN, FALLBACK_INCLUDE]
    _vet(search, files, read or {})
    with _LOCK, _Scratch() as scratch:  # one compilation at a time, scratch files and all
        _standard_descriptors_open()
        out, out_path = scratch.file("set.pb")
        args = [
            "protoc",
            # "=folder": the folder under the empty virtual path, so that protoc never splits
            # a name holding "=" into a virtual path and another folder ("v=d").
            *(f"--proto_path=={path}" for path in search),
            f"--descriptor_set_out={out_path}",
            *(["--include_imports"] if imports else []),
            *(["--include_source_info"] if locations else []),
            *(["--retain_options"] if retain_options else []),
            *files,
        ]
        if known is not None:
            _, given = scratch.file("known.pb", known.SerializeToString())
            args.insert(1, f"--descriptor_set_in={given}")
        errors, _ = scratch.file("stderr.txt")
        with _stderr_to(errors):
            status = _run_main([arg.encode() for arg in args])
        if status != 0:
            text = _read_all(errors).decode(errors="replace")
            lines = [re.sub(_LOG_PREFIX, "", line, count=1) for line in text.splitlines()]
            lines = [line for line in lines if line and line != _LOG_NOTICE]
            raise ProtocError(lines or [f"protoc exited with status {status}"])
        return descriptor_pb2.FileDescriptorSet.FromString(_read_all(out))


class _Scratch:
    """The scratch files of one compilation, each an open descriptor and a name protoc opens it
    by; every descriptor is closed, and the folder (if any) removed, when the block ends.

    In memory where the system allows it (``_memory_files``): no folder is made and removed on
    disk for each compilation. Else in a temporary folder; the tests compile the same trees both
    ways and compare the results byte for byte."""

    def __init__(self) -> None:
        self.in_memory = _memory_files()
        self.descriptors: list[int] = []
        self.folder: tempfile.TemporaryDirectory[str] | None = None

    def __enter__(self) -> "_Scratch":
        return self

    def __exit__(self, *exc: object) -> None:
        for descriptor in self.descriptors:
            os.close(descriptor)
        if self.folder is not None:
            self.folder.cleanup()

    def file(self, name: str, data: bytes = b"") -> tuple[int, str]:
        """A new scratch file holding ``data``: its descriptor (read and write) and its name."""
        if self.in_memory:
            descriptor = os.memfd_create(name)
            self.descriptors.append(descriptor)
            path = _memory_path(descriptor)
        else:
            if self.folder is None:
                # Imported here: with memory files, a compilation never needs tempfile (nor
                # the shutil, random, bz2 and lzma it imports).
                import tempfile

                self.folder = tempfile.TemporaryDirectory(prefix="erc-codec-")
            path = os.path.join(self.folder.name, name)
            flags = os.O_RDWR | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0)
            descriptor = os.open(path, flags, 0o600)
            self.descriptors.append(descriptor)
        view = memoryview(data)
        while view:
            view = view[os.write(descriptor, view) :]
        return descriptor, path


def _memory_files() -> bool:
    """Whether protoc's scratch files can live in memory: ``os.memfd_create`` exists and a memory
    file opened again by its ``/proc/self/fd`` name, truncating, as protoc opens its output, is
    the same file (tried once a process)."""
    return hasattr(os, "memfd_create") and _memory_files_work()


@functools.cache
def _memory_files_work() -> bool:
    try:
        probe = os.memfd_create("probe")
    except OSError:
        return False
    try:
        os.write(probe, b"old")
        again = os.open(_memory_path(probe), os.O_WRONLY | os.O_TRUNC)
        try:
            os.write(again, b"x")
        finally:
            os.close(again)
        return os.fstat(probe).st_size == 1 and os.pread(probe, 8, 0) == b"x"
    except OSError:
        return False
    finally:
        os.close(probe)


def _memory_path(descriptor: int) -> str:
    return f"/proc/self/fd/{descriptor}"


def _read_all(descriptor: int) -> bytes:
    """The whole content of a scratch file, from its start."""
    size = os.fstat(descriptor).st_size
    parts, at = [], 0
    while at < size:
        part = os.pread(descriptor, size - at, at)
        if not part:
            break
        parts.append(part)
        at += len(part)
    return b"".join(parts)


def _vet(search: Sequence[str], files: Sequence[str], read: Mapping[str, Iterable[str]]) -> None:
    """Read every file protoc will read from disk for ``files``, and their imports, each where
    protoc finds it: in the first search folder holding it as something other than a folder
    (files of ``read``: in the first, ``root``). What protoc will not open is left alone: a name
    it refuses (absolute, or with ``..``, ``.`` or an empty part), or one no folder holds
    (protoc reports it)."""
    trusted = (_WELL_KNOWN, FALLBACK_INCLUDE)
    pending, seen = list(files), set()
    while pending:
        name = pending.pop().partition("\0")[0]  # protoc's names are C strings
        if has_control(name):
            raise FileError(
                os.path.join(search[0], shown(name)),
                "a file name holding a control character: refused",
            )
        if name in seen or name.startswith("/") or {"", ".", ".."} & set(name.split("/")):
            continue
        seen.add(name)
        if name in read:
            pending.extend(read[name])
            continue
        for folder in search:
            path = os.path.join(folder, name)
            try:
                if stat.S_ISDIR(os.stat(path).st_mode):
                    continue
            except OSError:
                continue
            if folder not in trusted:
                text = read_text(path, errors="replace")
                pending.extend(spelling for _, _, spelling in imported(text))
            break


@functools.cache
def _default_names() -> frozenset[str]:
    """The files our own include folders provide."""
    return frozenset(
        path.relative_to(folder).as_posix()
        for folder in (Path(_WELL_KNOWN), Path(FALLBACK_INCLUDE))
        for path in folder.rglob("*.proto")
    )


@functools.cache
def _defaults() -> descriptor_pb2.FileDescriptorSet:
    """The well-known types and the fallback nanopb.proto, compiled once."""
    names = [p.relative_to(_WELL_KNOWN).as_posix() for p in Path(_WELL_KNOWN).rglob("*.proto")]
    found = compile_files(Path(_WELL_KNOWN), sorted(names), locations=False)
    fallback = compile_files(Path(FALLBACK_INCLUDE), ["nanopb.proto"], locations=False)
    seen = {file.name for file in found.file}
    found.file.extend(file for file in fallback.file if file.name not in seen)
    return found


def _standard_descriptors_open() -> None:
    """Give each of descriptors 0-2 that the process lacks /dev/null, for good: a scratch file
    must not take one of those numbers, least of all 2, which each run points elsewhere."""
    for number in (0, 1, 2):
        try:
            os.fstat(number)
        except OSError:
            spare = os.open(os.devnull, os.O_RDWR)  # the lowest free number: this one
            if spare != number:
                os.dup2(spare, number)
                os.close(spare)


@contextlib.contextmanager
def _stderr_to(sink: int) -> Iterator[None]:
    """Point file descriptor 2 at ``sink`` for the duration of the block."""
    saved = os.dup(2)
    try:
        os.dup2(sink, 2)
        try:
            yield
        finally:
            os.dup2(saved, 2)
    finally:
        os.close(saved)
