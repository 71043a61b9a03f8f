"""A proto tree as the embedded toolchain sees it: every file compiled, none hiding another.

Guarantees:
- Every ``.proto`` under the root is compiled with its imports; one that does not compile becomes
  ``COMPILE`` load problems carrying protoc's own ``path:line:col`` and text, and every other file
  is still loaded. The whole tree goes to protoc at once; only when that fails is it split in
  halves, recursively, so a tree with k broken files costs about k·log(n) compilations, not n.
- Files that would collide when compiled together (nanopb compiles one file at a time and never
  notices) load side by side: the collisions are for the NAME_COLLISION rule to report.
- Imports resolve whatever their spelling: relative to the root or an ``-I`` folder, prefixed with
  the repository's own folder name (``ERC-Protobufs/components/x.proto``), or a bare file name
  found anywhere in the tree. An import that matches several files is an ``IMPORT_AMBIGUOUS``
  load problem. Only when a spelling needs rewriting is the tree copied to a scratch folder (with
  the spelling rewritten in place, line for line, so protoc's locations stay the originals');
  otherwise protoc reads the tree where it is.
- Whatever the syntax (proto2, proto3, any edition protoc supports), files compile as they are,
  with their options of source retention kept (an extension range's ``declaration``s, which
  reserve extension numbers), for the model to resolve what each element means on the wire.

Every ``.proto`` under the root is read through ``erc_schema.read_text`` (a FIFO, a device
or a file over 16 MiB stops the run, naming it); symlinked folders are not entered.

The loader reports what it met as ``LoadProblem`` records; the rules of the same names turn them
into findings.
"""

import os
import re
from collections.abc import Collection, Iterable, Sequence
from fnmatch import fnmatchcase
from pathlib import Path
from typing import Literal, NamedTuple

from google.protobuf import descriptor_pb2

from erc_schema import Location, ProtocError, compile_files, imports, proto_files, read_text

__all__ = [
    "LoadProblem",
    "LoadedTree",
    "by_basename",
    "load_tree",
    "matches",
    "relative",
    "respell",
    "utf8_name",
]

# Read only when protoc refused a file: compiled on first use (re caches it).
_DIAGNOSTIC = r"^(.*?):(\d+):(\d+): (.*)$"


class LoadProblem(NamedTuple):
    """What loading a tree met: a file protoc does not compile (``COMPILE``, one per diagnostic),
    or an import whose spelling matches several files of the tree (``IMPORT_AMBIGUOUS``)."""

    kind: Literal["COMPILE", "IMPORT_AMBIGUOUS"]
    key: str  # the same problem in another revision has the same key (no scratch paths in it)
    location: Location
    text: str


class LoadedTree:
    """The compiled files of one tree, with the problems loading met."""

    __slots__ = ("failed", "files", "imported", "includes", "problems", "root", "texts")

    def __init__(self, root: Path, includes: Sequence[Path] = ()) -> None:
        self.root = root
        self.includes = tuple(includes)  # the further import folders it was compiled with
        self.files: dict[str, descriptor_pb2.FileDescriptorProto] = {}  # the tree's own, by name
        self.imported: dict[str, descriptor_pb2.FileDescriptorProto] = {}  # all protoc read
        self.problems: list[LoadProblem] = []
        self.failed: set[str] = set()  # files that did not compile
        self.texts: dict[str, str] = {}  # the tree's files as read


def load_tree(
    root: Path,
    includes: Sequence[Path] = (),
    exclude: Sequence[str] = (),
    only: Collection[str] | None = None,
) -> LoadedTree:
    """Compile every ``.proto`` under ``root`` but those matching an ``exclude`` pattern (which
    stay importable: excluding a file spares it the checks, not its importers), or only those
    in ``only``."""
    every = proto_files(root)
    tree = LoadedTree(root, includes)
    for name in [name for name in every if not utf8_name(name)]:
        every.remove(name)
        tree.failed.add(name)
        where = Location(str(root / name), 1, 1)
        text = "File name is not UTF-8: protoc cannot compile it, nor anything importing it."
        tree.problems.append(LoadProblem("COMPILE", repr(name), where, text))
    names = [
        name
        for name in every
        if not any(fnmatchcase(name, p) for p in exclude) and (only is None or name in only)
    ]
    texts = {name: read_text(root / name, errors="replace") for name in every}
    tree.texts = texts
    rewritten, read = _resolve_imports(tree, texts, set(names), includes)
    if not rewritten:
        _compile(tree, root, names, includes, read)
        return tree
    import tempfile  # only for a respelled import: a tree without one never loads it

    with tempfile.TemporaryDirectory(prefix="erc-lint-") as scratch:
        staged = Path(scratch)
        for name, text in texts.items():
            target = staged / name
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_text(rewritten.get(name, text), "utf-8")
        _compile(tree, staged, names, includes, read)
    return tree


