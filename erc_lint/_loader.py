"""A proto tree as the embedded toolchain sees it: every file compiled, none hiding another.

Guarantees:
- Every ``.proto`` under the root is compiled with its imports; one that does not compile becomes
  ``COMPILE`` findings carrying protoc's own ``path:line:col`` and text, and every other file is
  still loaded. The whole tree goes to protoc at once; only when that fails is it split in halves,
  recursively, so a tree with k broken files costs about k·log(n) compilations, not n.
- Files that would collide when compiled together (nanopb compiles one file at a time and never
  notices) load side by side: the collisions are for the NAME_COLLISION rule to report.
- Imports resolve whatever their spelling: relative to the root or an ``-I`` folder, prefixed with
  the repository's own folder name (``ERC-Protobufs/components/x.proto``), or a bare file name
  found anywhere in the tree. An import that matches several files is an ``IMPORT_AMBIGUOUS``
  finding. Only when a spelling needs rewriting is the tree copied to a scratch folder (with
  the spelling rewritten in place, line for line, so protoc's locations stay the originals');
  otherwise protoc reads the tree where it is.
"""

import os
import re
from collections.abc import Collection, Iterator, Sequence
from fnmatch import fnmatchcase
from pathlib import Path

from google.protobuf import descriptor_pb2

from erc_codec.schema import Location, ProtocError, compile_files

from ._finding import Finding

__all__ = ["LoadedTree", "by_basename", "imports", "load_tree", "matches", "relative", "utf8_name"]

# One pass over a file, tokenised as protoc does: comments and string literals are skipped whole,
# so an import inside one is no import; an import statement (comments allowed between its
# tokens, none needed around a string) captures its file name: adjacent string literals, which
# protoc joins.
_STRING = r'"(?:\\.|[^"\\\n])*"|\'(?:\\.|[^\'\\\n])*\''
_GAP = r"(?:[ \t\n\r\v\f]|//[^\n]*|/\*.*?\*/)"
_SCAN = re.compile(
    rf"//[^\n]*|/\*.*?\*/|{_STRING}|\bimport\b(?:{_GAP}*(?:public|weak)\b)?"
    rf"{_GAP}*({_STRING})((?:{_GAP}*(?:{_STRING}))*){_GAP}*;",
    re.DOTALL,
)
# The literals of a run of them (and the comments between them, to skip), and the escapes
# protoc's tokenizer reads inside one. Rarely needed: compiled on first use (re caches them).
_LITERALS = rf"(?s)//[^\n]*|/\*.*?\*/|({_STRING})"
_ESCAPE = (
    r"(?s)\\(?:([0-7]{1,3})|[xX]([0-9A-Fa-f]{1,2})"
    r"|u([dD][89abAB][0-9A-Fa-f]{2})\\u([dD][c-fC-F][0-9A-Fa-f]{2})"
    r"|u([0-9A-Fa-f]{4})|U([0-9A-Fa-f]{8})|(.))"
)
_C_ESCAPES = {"a": "\a", "b": "\b", "f": "\f", "n": "\n", "r": "\r", "t": "\t", "v": "\v"}
_DIAGNOSTIC = re.compile(r"^(.*?):(\d+):(\d+): (.*)$")


class LoadedTree:
    """The compiled files of one tree, with the findings loading produced."""

    __slots__ = ("failed", "files", "findings", "imported", "root", "texts")

    def __init__(self, root: Path) -> None:
        self.root = root
        self.files: dict[str, descriptor_pb2.FileDescriptorProto] = {}  # the tree's own, by name
        self.imported: dict[str, descriptor_pb2.FileDescriptorProto] = {}  # all protoc read
        self.findings: list[tuple[str, Finding]] = []  # (key, finding)
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
    every = [
        path.relative_to(root).as_posix()
        for path in sorted(root.rglob("*.proto"))
        if path.is_file()
    ]
    tree = LoadedTree(root)
    for name in [name for name in every if not utf8_name(name)]:
        every.remove(name)
        tree.failed.add(name)
        where = Location(str(root / name), 1, 1)
        text = "File name is not UTF-8: protoc cannot compile it, nor anything importing it."
        tree.findings.append((repr(name), Finding.at(where, "COMPILE", text)))
    names = [
        name
        for name in every
        if not any(fnmatchcase(name, p) for p in exclude) and (only is None or name in only)
    ]
    texts = {name: (root / name).read_text(encoding="utf-8", errors="replace") for name in every}
    tree.texts = texts
    rewritten = _resolve_imports(tree, texts, set(names), includes)
    if not rewritten:
        _compile(tree, root, names, includes)
        return tree
    import tempfile  # only a tree whose imports need respelling is staged

    with tempfile.TemporaryDirectory(prefix="erc-lint-") as scratch:
        staged = Path(scratch)
        for name, text in texts.items():
            target = staged / name
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_text(rewritten.get(name, text), "utf-8")
        _compile(tree, staged, names, includes)
    return tree


