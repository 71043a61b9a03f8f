"""What the decode commands read: standard input as hex text or raw bytes, and hex lines.

``erc-codec decode`` and ``erc-codec proton decode`` take their datagrams the same way.
"""

import io
import itertools
import sys
from collections.abc import Callable, Iterable, Iterator
from typing import cast

from ._shared import Fatal, unhex

__all__ = ["hex_lines", "read_stdin"]

_HEX_TEXT = b"0123456789abcdefABCDEF \t\n\r\v\f:"  # what a line of hex text holds
_TEXT = bytes(range(0x20, 0x7F)) + b"\t\n\r\v\f"  # printable ASCII and whitespace
_CHUNK = 1 << 16


def read_stdin() -> tuple[bool, Iterator[bytes]]:
    """Whether standard input is hex text, and its chunks (whatever has arrived: ``read1``).

    Hex text is text (printable ASCII and whitespace) whose first non-empty line spells at least
    one whole byte in hex digits, spaces and colons: a raw datagram is almost never all that (a
    one-byte stripped datagram such as ``2`` or a newline is raw), and a stray line of text later
    on is one ``not_hex`` error instead of turning the whole input into one bogus datagram. It is
    judged once the first non-empty line is whole, a byte that is not text has come, the input
    has ended, or 64 KiB have come, however slowly (a line typed, or written by a slow logger, in
    pieces), and not before. Reading chunk by chunk decodes a pipe from a serial port or a log
    that is still being written as it comes.
    """
    if sys.stdin is None:
        raise Fatal("standard input is closed: give the datagrams as arguments or a file")
    stream = cast(io.BufferedReader, sys.stdin.buffer)
    first = _first_line(stream)
    rest = iter(lambda: stream.read1(_CHUNK), b"")
    lines = first.split(b"\n")
    line = next((line for line in lines if line.strip()), b"")
    digits = len(line.translate(None, _HEX_TEXT.removeprefix(b"0123456789abcdefABCDEF")))
    hex_text = (
        not first.translate(None, _TEXT)
        and not line.translate(None, _HEX_TEXT)
        and digits >= 2
        and digits % 2 == 0
    )
    return hex_text, itertools.chain([first], rest)


def _first_line(stream: io.BufferedReader) -> bytes:
    """What standard input holds up to the end of its first non-empty line, up to a byte that is
    not text, or up to its end or ``_CHUNK`` bytes, whichever comes first (and perhaps a little
    beyond: whole chunks)."""
    first = bytearray()
    content = False  # a byte other than whitespace has come: the first non-empty line began
    while len(first) < _CHUNK:
        chunk = stream.read1(_CHUNK)
        if not chunk:
            break
        first += chunk
        if chunk.translate(None, _TEXT):
            break  # not text: raw bytes
        if not content:
            chunk = chunk.lstrip()
            content = bool(chunk)
        if content and b"\n" in chunk:
            break
    return bytes(first)


def _lines(chunks: Iterable[bytes]) -> Iterator[tuple[int, str]]:
    """Number and text (Latin-1, so every byte is one character) of each line of ``chunks``."""
    pending = b""
    number = 0
    for chunk in chunks:
        *lines, pending = (pending + chunk).split(b"\n")
        for line in lines:
            number += 1
            yield number, line.decode("latin-1")
    if pending:
        yield number + 1, pending.decode("latin-1")


def hex_lines(chunks: Iterable[bytes], not_hex: Callable[[int, str], object]) -> Iterator[bytes]:
    """The bytes of each non-empty line of hex text; a line that is not hex goes to
    ``not_hex(line number, problem)``."""
    for number, line in _lines(chunks):
        if not line.strip():
            continue
        try:
            yield unhex(line)
        except ValueError as error:
            not_hex(number, str(error))