def respell(text: str, edits: Iterable[tuple[int, int, str]]) -> str:
    """``text`` with each import literal ``text[start:end]`` of ``edits`` replaced by a string
    literal protoc reads as the edit's name, of as many lines as the span it replaces, so the
    lines after it keep their numbers (protoc's locations stay the original file's)."""
    for start, end, name in sorted(edits, reverse=True):
        escaped = name.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n")
        lines = "\n" * text.count("\n", start, end)
        text = f'{text[:start]}"{escaped}"{lines}{text[end:]}'
    return text


def matches(spelling: str, known: Collection[str], by_basename: dict[str, list[str]]) -> list[str]:
    """The tree files an import spelling may mean, when it names none of them as it stands:
    a suffix of it that is a tree path (a repository prefix in front), else its bare file name
    found anywhere. ``by_basename`` indexes ``known`` by file name."""
    parts = spelling.split("/")
    found = sorted({"/".join(parts[k:]) for k in range(1, len(parts))} & set(known))
    return found or by_basename.get(parts[-1], [])


def by_basename(known: Collection[str]) -> dict[str, list[str]]:
    index: dict[str, list[str]] = {}
    for name in sorted(known):
        index.setdefault(name.rsplit("/", 1)[-1], []).append(name)
    return index


def _resolve_imports(
    tree: LoadedTree, texts: dict[str, str], reported: set[str], includes: Sequence[Path]
) -> tuple[dict[str, str], dict[str, list[str]]]:
    """The texts whose imports needed respelling (relative to the root), respelled, and every
    file's imports as protoc will read them (respelled too); ambiguous imports of the files in
    ``reported`` are load problems."""
    known, index = set(texts), by_basename(texts)
    rewritten: dict[str, str] = {}
    read: dict[str, list[str]] = {}
    for name, text in texts.items():
        edits: list[tuple[int, int, str]] = []
        spellings = read[name] = []
        for start, end, spelling in imports(text):
            spellings.append(spelling)
            if spelling in known or any((folder / spelling).is_file() for folder in includes):
                continue
            found = matches(spelling, known, index)
            if len(found) == 1:
                spellings[-1] = found[0]
                edits.append((start, end, found[0]))
            elif len(found) > 1 and name in reported:
                line = text.count("\n", 0, start) + 1
                column = start - text.rfind("\n", 0, start)
                where = Location(str(tree.root / name), line, column)
                message = f'Import "{spelling}" is ambiguous: it matches {", ".join(found)}.'
                key = f"{name}:{spelling}"
                tree.problems.append(LoadProblem("IMPORT_AMBIGUOUS", key, where, message))
        if edits:
            rewritten[name] = respell(text, edits)
    return rewritten, read


def _compile(
    tree: LoadedTree,
    base: Path,
    names: list[str],
    includes: Sequence[Path],
    read: dict[str, list[str]],
) -> None:
    """Compile ``names`` (``read``: every file of ``base``, read, with its imports)."""
    if not names:
        return
    try:
        # Options of source retention too: an extension range's declarations reserve numbers.
        compiled = compile_files(base, names, includes, read=read, retain_options=True)
    except ProtocError as error:
        if len(names) == 1:
            tree.failed.add(names[0])
            _report(tree, base, names[0], error.lines, includes)
            return
        half = len(names) // 2
        _compile(tree, base, names[:half], includes, read)
        _compile(tree, base, names[half:], includes, read)
        return
    own = set(names)
    for proto in compiled.file:
        tree.imported.setdefault(proto.name, proto)
        if proto.name in own:
            tree.files[proto.name] = proto


def _report(
    tree: LoadedTree, base: Path, name: str, lines: list[str], includes: Sequence[Path]
) -> None:
    """COMPILE problems from protoc's diagnostics for ``name``, located in the original files.

    An error inside an imported file is reported once, however many files import it.
    """
    prefix = str(base) + os.sep
    for line in lines:
        match = re.match(_DIAGNOSTIC, line)
        if match is None:
            where, text = Location(str(tree.root / name), 1, 1), line
        else:
            path = match[1].removeprefix(prefix)
            if not os.path.isabs(path) and not (tree.root / path).is_file():
                outside = [folder / path for folder in includes if (folder / path).is_file()]
                path = str(outside[0]) if outside else path  # a file of an -I folder
            elif not os.path.isabs(path):
                path = str(tree.root / path)
            where, text = Location(path, int(match[2]), int(match[3])), match[4]
        if any(
            p.location.path == where.path
            and p.location.line == where.line
            and p.text.startswith(text)
            for p in tree.problems
        ):
            continue
        # Keyed by the erring file and the error, not by which importer protoc compiled first.
        key = f"{relative(tree.root, where.path)}:{text}"
        if where.path != str(tree.root / name):
            text = f"{text} (imported by {name})"
        tree.problems.append(LoadProblem("COMPILE", key, where, text))


def utf8_name(name: str) -> bool:
    """Whether protoc can be given this file name (a file system's or git's may be any bytes)."""
    try:
        name.encode("utf-8")
    except UnicodeEncodeError:
        return False
    return True


def relative(root: Path, path: str) -> str:
    """``path`` relative to ``root`` when it lies inside it, so OLD and NEW keys compare."""
    inside = Path(path).is_relative_to(root)
    return Path(path).relative_to(root).as_posix() if inside else path