def imports(text: str) -> Iterator[tuple[int, int, str]]:
    """``(start, end, spelling)`` of each import's file name as protoc reads it: ``start:end``
    spans its string literals (several, joined, perhaps over several lines, with whatever lies
    between them), ``spelling`` is their text unescaped (comments skipped)."""
    if "import" not in text:
        return
    for match in _SCAN.finditer(text):
        first = match[1]
        if first is None:
            continue
        if match[2] or "\\" in first:
            yield match.start(1), match.end(2), _unquote(text[match.start(1) : match.end(2)])
        else:
            yield match.start(1), match.end(1), first[1:-1]


def _literal(name: str, span: str) -> str:
    """A string literal protoc reads as ``name``, to stand for ``span`` (an import's literals):
    as many lines as ``span``, so that the lines after it keep their numbers."""
    escaped = name.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n")
    return f'"{escaped}"' + "\n" * span.count("\n")


def _unquote(literals: str) -> str:
    """The bytes protoc makes of adjacent string literals, read as UTF-8."""
    joined = bytearray()
    for match in re.finditer(_LITERALS, literals):
        if match[1] is not None:
            body = match[1][1:-1]
            at = 0
            for escape in re.finditer(_ESCAPE, body):
                joined += body[at : escape.start()].encode("utf-8", "surrogatepass")
                joined += _unescape(escape)
                at = escape.end()
            joined += body[at:].encode("utf-8", "surrogatepass")
    return joined.decode("utf-8", "replace")


def _unescape(escape: re.Match[str]) -> bytes:
    """One escape sequence's bytes, as protoc's tokenizer makes them."""
    octal, hexa, head, trail, u4, u8, other = escape.groups()
    if octal is not None:
        return bytes([int(octal, 8) & 0xFF])  # protoc keeps the low byte of \777
    if hexa is not None:
        return bytes([int(hexa, 16)])
    if head is not None:  # a UTF-16 surrogate pair, one code point
        point = 0x10000 + ((int(head, 16) - 0xD800) << 10 | (int(trail, 16) - 0xDC00))
    elif u4 is not None or u8 is not None:
        point = int(u4 or u8, 16)
        if point > 0x10FFFF:
            return f"\\U{point:08x}".encode()  # out of range: protoc writes it back out
    else:
        return _C_ESCAPES.get(other, other).encode("utf-8", "surrogatepass")
    return chr(point).encode("utf-8", "surrogatepass")


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
) -> dict[str, str]:
    """The texts whose imports needed respelling (relative to the root), respelled; ambiguous
    imports of the files in ``reported`` are findings."""
    known, index = set(texts), by_basename(texts)
    rewritten = {}
    for name, text in texts.items():
        edits: list[tuple[int, int, str]] = []
        for start, end, spelling in imports(text):
            if spelling in known or any((folder / spelling).is_file() for folder in includes):
                continue
            found = matches(spelling, known, index)
            if len(found) == 1:
                edits.append((start, end, _literal(found[0], text[start:end])))
            elif len(found) > 1 and name in reported:
                line = text.count("\n", 0, start) + 1
                column = start - text.rfind("\n", 0, start)
                where = Location(str(tree.root / name), line, column)
                message = f'Import "{spelling}" is ambiguous: it matches {", ".join(found)}.'
                finding = Finding.at(where, "IMPORT_AMBIGUOUS", message)
                tree.findings.append((f"{name}:{spelling}", finding))
        for start, end, replacement in reversed(edits):
            text = text[:start] + replacement + text[end:]
        if edits:
            rewritten[name] = text
    return rewritten


def _compile(tree: LoadedTree, base: Path, names: list[str], includes: Sequence[Path]) -> None:
    if not names:
        return
    try:
        compiled = compile_files(base, names, includes)
    except ProtocError as error:
        if len(names) == 1:
            tree.failed.add(names[0])
            _report(tree, base, names[0], error.lines, includes)
            return
        half = len(names) // 2
        _compile(tree, base, names[:half], includes)
        _compile(tree, base, names[half:], includes)
        return
    own = set(names)
    for proto in compiled.file:
        tree.imported.setdefault(proto.name, proto)
        if proto.name in own:
            tree.files[proto.name] = proto


def _report(
    tree: LoadedTree, base: Path, name: str, lines: list[str], includes: Sequence[Path]
) -> None:
    """COMPILE findings from protoc's diagnostics for ``name``, located in the original files.

    An error inside an imported file is reported once, however many files import it.
    """
    prefix = str(base) + os.sep
    for line in lines:
        match = _DIAGNOSTIC.match(line)
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
            f.path == where.path and f.line == where.line and f.message.startswith(text)
            for _, f in tree.findings
        ):
            continue
        # Keyed by the erring file and the error, not by which importer protoc compiled first.
        key = f"{relative(tree.root, where.path)}:{text}"
        if where.path != str(tree.root / name):
            text = f"{text} (imported by {name})"
        tree.findings.append((key, Finding.at(where, "COMPILE", text)))


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
