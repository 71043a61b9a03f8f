"""Proton's serial framing, byte for byte: ``50 52 | length (u16 LE) | payload | CRC-16 (LE)``.

The CRC is CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF, no reflection) over the payload only,
which is what ``binascii.crc_hqx(payload, 0xFFFF)`` computes.

``Deframer`` is incremental and sans-IO, in the manner of h11's receive buffer. Guarantees:
- any chunking of the same bytes yields the same payloads: a decision is taken only on bytes that
  have arrived, and a frame waits, whole, for the bytes it still needs;
- after garbage, a bad CRC or an impossible length it resynchronises on the next ``PR``: a
  rejected candidate costs one byte, so a real frame inside a false one is still found;
- every discarded byte is counted by reason (``garbage``, ``bad_crc``, ``too_long``), and so is
  every rejected frame candidate;
- memory is bounded: between feeds it keeps at most one incomplete frame (``max_length`` + 6
  bytes); a feed scans one copy of that plus the chunk, and none while a frame is still short;
- time is linear in the bytes fed: each byte is scanned once, and each candidate frame start
  costs at most one CRC over ``max_length`` bytes (in C, through ``binascii``).

Speed: frames of one length back to back (a board sending padded envelopes, say) are checked a
batch at a time, with the Python-level work per batch rather than per frame. A run's first batch
is 16 frames, and each whole batch doubles the next (up to 256), so a CRC failure wastes at most
as many CRCs as the run has delivered before it, plus 16. Other frames go one at a time. The batch
serves the target of ``benchmarks/bench_framing.py`` (60-byte frames at half the bare CRC's rate or
better); ``tests/test_framing.py`` holds the Deframer to a plain frame-by-frame reading of the
stream.
"""

import binascii
import functools
import struct
import warnings
from itertools import repeat
from typing import TYPE_CHECKING, NamedTuple

from ._errors import EncodeError

if TYPE_CHECKING:
    from ._codec import Codec

__all__ = ["Deframer", "DeframerStats", "crc16", "frame"]

MAGIC = b"PR"
_HEADER = 4  # magic and length
_TRAILER = 2  # CRC
_MAX_LENGTH = 0xFFFF
_FIRST_BATCH = 16  # frames verified at once when a run of equal lengths starts; doubles up to
_LAST_BATCH = 256  # this while the run holds


def crc16(payload: bytes) -> int:
    """CRC-16/CCITT-FALSE of ``payload``, as Proton computes it."""
    return binascii.crc_hqx(payload, 0xFFFF)


def frame(payload: bytes) -> bytes:
    """``payload`` framed for a serial link."""
    if len(payload) > _MAX_LENGTH:
        raise EncodeError(
            f"payload of {len(payload)} bytes is too long for a frame (65535 at most)"
        )
    size = len(payload).to_bytes(2, "little")
    return MAGIC + size + payload + crc16(payload).to_bytes(2, "little")


class DeframerStats(NamedTuple):
    """A Deframer's counters since it was made (copies: changing them changes nothing)."""

    frames: int  # payloads returned
    discarded_bytes: dict[str, int]  # reason → bytes
    rejected: dict[str, int]  # reason → frame candidates


