"""Proton's serial framing, byte for byte: ``50 52 | length (u16 LE) | payload | CRC-16 (LE)``.

The CRC is CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF, no reflection) over the payload only,
which is what ``binascii.crc_hqx(payload, 0xFFFF)`` computes.

``Deframer`` is incremental and sans-IO, in the manner of h11's receive buffer. Its rule: judge
the stream as if its bytes arrived one at a time.
- A candidate is a ``PR``.
- Once its length is in, a candidate claiming more than ``max_length`` bytes is rejected at once
  (``too_long``).
- Any other candidate is decided at the byte that completes it.
- The first candidate to complete with a good CRC is delivered; of two that tie, the earlier
  start wins.
- Every candidate that started before a delivered frame's end is dropped. It is ``overtaken`` if
  it started before the frame.
- Scanning goes on after a delivered frame.
- A candidate that completes with a bad CRC is rejected (``bad_crc``), and the candidates after
  its first byte carry on.

So a frame comes out as soon as its last byte is in, whatever came before it. A glitch that reads
as a long header does not hold it back. The price: a frame whose payload holds a whole valid frame
loses to that inner frame.

Guarantees:
- Any chunking of the same bytes gives the same payloads and the same counters. The rule speaks
  of single bytes, and what a feed leaves behind depends on the bytes fed so far only.
- Every discarded byte is counted by reason as it leaves the window:
  - the first byte of a rejected candidate, under the candidate's reason, with the candidate in
    ``rejected``;
  - any other byte outside a frame, under ``garbage``;
  - a candidate whose first byte ends up inside a delivered frame is counted nowhere.
- ``flush()`` (the stream ended) discards what the window still holds, counted as
  ``unfinished``, and returns it. A frame is never lost silently, since a complete one is already
  out.
- Memory is bounded. Between feeds the window holds the bytes from the earliest undecided
  candidate on, at most ``max_length + 5`` of them, as a candidate is decided by its
  ``max_length + 6``-th byte. It also holds a few integers for each candidate in it.
- Time is linear in the bytes fed, whatever ``max_length``, as a slow path is a denial of service:
  - each byte is searched for ``PR`` (in C) a bounded number of times;
  - each byte is passed to ``crc_hqx`` about three times at most: once where a candidate no other
    one can overtake is checked whole, and once by each of two running CRCs where candidates
    overlap;
  - in a run of equal frames broken by a bad one, the break costs up to 15 frames' CRCs more (see
    below);
  - each candidate costs a bounded amount of Python work: a push and a pop on a heap (at most 16
    levels deep, in C) and at most four table look-ups;
  - each feed costs a bounded amount more.
- ``benchmarks/bench_framing.py`` measures the worst cases. ``tests/runtime/test_framing.py``
  counts the bytes ``crc_hqx`` is given.

Overlapping candidates. Checking every candidate's CRC over its payload would cost up to
``max_length`` bytes per ``PR`` (``PR ff ff`` repeated: a 64 KiB CRC every 4 bytes). But CRC-16
without its xorout is affine: with running prefix states ``Q(i) = crc_hqx(stream[o:i], 0)`` from
an origin ``o``, the CRC of the payload ``stream[a:b]`` is ``A_L(0xFFFF ^ Q(a)) ^ Q(b)``, where
``A_L(x) = crc_hqx(bytes(L), x)`` is linear in ``x``: one table look-up per hex digit of ``L``
(60 tables of 512, for ``d * 16**k`` zeros, made once per process, the first time candidates
overlap). ``Q(a)`` is taken as candidates are found (in order of start) and ``Q(b)`` as they
complete (in order of completion, from the heap), so each running CRC passes each byte once, and
a candidate costs the same whatever its length. That machinery engages only where candidates
overlap: a candidate incomplete at the end of the data with another one starting after it, or
one holding another that may complete first. Frames back to back, however chunked, are checked
whole as they complete.

CRC-16's blind spots. A good CRC is evidence, not proof.
- The CRC of ``ff ff`` followed by any number of zeros is 0. ``ff ff`` empties the register the
  init value 0xFFFF filled, and zeros keep it empty. So ``50 52 02 00 ff ff 00 00`` is a valid
  frame, and a line that idles high then drops can forge one.
- Any 16-bit check passes about 1 in 65,536 random candidates. So a noisy line full of ``PR``
  delivers a false frame now and then.

A caller can check payloads too, with ``accept=callable``:
- a frame with a good CRC whose payload ``accept`` refuses is rejected as if its CRC were bad
  (``undecodable``);
- the candidates after its first byte carry on, so a frame it was hiding (one starting inside it
  and ending later) still comes out;
- ``Deframer.for_codec(codec, validate=True)`` accepts what ``codec.decode`` decodes;
- ``accept`` runs once for every candidate with a good CRC, on top of the bound above: rarely on
  noise, but as often as a crafted stream has candidates;
- ``accept`` must not raise: an exception from it leaves the feed it came from half done;
- with ``accept``, frames are checked one at a time, not in batches.

Speed: frames of one length back to back (a board sending padded envelopes, say) are checked a batch
at a time, with the Python-level work per batch rather than per frame. A run's first batch is 16
frames, and each whole batch doubles the next (up to 256), so a CRC failure wastes at most as many
CRCs as the run has delivered before it, plus 16. A batch ends before a frame holding a candidate
short enough to complete inside it (one regular-expression search over the batch's payloads finds
them), and that frame is looked at on its own. Other frames go one at a time. The batch serves the
target of ``benchmarks/bench_framing.py`` (60-byte frames at half the bare CRC's rate or better);
``tests/runtime/test_framing.py`` holds the Deframer to a plain byte-at-a-time reading of the
stream.
"""

