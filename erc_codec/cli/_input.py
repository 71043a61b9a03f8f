"""What the decode commands read: standard input, and the datagrams of its hex lines.

``erc-codec decode`` and ``erc-codec proton decode`` take their datagrams the same way.

Guarantee: a line of standard input is held in memory only up to ``LINE_LIMIT`` characters; the
rest of a longer one is dropped as it arrives and the line is reported by number (a 100 MB line
is neither stored nor parsed).
"""

import io
import sys
from collections.abc import Callable, Iterable, Iterator
from typing import cast

from ._shared import Fatal, unhex

__all__ = ["LINE_LIMIT", "hex_lines", "read_stdin"]

_CHUNK = 1 << 16
# The longest line of hex read: the largest datagram (65535 bytes, the most UDP carries) spelled
# with a separator between bytes ("0a:1b:..." or "0a 1b ...") is 196605 characters.
LINE_LIMIT = 256 * 1024


def read_stdin() -> Iterator[bytes]:
    """Standard input's chunks, each whatever has arrived (``read1``): a pipe from a serial port
    or a log still being written is decoded as it comes."""
    if sys.stdin is None:
        raise Fatal("standard input is closed: give the datagrams as arguments or a file")
    stream = cast(io.BufferedReader, sys.stdin.buffer)
    return iter(lambda: stream.read1(_CHUNK), b"")


def _lines(chunks: Iterable[bytes]) -> Iterator[tuple[int, str | None]]:
    """Number and text (Latin-1, so every byte is one character) of each line of ``chunks``;
    ``None`` for a line longer than ``LINE_LIMIT``, whose text is not kept."""
    pending: list[bytes] = []  # the start of a line not ended yet, in pieces (a long line
    size = 0  # arriving in many chunks is joined once, not once per chunk), and its length
    too_long = False  # the line being read passed the limit: the rest of it is dropped
    number = 0
    for chunk in chunks:
        *lines, rest = chunk.split(b"\n")
        for line in lines:
            number += 1
            if too_long or size + len(line) > LINE_LIMIT:
                yield number, None
            else:
                yield number, b"".join([*pending, line]).decode("latin-1")
            pending.clear()
            size, too_long = 0, False
        if rest and not too_long:
            size += len(rest)
            too_long = size > LINE_LIMIT
            if too_long:
                pending.clear()
            else:
                pending.append(rest)
    if too_long:
        yield number + 1, None
    elif pending:
        yield number + 1, b"".join(pending).decode("latin-1")


def hex_lines(
    chunks: Iterable[bytes],
    not_hex: Callable[[int, str], object],
    too_long: Callable[[int], object],
) -> Iterator[bytes]:
    """The bytes of each non-empty line of hex text; a line that is not hex goes to
    ``not_hex(line number, problem)``, one longer than ``LINE_LIMIT`` to ``too_long(line
    number)``."""
    for number, line in _lines(chunks):
        if line is None:
            too_long(number)
            continue
        if not line.strip():
            continue
        try:
            yield unhex(line)
        except ValueError as error:
            not_hex(number, str(error))