class Deframer:
    """Turns a byte stream, fed in any chunks, back into the payloads that were framed."""

    def __init__(self, max_length: int | None = None) -> None:
        """``max_length``: the longest payload accepted (``Deframer.for_codec(codec)``: the
        codec's envelope size). Leaving it out is deprecated: it loads the packaged schema."""
        if max_length is None:
            warnings.warn(
                "Deframer() without max_length is deprecated: give max_length, or use "
                "Deframer.for_codec(codec)",
                DeprecationWarning,
                stacklevel=2,
            )
            from ._codec import Codec

            max_length = Codec.default().max_size(Codec.default().root)
        if not 0 <= max_length <= _MAX_LENGTH:
            raise ValueError(f"max_length must be within 0..{_MAX_LENGTH}")
        self._max = max_length
        self._buffer = bytearray()
        self._wanted = 2  # bytes the buffer must hold before a scan can decide anything new
        self._batch = _FIRST_BATCH
        self._last = -1  # length of the frame just before the buffer, when nothing came between
        self._frames = 0
        self._discarded: dict[str, int] = {}
        self._rejected: dict[str, int] = {}

    @classmethod
    def for_codec(cls, codec: "Codec") -> "Deframer":
        """A deframer accepting payloads up to ``codec``'s envelope size."""
        return cls(codec.max_size(codec.root))

    def feed(self, chunk: bytes | bytearray | memoryview) -> list[bytes]:  # noqa: C901
        """Take the next bytes of the stream; the payloads of the frames they complete."""
        # One loop with its state in locals, not split into calls: a call per frame candidate
        # would cost the deframing target of benchmarks/bench_framing.py.
        if type(chunk) is not bytes:
            chunk = bytes(chunk)  # a copy of a mutable or typed buffer, counted in bytes
        if not self._buffer:
            data = chunk  # the payloads are slices of it
        elif len(self._buffer) + len(chunk) < self._wanted:
            self._buffer += chunk  # still waiting for the rest of a frame: nothing to rescan
            return []
        else:
            data = b"".join((self._buffer, chunk))
        payloads: list[bytes] = []
        append, find, crc, limit = payloads.append, data.find, binascii.crc_hqx, self._max
        pos, end, last = 0, len(data), self._last  # last: length of the frame that ended at ``pos``
        batch = self._batch
        while True:
            start = find(MAGIC, pos)
            if start < 0:
                # Keep a last "P": it may be the first half of the next frame's magic.
                keep = end - 1 if end > pos and data[end - 1] == MAGIC[0] else end
                if keep != pos:
                    self._discard("garbage", keep - pos)
                    pos, last = keep, -1
                wanted = end + 1
                break
            if start != pos:
                self._discard("garbage", start - pos)
                pos, last = start, -1
            if end - start < _HEADER:
                wanted = start + _HEADER  # wait for the length
                break
            length = data[start + 2] | data[start + 3] << 8
            if length > limit:
                self._reject("too_long")
                pos, last = start + 1, -1
                continue
            stop = start + _HEADER + length
            if stop + _TRAILER > end:
                wanted = stop + _TRAILER  # wait for the rest of the frame
                break
            if length == last:  # a run of equal lengths: verify its frames a batch at once
                step = length + _HEADER + _TRAILER
                count = min(batch, (end - start) // step)
                run = _run(data, start, length, count)
                payloads += run
                pos = start + len(run) * step
                if len(run) < count:
                    last = -1  # the frame that broke the run is looked at on its own
                elif count == batch:  # a whole batch: the next may be twice as long
                    batch = min(2 * batch, _LAST_BATCH)
                continue
            payload = data[start + _HEADER : stop]
            if crc(payload, 0xFFFF) != data[stop] | data[stop + 1] << 8:
                self._reject("bad_crc")
                pos, last = start + 1, -1
                continue
            append(payload)
            pos, last, batch = stop + _TRAILER, length, _FIRST_BATCH  # perhaps a new run starts
        self._buffer = bytearray(data[pos:])
        self._wanted, self._last, self._batch = wanted - pos, last, batch
        self._frames += len(payloads)
        return payloads

    def buffered(self) -> int:
        """Bytes held while waiting for the rest of a frame."""
        return len(self._buffer)

    def stats(self) -> DeframerStats:
        """A snapshot of the counters."""
        return DeframerStats(self._frames, dict(self._discarded), dict(self._rejected))

    def _discard(self, reason: str, count: int) -> None:
        if count:
            self._discarded[reason] = self._discarded.get(reason, 0) + count

    def _reject(self, reason: str) -> None:
        """A frame candidate fails: its first byte is discarded, the rest rescanned."""
        self._rejected[reason] = self._rejected.get(reason, 0) + 1
        self._discard(reason, 1)


def _run(data: bytes, start: int, length: int, count: int) -> tuple[bytes, ...]:
    """The payloads of the longest valid prefix of ``count`` frames of ``length`` bytes that lie
    back to back from ``start`` (all complete in ``data``, the first one's header checked).

    Exactly what the frame-by-frame scan would accept, but each step runs over the whole batch
    in C: header and CRC bytes are compared column by column through strided slices, and the
    payloads come out of one ``struct`` layout of the whole batch."""
    step = length + _HEADER + _TRAILER
    end = start + count * step
    payloads, crcs, headers = _layout(length, count)
    columns = (  # the magic's two bytes and the length's two, frame by frame
        data[start:end:step],
        data[start + 1 : end : step],
        data[start + 2 : end : step],
        data[start + 3 : end : step],
    )
    if columns != headers:  # the run breaks at the first frame with another header
        count = min(
            _first_difference(a, b) for a, b in zip(columns, headers, strict=True) if a != b
        )
        end = start + count * step
        payloads, crcs, _ = _layout(length, count)
    found = payloads.unpack_from(data, start)
    computed = crcs.pack(*map(binascii.crc_hqx, found, repeat(0xFFFF)))  # little-endian pairs
    low = start + _HEADER + length
    sent = data[low:end:step], data[low + 1 : end : step]
    if (computed[0::2], computed[1::2]) != sent:  # the run breaks at the first bad CRC
        pairs = bytearray(computed)
        pairs[0::2], pairs[1::2] = sent
        return found[: _first_difference(computed, bytes(pairs)) // _TRAILER]
    return found


@functools.lru_cache(maxsize=64)  # at most 64 layouts of at most 256 frames: under 1 MB
def _layout(length: int, count: int) -> tuple[struct.Struct, struct.Struct, tuple[bytes, ...]]:
    """For ``count`` frames of ``length`` bytes back to back: the layout of their payloads, that
    of their CRCs, and what their header bytes must be, column by column."""
    header = MAGIC + length.to_bytes(2, "little")
    columns = tuple(header[offset : offset + 1] * count for offset in range(_HEADER))
    return struct.Struct(f"4x{length}s2x" * count), struct.Struct(f"<{count}H"), columns


def _first_difference(a: bytes, b: bytes) -> int:
    """The index of the first byte where ``a`` and ``b`` (equally long, not equal) differ."""
    bits = int.from_bytes(a, "little") ^ int.from_bytes(b, "little")
    return ((bits & -bits).bit_length() - 1) // 8