import binascii
import functools
import heapq
import re
import struct
import warnings
from collections import Counter, deque
from collections.abc import Callable
from itertools import repeat
from typing import TYPE_CHECKING, NamedTuple

from erc_schema import DecodeError, EncodeError

from .checks import count as whole

if TYPE_CHECKING:
    from ..codec import Codec

__all__ = ["Deframer", "DeframerStats", "crc16", "frame"]

MAGIC = b"PR"
_P, _R = MAGIC
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

    def __init__(
        self, max_length: int | None = None, *, accept: Callable[[bytes], bool] | None = None
    ) -> None:
        """Parameters:

        - ``max_length`` is the longest payload accepted. ``Deframer.for_codec(codec)`` sets it
          to the codec's envelope size. Leaving it out is deprecated: it loads the packaged
          schema.
        - ``accept``, if given, decides delivery: a frame is delivered only if
          ``accept(payload)`` is true. Otherwise it is rejected as ``undecodable``, like a bad
          CRC.
        """
        if max_length is None:
            warnings.warn(
                "Deframer() without max_length is deprecated: give max_length, or use "
                "Deframer.for_codec(codec)",
                DeprecationWarning,
                stacklevel=2,
            )
            from ..codec import Codec

            max_length = Codec.default().max_size(Codec.default().root)
        length = whole("max_length", max_length, minimum=0)  # not 2.5, not True
        if length > _MAX_LENGTH:
            raise ValueError(f"max_length must be within 0..{_MAX_LENGTH}, not {max_length!r}")
        self._max = length
        self._accept = accept
        self._buffer = bytearray()  # the window: the bytes not yet decided
        self._base = 0  # the stream offset of the window's first byte
        self._pos = 0  # the first byte not yet decided (between feeds: the window's first)
        self._wanted = 2  # bytes the window must hold before a plain scan can decide anything new
        self._batch = _FIRST_BATCH
        self._last = -1  # length of the frame just before ``_pos``, when nothing came between
        # Overlapping candidates, by stream offset; all empty while there are none.
        self._heap: list[tuple[int, int, int, int]] = []  # (end, start, length, Q(start + 4))
        self._starts: deque[int] = deque()  # every candidate in the window, in order
        self._fate: dict[int, str] = {}  # start → why it was rejected, for those that were
        self._scan = 0  # where the search for the next candidate goes on
        self._qa = (0, 0)  # running prefix CRC, taken at payload starts: (offset, Q(offset))
        self._qb = (0, 0)  # running prefix CRC, taken at payload ends
        self._frames = 0
        self._discarded: dict[str, int] = {}
        self._rejected: dict[str, int] = {}

    @classmethod
    def for_codec(cls, codec: "Codec", *, validate: bool = False) -> "Deframer":
        """A deframer accepting payloads up to ``codec``'s envelope size; with ``validate``,
        only payloads ``codec`` decodes (others are rejected as ``undecodable``)."""
        if not validate:
            return cls(codec.max_size(codec.root))
        decode = codec.decode

        def decodes(payload: bytes) -> bool:
            try:
                decode(payload)
            except DecodeError:
                return False
            return True

        return cls(codec.max_size(codec.root), accept=decodes)

    def feed(self, chunk: bytes | bytearray | memoryview) -> list[bytes]:
        """Take the next bytes of the stream; the payloads of the frames they complete."""
        if type(chunk) is not bytes:
            chunk = bytes(chunk)  # a copy of a mutable or typed buffer, counted in bytes
        payloads: list[bytes] = []
        buffer = self._buffer
        if self._heap and len(buffer) > len(chunk):
            # Overlapping candidates wait, and the chunk is short: grow the window in place
            # rather than copy it, and go the plain way with what is left if they all settle.
            buffer += chunk
            self._overlapping(buffer, self._base, payloads)
            if self._heap:
                self._keep(buffer, self._base)
                self._frames += len(payloads)
                return payloads
            data, base = bytes(buffer[self._pos - self._base :]), self._pos  # the chunk at most
        elif not buffer:
            data, base = chunk, self._base  # the payloads are slices of it
        elif (
            not self._heap
            and len(buffer) + len(chunk) < self._wanted
            and chunk.find(MAGIC) < 0
            and not (buffer[-1] == _P and chunk[:1] == b"R")
        ):
            buffer += chunk  # still waiting for the rest of a frame, and nothing starts inside
            return payloads
        else:
            data, base = b"".join((buffer, chunk)), self._base
        start = -1 if self._heap else self._plain(data, base, payloads)
        while self._heap or start >= 0:  # overlapping candidates: decide them, then go on
            if start >= 0:
                self._scan, self._qa, self._qb = start, (start, 0), (start, 0)
            self._overlapping(data, base, payloads)
            if self._heap:
                break  # they wait for more bytes
            start = self._plain(data, base, payloads)
        if self._heap:
            self._keep(data, base)
        else:  # what _keep does, without the call: the benchmark's chunks all come here
            self._buffer = bytearray(data[self._pos - base :])
            self._base = self._pos
        self._frames += len(payloads)
        return payloads

    def flush(self) -> bytes:
        """The stream ended: discard the bytes held (a frame still arriving, the first bytes of
        a header), counted as ``unfinished``, and return them. The deframer starts afresh."""
        held = bytes(self._buffer)
        self._discard("unfinished", len(held))
        self._base = self._pos = self._scan = self._base + len(held)
        self._buffer = bytearray()
        self._wanted, self._last, self._batch = 2, -1, _FIRST_BATCH
        self._heap.clear()
        self._starts.clear()
        self._fate.clear()
        return held

    def buffered(self) -> int:
        """Bytes held while waiting for the rest of a frame."""
        return len(self._buffer)

    def stats(self) -> DeframerStats:
        """A snapshot of the counters."""
        return DeframerStats(self._frames, dict(self._discarded), dict(self._rejected))

    def _plain(self, data: bytes, base: int, payloads: list[bytes]) -> int:  # noqa: C901
        """Deframe ``data`` (the stream from offset ``base``) from ``_pos`` while no candidates
        overlap; the stream offset where overlapping ones begin, or -1 once ``data`` is used
        up (``_pos`` and ``_wanted`` then say what waits)."""
        # One loop with its state in locals, not split into calls: a call per frame candidate
        # would cost the deframing target of benchmarks/bench_framing.py.
        append, find, crc, limit = payloads.append, data.find, binascii.crc_hqx, self._max
        accept = self._accept
        pos, end, last = self._pos - base, len(data), self._last  # last: frame that ended at pos
        batch, overlap, wanted = self._batch, -1, 0  # wanted: bytes needed, from the start
        start = find(MAGIC, pos)  # the next candidate
        while True:
            if start < 0:
                # Keep a last "P": it may be the first half of the next frame's magic.
                keep = end - 1 if end > pos and data[end - 1] == _P else end
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
                start = find(MAGIC, pos)
                continue
            stop = start + _HEADER + length
            if stop + _TRAILER > end:
                wanted = stop + _TRAILER  # wait for the rest of the frame,
                if find(MAGIC, start + 1) >= 0:  # unless another candidate started meanwhile
                    overlap = start
                break
            if length == last and accept is None:  # a run of equal lengths: a batch at once
                step = length + _HEADER + _TRAILER
                count = min(batch, (end - start) // step)
                run = _run(data, start, length, count)
                payloads += run
                pos = start + len(run) * step
                if len(run) < count:
                    last = -1  # the frame that broke the run is looked at on its own
                elif count == batch:  # a whole batch: the next may be twice as long
                    batch = min(2 * batch, _LAST_BATCH)
                start = find(MAGIC, pos)
                continue
            # The next candidate after this one's start; one inside it may be decided first.
            after, done = find(MAGIC, start + 1), stop + _TRAILER
            if 0 <= after < done and _completes_inside(data, after, done, limit):
                inner = self._overtaking(data, start, after, done, payloads)
                if inner < 0:
                    overlap = start
                    break
                pos, last = inner, -1
                start = find(MAGIC, pos)
                continue
            payload = data[start + _HEADER : stop]
            if crc(payload, 0xFFFF) != data[stop] | data[stop + 1] << 8:
                self._reject("bad_crc")
            elif accept is not None and not accept(payload):
                self._reject("undecodable")
            else:
                append(payload)
                pos, last, batch = done, length, _FIRST_BATCH  # perhaps a run starts
                start = after if after >= done else find(MAGIC, done)
                continue
            pos, last, start = start + 1, -1, after
            if 0 <= after < done:  # the candidates inside it are still open, and they overlap
                overlap = pos
                break
        self._pos, self._wanted, self._last, self._batch = base + pos, wanted - pos, last, batch
        return overlap if overlap < 0 else base + overlap

    def _overtaking(
        self, data: bytes, start: int, inner: int, end: int, payloads: list[bytes]
    ) -> int:
        """The candidate at ``start`` (ending at ``end``) holds one that completes first. The
        common case is a glitch that reads as a header just before a frame: if the first "PR"
        after ``start``, at ``inner``, is a frame nothing inside can overtake, deliver it here;
        its end, or -1 (the overlapping path decides)."""
        length = data[inner + 2] | data[inner + 3] << 8 if inner + _HEADER <= end else -1
        done = inner + _HEADER + length + _TRAILER
        if self._accept is not None or not 0 <= length <= self._max or done >= end:
            return -1
        after = data.find(MAGIC, inner + 1)
        if 0 <= after < done and _completes_inside(data, after, done, self._max):
            return -1
        payload = data[inner + _HEADER : done - _TRAILER]
        if binascii.crc_hqx(payload, 0xFFFF) != data[done - 2] | data[done - 1] << 8:
            return -1
        payloads.append(payload)
        self._reject("overtaken")
        self._discard("garbage", inner - start - 1)
        return done

    def _overlapping(  # noqa: C901
        self, data: bytes | bytearray, base: int, payloads: list[bytes]
    ) -> None:
        """Decide overlapping candidates, from ``_scan`` on, in the order of the bytes that
        complete them, until none is open or ``data`` (the stream from ``base``) is used up."""
        # One loop with its state in locals, as in _plain: its cost per candidate is the worst
        # case the module promises (benchmarks/bench_framing.py measures it).
        heap, starts, fate = self._heap, self._starts, self._fate
        find, crc, push, pop = data.find, binascii.crc_hqx, heapq.heappush, heapq.heappop
        limit, accept, tables = self._max, self._accept, _zero_tables()
        released: list[str] = []  # the reasons of the candidates that left the window
        end, pos, garbage = base + len(data), self._pos, 0
        scan, (qa_at, qa), (qb_at, qb) = self._scan, self._qa, self._qb
        found = find(MAGIC, scan - base)
        candidate = -1 if found < 0 else base + found
        while True:
            done = heap[0][0] if heap else end + 1
            if 0 <= candidate < done and candidate + _HEADER <= end:  # it starts first: take it
                at = candidate - base
                length = data[at + 2] | data[at + 3] << 8
                starts.append(candidate)
                if length > limit:
                    fate[candidate] = "too_long"
                else:
                    at += _HEADER
                    qa = crc(data[qa_at - base : at], qa)
                    qa_at = base + at
                    push(heap, (qa_at + length + _TRAILER, candidate, length, qa))
                scan = candidate + 1
                found = find(MAGIC, scan - base)
                candidate = -1 if found < 0 else base + found
                if heap:
                    continue
                break  # a candidate too long, with none open: the plain way again
            if done > end:
                break  # nothing more is decided before more bytes come
            done, start, length, x = pop(heap)
            stop = done - _TRAILER - base
            qb = crc(data[qb_at - base : stop], qb)
            qb_at = done - _TRAILER
            # x = A_length(0xFFFF ^ Q(payload start)): the CRC the payload would have if it
            # were zeros, from the state before it; one table per hex digit of the length.
            x ^= 0xFFFF
            if digit := length & 0xF:
                table = tables[digit]
                x = table[x & 0xFF] ^ table[256 + (x >> 8)]
            if digit := length >> 4 & 0xF:
                table = tables[16 + digit]
                x = table[x & 0xFF] ^ table[256 + (x >> 8)]
            if digit := length >> 8 & 0xF:
                table = tables[32 + digit]
                x = table[x & 0xFF] ^ table[256 + (x >> 8)]
            if digit := length >> 12:
                table = tables[48 + digit]
                x = table[x & 0xFF] ^ table[256 + (x >> 8)]
            if x ^ qb != data[stop] | data[stop + 1] << 8:
                fate[start] = "bad_crc"
            elif accept is not None and not accept(bytes(data[start + _HEADER - base : stop])):
                fate[start] = "undecodable"
            else:
                payloads.append(bytes(data[start + _HEADER - base : stop]))
                self._pos = pos
                self._deliver(start, done, length)
                pos, scan, qa_at, qa, qb_at, qb = done, done, done, 0, done, 0
                if candidate < done:
                    found = find(MAGIC, done - base)
                    candidate = -1 if found < 0 else base + found
                break
            while starts and starts[0] in fate:  # rejected ones at the front leave the window
                first = starts.popleft()
                released.append(fate.pop(first))
                garbage += first - pos
                pos = first + 1
            if not heap:
                break  # all decided: the plain way again
        if candidate < 0:
            scan = max(scan, end - 1)  # no "PR" before the last byte: never search there again
        self._discard("garbage", garbage)
        for reason, count in Counter(released).items():
            self._rejected[reason] = self._rejected.get(reason, 0) + count
            self._discard(reason, count)
        self._scan, self._qa, self._qb, self._pos = scan, (qa_at, qa), (qb_at, qb), pos
        self._settle(data, base, candidate)

    def _deliver(self, start: int, done: int, length: int) -> None:
        """The candidate at ``start`` is a frame ending at ``done``: every other one drops."""
        pos, starts, fate = self._pos, self._starts, self._fate
        garbage = 0
        while starts and starts[0] < start:
            first = starts.popleft()
            garbage += first - pos
            self._reject(fate.get(first, "overtaken"))
            pos = first + 1
        self._discard("garbage", garbage + start - pos)
        self._heap.clear()
        starts.clear()
        fate.clear()
        self._pos, self._last = done, length

    def _settle(self, data: bytes | bytearray, base: int, candidate: int) -> None:
        """Discard the bytes before the earliest undecided candidate (``candidate``: the next
        one found, not yet taken, or -1)."""
        pos, starts, fate = self._pos, self._starts, self._fate
        garbage = 0
        while starts and starts[0] in fate:
            first = starts.popleft()
            garbage += first - pos
            self._reject(fate.pop(first))
            pos = first + 1
        end = base + len(data)
        if starts:
            undecided = starts[0]
        elif candidate >= 0:
            undecided = candidate
        elif end > pos and data[-1] == _P:
            undecided = end - 1  # perhaps the first half of a magic
        else:
            undecided = end
        self._discard("garbage", garbage + undecided - pos)
        if undecided != pos:
            self._last = -1
        self._pos = undecided

    def _keep(self, data: bytes | bytearray, base: int) -> None:
        """Keep the bytes from ``_pos`` on as the window."""
        pos = self._pos
        if self._heap:  # the running CRCs must not lag behind the bytes kept
            (qa_at, qa), (qb_at, qb) = self._qa, self._qb
            if qa_at < pos:
                self._qa = pos, binascii.crc_hqx(data[qa_at - base : pos - base], qa)
            if qb_at < pos:
                self._qb = pos, binascii.crc_hqx(data[qb_at - base : pos - base], qb)
        if data is self._buffer:
            del self._buffer[: pos - base]
        else:
            self._buffer = bytearray(data[pos - base :])
        self._base = pos

    def _discard(self, reason: str, count: int) -> None:
        if count:
            self._discarded[reason] = self._discarded.get(reason, 0) + count

    def _reject(self, reason: str) -> None:
        """A frame candidate fails: its first byte is discarded."""
        self._rejected[reason] = self._rejected.get(reason, 0) + 1
        self._discard(reason, 1)


def _completes_inside(data: bytes, inner: int, end: int, limit: int) -> bool:
    """Whether a candidate starting at ``inner`` or later, before ``end``, completes before
    ``end`` (then it is decided before the candidate that ends there)."""
    while inner >= 0:
        if inner + _HEADER <= end:
            length = data[inner + 2] | data[inner + 3] << 8
            if length <= limit and inner + _HEADER + length + _TRAILER < end:
                return True
        inner = data.find(MAGIC, inner + 1, end + 1)
    return False


@functools.cache
def _zero_tables() -> list[list[int]]:
    """At index ``16 * position + digit`` (digit 1-15): the map ``x → crc_hqx(bytes(L), x)``
    for ``L = digit << 4 * position``, as one table of 512, the images of ``x``'s low byte then
    those of its high byte (the map is linear in ``x``). 60 tables: about 1 MB, made once, the
    first time candidates overlap."""

    def table(images: list[int]) -> list[int]:  # the images of x's 16 bits, spread out
        low, high = [0], [0]
        for bit in range(8):
            low += [value ^ images[bit] for value in low]
            high += [value ^ images[8 + bit] for value in high]
        return low + high

    tables: list[list[int]] = [[] for _ in range(64)]
    step = [binascii.crc_hqx(b"\0", 1 << bit) for bit in range(16)]  # bits' images: one zero
    for position in range(4):
        power = table(step)  # the map for 16 ** position zeros
        images = step
        for digit in range(1, 16):
            if digit > 1:  # one more 16 ** position zeros
                images = [power[image & 0xFF] ^ power[256 + (image >> 8)] for image in images]
            tables[16 * position + digit] = table(images)
        step = [power[image & 0xFF] ^ power[256 + (image >> 8)] for image in images]
    return tables


def _run(data: bytes, start: int, length: int, count: int) -> tuple[bytes, ...]:
    """The payloads of the longest valid prefix of ``count`` frames of ``length`` bytes that lie
    back to back from ``start`` (all complete in ``data``, the first one's header checked),
    and before the first one holding a candidate that may end inside it (which is looked at on
    its own).

    Exactly what the frame-by-frame scan would accept, but each step runs over the whole batch
    in C: header and CRC bytes are compared column by column through strided slices, and the
    payloads come out of one ``struct`` layout of the whole batch."""
    step = length + _HEADER + _TRAILER
    end = start + count * step
    payloads, crcs, headers, shorter = _layout(length, count)
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
        payloads, crcs, _, _ = _layout(length, count)
    found = payloads.unpack_from(data, start)
    if shorter is not None:  # the run stops before the first frame holding a candidate that
        # may end inside it. Such a "PR" lies in a payload, unless the header holds a "P" past
        # its magic; searching the payloads alone skips the partial matches every header is.
        if _P in (length & 0xFF, length >> 8):
            hit = shorter.search(data, start, end)
            first = -1 if hit is None else (hit.start() - start) // step
        else:
            hit = shorter.search(b"".join(found))
            first = -1 if hit is None else hit.start() // length
        if first >= 0:
            if not first:
                return ()
            count, end, found = first, start + first * step, found[:first]
            crcs = _layout(length, count)[1]
    computed = crcs.pack(*map(binascii.crc_hqx, found, repeat(0xFFFF)))  # little-endian pairs
    low = start + _HEADER + length
    sent = data[low:end:step], data[low + 1 : end : step]
    if (computed[0::2], computed[1::2]) != sent:  # the run breaks at the first bad CRC
        pairs = bytearray(computed)
        pairs[0::2], pairs[1::2] = sent
        return found[: _first_difference(computed, bytes(pairs)) // _TRAILER]
    return found


@functools.lru_cache(maxsize=64)
def _shorter(length: int) -> "re.Pattern[bytes] | None":
    """A search for a candidate shorter than ``length - 1`` bytes, the only ones that can end
    inside a frame of ``length`` bytes they start in (None: none can)."""
    if length < 2:
        return None
    high, low = divmod(length - 2, 256)
    if not high:
        return re.compile(b"PR[\\x00-\\x%02x]\\x00" % low)
    return re.compile(
        b"PR(?:[\\x00-\\xff][\\x00-\\x%02x]|[\\x00-\\x%02x]\\x%02x)" % (high - 1, low, high)
    )


@functools.lru_cache(maxsize=64)  # at most 64 layouts of at most 256 frames: under 1 MB
def _layout(
    length: int, count: int
) -> tuple[struct.Struct, struct.Struct, tuple[bytes, ...], "re.Pattern[bytes] | None"]:
    """For ``count`` frames of ``length`` bytes back to back: the layout of their payloads, that
    of their CRCs, what their header bytes must be, column by column, and ``_shorter(length)``."""
    header = MAGIC + length.to_bytes(2, "little")
    columns = tuple(header[offset : offset + 1] * count for offset in range(_HEADER))
    payloads, crcs = struct.Struct(f"4x{length}s2x" * count), struct.Struct(f"<{count}H")
    return payloads, crcs, columns, _shorter(length)


def _first_difference(a: bytes, b: bytes) -> int:
    """The index of the first byte where ``a`` and ``b`` (equally long, not equal) differ."""
    bits = int.from_bytes(a, "little") ^ int.from_bytes(b, "little")
    return ((bits & -bits).bit_length() - 1) // 8
