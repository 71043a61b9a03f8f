"""What the decode commands read: standard input, and the datagrams of its hex lines.

``erc-codec decode`` and ``erc-codec proton decode`` take their datagrams the same way.
"""

import io
import sys
from collections.abc import Callable, Iterable, Iterator
from typing import cast

from ._shared import Fatal, unhex

__all__ = ["hex_lines", "read_stdin"]

_CHUNK = 1 << 16


def read_stdin() -> Iterator[bytes]:
    """Standard input's chunks, each whatever has arrived (``read1``): a pipe from a serial port
    or a log still being written is decoded as it comes."""
    if sys.stdin is None:
        raise Fatal("standard input is closed: give the datagrams as arguments or a file")
    stream = cast(io.BufferedReader, sys.stdin.buffer)
    return iter(lambda: stream.read1(_CHUNK), b"")


def _lines(chunks: Iterable[bytes]) -> Iterator[tuple[int, str]]:
    """Number and text (Latin-1, so every byte is one character) of each line of ``chunks``."""
    pending: list[bytes] = []  # the start of a line not ended yet, in pieces (a long line
    number = 0  # arriving in many chunks is joined once, not once per chunk)
    for chunk in chunks:
        *lines, rest = chunk.split(b"\n")
        if lines:
            lines[0] = b"".join([*pending, lines[0]])
            pending.clear()
        if rest:
            pending.append(rest)
        for line in lines:
            number += 1
            yield number, line.decode("latin-1")
    if pending:
        yield number + 1, b"".join(pending).decode("latin-1")


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
