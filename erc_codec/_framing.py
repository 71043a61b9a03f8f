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
- memory is bounded: besides the chunk being fed, it keeps at most one incomplete frame
  (``max_length`` + 6 bytes);
- time is linear in the bytes fed: each byte is scanned once, and each candidate frame start
  costs at most one CRC over ``max_length`` bytes (in C, through ``binascii``).
"""

import binascii
from dataclasses import dataclass, field

from ._errors import EncodeError

__all__ = ["Deframer", "DeframerStats", "crc16", "frame"]

MAGIC = b"PR"
_HEADER = 4  # magic and length
_TRAILER = 2  # CRC
_MAX_LENGTH = 0xFFFF


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


@dataclass
class DeframerStats:
    frames: int = 0  # payloads returned
    discarded_bytes: dict[str, int] = field(default_factory=dict)  # reason → bytes
    rejected: dict[str, int] = field(default_factory=dict)  # reason → frame candidates


class Deframer:
    """Turns a byte stream, fed in any chunks, back into the payloads that were framed."""

    def __init__(self, max_length: int | None = None) -> None:
        """``max_length``: the longest payload accepted; default the packaged envelope's size."""
        if max_length is None:
            from ._codec import Codec

            max_length = Codec.default().max_size(Codec.default().root)
        if not 0 <= max_length <= _MAX_LENGTH:
            raise ValueError(f"max_length must be within 0..{_MAX_LENGTH}")
        self._max = max_length
        self._buffer = bytearray()
        self._stats = DeframerStats()

    def feed(self, chunk: bytes) -> list[bytes]:
        """Take the next bytes of the stream; the payloads of the frames they complete."""
        buffer = self._buffer
        buffer += chunk
        payloads: list[bytes] = []
        append, find, crc, limit = payloads.append, buffer.find, binascii.crc_hqx, self._max
        pos, end = 0, len(buffer)
        while True:
            start = find(MAGIC, pos)
            if start < 0:
                # Keep a last "P": it may be the first half of the next frame's magic.
                keep = end - 1 if end > pos and buffer[end - 1] == MAGIC[0] else end
                self._discard("garbage", keep - pos)
                pos = keep
                break
            if start != pos:
                self._discard("garbage", start - pos)
                pos = start
            if end - start < _HEADER:
                break  # wait for the length
            body = start + _HEADER
            stop = body + (buffer[start + 2] | buffer[start + 3] << 8)
            if stop - body > limit:
                self._reject("too_long")
                pos = start + 1
                continue
            if stop + _TRAILER > end:
                break  # wait for the rest of the frame
            payload = bytes(buffer[body:stop])
            if crc(payload, 0xFFFF) != buffer[stop] | buffer[stop + 1] << 8:
                self._reject("bad_crc")
                pos = start + 1
                continue
            append(payload)
            pos = stop + _TRAILER
        del buffer[:pos]
        self._stats.frames += len(payloads)
        return payloads

    def buffered(self) -> int:
        """Bytes held while waiting for the rest of a frame."""
        return len(self._buffer)

    def stats(self) -> DeframerStats:
        """A snapshot of the counters."""
        s = self._stats
        return DeframerStats(s.frames, dict(s.discarded_bytes), dict(s.rejected))

    def _discard(self, reason: str, count: int) -> None:
        if count:
            self._stats.discarded_bytes[reason] = self._stats.discarded_bytes.get(reason, 0) + count

    def _reject(self, reason: str) -> None:
        """A frame candidate fails: its first byte is discarded, the rest rescanned."""
        self._stats.rejected[reason] = self._stats.rejected.get(reason, 0) + 1
        self._discard(reason, 1)
