"""A .proto file's text read as protoc's tokenizer reads it, for the two questions asked of it
before anything is compiled: which files it imports, which names it declares, and its package.

Comments and string literals are skipped whole, so an ``import`` or a ``message`` inside one counts
for nothing; an import's file name is its string literals joined (protoc joins adjacent ones, across
lines and comments too) and unescaped as protoc unescapes them.
"""

import re
from collections.abc import Iterator

__all__ = ["declared_names", "imports", "package_name"]

_STRING = r'"(?:\\.|[^"\\\n])*"|\'(?:\\.|[^\'\\\n])*\''
_COMMENT = r"//[^\n]*|/\*.*?\*/"
_GAP = rf"(?:[ \t\n\r\v\f]|{_COMMENT})"
# One pass over a file: comments and strings whole, and each import statement with its file name
# (its first literal, then any adjacent ones). The keyword is spelled ``i(?<!\wi)mport\b``, which
# is ``\bimport\b``: then every alternative starts with a character (/, ", ', i), and re skips
# ahead to the next of them instead of trying each alternative at every position.
# test_lint_loader holds the two spellings to the same matches.
_IMPORTS = re.compile(
    rf"{_COMMENT}|{_STRING}|i(?<!\wi)mport\b(?:{_GAP}*(?:public|weak)\b)?"
    rf"{_GAP}*({_STRING})((?:{_GAP}*(?:{_STRING}))*){_GAP}*;",
    re.DOTALL,
)
# Comments and strings whole, and each declaration of a message, enum or group with its name.
# Asked only of files that do not compile: compiled on first use (re caches it), not at import.
_DECLARATIONS = (
    rf"(?s){_COMMENT}|{_STRING}|\b(?:message|enum)\b{_GAP}+([A-Za-z_]\w*)"
    rf"|\bgroup\b{_GAP}+([A-Za-z_]\w*){_GAP}*="
)
# Comments and strings whole, and the package statement with its name. Asked only when sizing a
# root: compiled on first use (re caches it), not at import.
_PACKAGE = rf"(?s){_COMMENT}|{_STRING}|\bpackage\b{_GAP}+([A-Za-z_][\w.]*){_GAP}*;"
# The literals of a run of them (and the comments between them, to skip), and the escapes
# protoc's tokenizer reads inside one. Rarely needed: compiled on first use (re caches them).
_LITERALS = rf"(?s){_COMMENT}|({_STRING})"
_ESCAPE = (
    r"(?s)\\(?:([0-7]{1,3})|[xX]([0-9A-Fa-f]{1,2})"
    r"|u([dD][89abAB][0-9A-Fa-f]{2})\\u([dD][c-fC-F][0-9A-Fa-f]{2})"
    r"|u([0-9A-Fa-f]{4})|U([0-9A-Fa-f]{8})|(.))"
)
_C_ESCAPES = {"a": "\a", "b": "\b", "f": "\f", "n": "\n", "r": "\r", "t": "\t", "v": "\v"}


def imports(text: str) -> Iterator[tuple[int, int, str]]:
    """``(start, end, spelling)`` of each import's file name as protoc reads it: ``start:end``
    spans its string literals (several, joined, perhaps over several lines, with whatever lies
    between them), ``spelling`` is their text unescaped (comments skipped)."""
    last = text.rfind("import")
    if last < 0:
        return
    for match in _IMPORTS.finditer(text):
        if match.start() > last:
            break  # no statement starts after the last keyword: the rest is never scanned
        first = match[1]
        if first is None:
            continue
        if match[2] or "\\" in first:
            yield match.start(1), match.end(2), _unquote(text[match.start(1) : match.end(2)])
        else:
            yield match.start(1), match.end(1), first[1:-1]


def declared_names(text: str) -> frozenset[str]:
    """The short names of the messages, enums and groups ``text`` declares, at any depth."""
    return frozenset(
        match[1] or match[2] for match in re.finditer(_DECLARATIONS, text) if match[1] or match[2]
    )


def package_name(text: str) -> str | None:
    """The package ``text`` declares, ``None`` when it declares none."""
    return next((match[1] for match in re.finditer(_PACKAGE, text) if match[1]), None)


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
