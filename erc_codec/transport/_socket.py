"""A non-blocking UDP socket that says what the kernel dropped: the bytes under ``UdpEndpoint``.

Guarantees:
- Every datagram the kernel took for this socket is accounted for in one of these ways:
  - returned by ``receive``;
  - counted in ``kernel_dropped()``, the socket's own drop counter (``sk_drops``), which counts
    datagrams that found the receive buffer full or whose checksum was bad;
  - counted by ``close()`` as unread, when the socket closes with datagrams still queued.
- Where the system cannot tell (not Linux), ``kernel_dropped()`` is ``None``, never a made-up 0.

How the drops are read on Linux:
- ``SO_RXQ_OVFL`` makes the kernel attach the socket's cumulative drop count to each datagram it
  queues after a drop; ``recvmsg`` reads it here.
- ``SO_MEMINFO`` (Linux 4.6) reads the counter at any moment.
  It also covers drops after the last datagram read, since a flood into a full buffer queues
  nothing that could carry their count.
- The counter is 32 bits and may wrap.
  Readings are merged by serial-number arithmetic, so a stale reading never counts twice.

The receive buffer:
- It is asked for with ``SO_RCVBUF``.
- ``buffer`` is what the kernel granted, as it reports it.
- Linux doubles the request, because half of it is bookkeeping.
  A datagram of a few bytes takes about 800 bytes of buffer.
- Linux caps the buffer at twice ``net.core.rmem_max``; raise that sysctl for more.
- ``SO_RCVBUFFORCE`` would let root pass the cap; it is not used, because the cap is the
  administrator's.
- A system that refuses a size instead (the BSDs above ``kern.ipc.maxsockbuf``) is asked for half
  as much, and so on down to its default.

There is no asyncio here: ``_endpoint.UdpEndpoint`` puts the socket on a loop.
"""

import socket
import sys
from typing import Any

__all__ = ["UdpSocket"]

_LINUX = sys.platform == "linux"
_RXQ_OVFL: int | None = getattr(socket, "SO_RXQ_OVFL", 40 if _LINUX else None)
_MEMINFO: int | None = getattr(socket, "SO_MEMINFO", 55 if _LINUX else None)
_MEMINFO_DROPS = 8  # SK_MEMINFO_DROPS: the ninth u32 of the array
_MEMINFO_SIZE = 4 * (_MEMINFO_DROPS + 1)
_LARGEST = 65535  # the largest UDP datagram (IPv4 payloads stop at 65507)
_ANCILLARY = socket.CMSG_SPACE(4) if _RXQ_OVFL is not None else 0  # one u32: the drop count
_SMALLEST_ASKED = 1 << 16  # a refused receive buffer is asked for by halves down to this
_HALF = 1 << 31
_WRAP = (1 << 32) - 1
_LEAST_TRUESIZE = 256  # bytes of receive buffer a queued datagram takes at least (the kernel's
# bookkeeping included): close() reads at most the granted buffer's worth of them, and then some


class UdpSocket:
    """A bound, non-blocking UDP socket with a large receive buffer and its drops counted."""

    def __init__(self, family: int, address: tuple[Any, ...], receive_buffer: int) -> None:
        """Bound to ``address`` (of ``family``), asking for ``receive_buffer`` bytes of receive
        buffer; ``OSError`` if it cannot bind."""
        self._sock = sock = socket.socket(family, socket.SOCK_DGRAM)
        try:
            sock.setblocking(False)
            _ask_for_buffer(sock, receive_buffer)
            self._ovfl = _RXQ_OVFL is not None and _enable(sock, _RXQ_OVFL)
            self._meminfo = _meminfo_drops(sock) is not None
            sock.bind(address)
        except BaseException:
            sock.close()
            raise
        self.buffer: int = sock.getsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF)
        self.address: tuple[Any, ...] = sock.getsockname()
        self.received = 0
        self.errors = 0  # errors the socket reported (an ICMP port unreachable after a send)
        self.unread = 0  # datagrams still queued when the socket closed
        self._drops = 0  # drops counted so far, and the counter's last reading
        self._reading = 0
        self._closed = False

    def fileno(self) -> int:
        return self._sock.fileno()

    def receive(self) -> tuple[bytes, Any] | None:
        """The next datagram and its sender, ``None`` when none is waiting."""
        try:
            if self._ovfl:
                data, ancillary, _, sender = self._sock.recvmsg(_LARGEST, _ANCILLARY)
            else:
                (data, sender), ancillary = self._sock.recvfrom(_LARGEST), None
        except (BlockingIOError, InterruptedError):
            return None
        except OSError:  # the error of an earlier send, reported by the kernel
            self.errors += 1
            return None  # whatever is queued still makes the socket readable
        if ancillary:  # only once the socket has dropped: the counter as this one was queued
            for level, kind, value in ancillary:
                if level == socket.SOL_SOCKET and kind == _RXQ_OVFL and len(value) >= 4:
                    self._count_drops(int.from_bytes(value[:4], sys.byteorder))
        self.received += 1
        return data, sender

    def sendto(self, data: bytes, address: tuple[Any, ...]) -> None:
        """Send one datagram; ``BlockingIOError`` when the send buffer is full."""
        self._sock.sendto(data, address)

    def kernel_dropped(self) -> int | None:
        """The datagrams the kernel dropped for this socket; ``None`` where it cannot say."""
        if self._meminfo and not self._closed:
            reading = _meminfo_drops(self._sock)
            if reading is not None:
                self._count_drops(reading)
        return self._drops if self._ovfl or self._meminfo else None

    def close(self) -> None:
        """Take the last drop count, count (and discard) what is still queued, and close."""
        if self._closed:
            return
        self.kernel_dropped()
        for _ in range(2 * (self.buffer // _LEAST_TRUESIZE + 1)):  # ends while a sender floods
            try:
                self._sock.recv(1)
            except (BlockingIOError, InterruptedError):
                break
            except OSError:
                continue
            self.unread += 1
        self.kernel_dropped()  # drops while the queue was read off
        self._closed = True
        self._sock.close()

    def _count_drops(self, reading: int) -> None:
        """Merge a reading of the kernel's 32-bit counter: only a step forward counts."""
        step = (reading - self._reading) & _WRAP
        if 0 < step < _HALF:
            self._drops += step
            self._reading = reading


def _ask_for_buffer(sock: socket.socket, size: int) -> None:
    """Ask for ``size`` bytes of receive buffer, or the most below it the system takes."""
    while True:
        try:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, size)
        except OSError:
            if size <= _SMALLEST_ASKED:
                return  # the system's default stays
            size //= 2
            continue
        return


def _enable(sock: socket.socket, option: int) -> bool:
    try:
        sock.setsockopt(socket.SOL_SOCKET, option, 1)
    except OSError:
        return False
    return True


def _meminfo_drops(sock: socket.socket) -> int | None:
    if _MEMINFO is None:
        return None
    try:
        info = sock.getsockopt(socket.SOL_SOCKET, _MEMINFO, _MEMINFO_SIZE)
    except OSError:
        return None
    if len(info) < _MEMINFO_SIZE:
        return None
    return int.from_bytes(info[4 * _MEMINFO_DROPS : _MEMINFO_SIZE], sys.byteorder)
