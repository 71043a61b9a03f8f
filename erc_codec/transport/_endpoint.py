"""Thin asyncio shells around the sans-IO core: a UDP endpoint and a serial (byte-stream) reader.

Everything that decides lives in the core (codec, ``Dispatcher``, ``Watchdog``, ``Deframer``).
These shells only move bytes and read the clock.

- The UDP endpoint binds 127.0.0.1 unless told otherwise.
- A datagram longer than the envelope's maximum is dropped with reason ``too_long``.
  The dispatcher counts it, as it counts every undecodable datagram.
- ``UdpEndpoint.stats()`` counts what never reaches the dispatcher:
  - datagrams the kernel dropped because its receive buffer was full;
  - datagrams still queued when the endpoint closed.
- The endpoint asks for a large receive buffer (4 MiB).
- It reads the socket itself, in batches (``_socket.UdpSocket``).
  It uses ``recvmsg`` for the kernel's drop count.
  Asyncio's datagram transport would hide both the drops and the unread datagrams.

This module imports neither asyncio nor socket at import time.
A program that only encodes and decodes must not pay their 20 to 40 ms of start-up.
Code here runs inside an event loop, where both are loaded already.
"""

import time
from collections import deque
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, NamedTuple

from google.protobuf.message import Message

from ..codec import Mode
from ..runtime import Deframer, Dispatcher, Watchdog
from ..runtime.checks import count, duration

if TYPE_CHECKING:
    import asyncio

    from ._socket import UdpSocket

__all__ = ["UdpEndpoint", "UdpStats", "open_udp", "read_serial"]

Clock = Callable[[], float]
Heard = Callable[[bytes, Any], object]

# Bytes of receive buffer asked for. Linux grants twice as much, up to twice net.core.rmem_max
# (often 208 KiB: raise it for the full buffer): 8 MiB hold some 10,000 small datagrams, half a
# second of 20,000 a second.
RECEIVE_BUFFER = 4 << 20
_BATCH = 256  # datagrams read in one go before the loop runs anything else
_LARGEST_BUFFER = (1 << 31) - 1  # SO_RCVBUF takes a C int


class UdpStats(NamedTuple):
    """A UDP endpoint's counters since it opened. Once it is closed, received + kernel_dropped
    + unread is every datagram that reached its port."""

    received: int  # datagrams read, each heard by on_datagram and fed to the dispatcher
    kernel_dropped: int | None  # dropped by the kernel before they could be read (None: the
    # system does not say: not Linux)
    unread: int  # still queued when the endpoint closed, read off and discarded
    send_errors: int  # sends that failed (and errors the kernel reported for earlier sends)
    receive_buffer: int  # bytes of receive buffer the kernel granted, as it counts them


class UdpEndpoint:
    """A UDP endpoint, made by ``open_udp``.

    - Every datagram received goes to the dispatcher.
    - ``send`` encodes and sends a message.
    - Without a dispatcher (``None``, a relay that routes bytes), datagrams go to ``on_datagram``
      only, and ``send_datagram`` sends bytes as they are.
    - With a watchdog, the endpoint polls it every ``poll_interval`` seconds while the socket is
      open, so ``on_timeout`` fires while the loop runs.
    - ``on_datagram(data, sender)`` hears every datagram, with the sender's address, before the
      dispatcher does; it is an attribute too.
    - If polling fails (the clock read NaN, or ``on_timeout`` raised), the endpoint closes and
      ``wait_closed()`` raises what stopped it, as Proton's links do.
      Otherwise a watchdog that stopped polling would be a silent one."""

    def __init__(
        self,
        dispatcher: Dispatcher | None,
        watchdog: Watchdog | None = None,
        clock: Clock = time.monotonic,
        poll_interval: float = 0.05,
        on_datagram: Heard | None = None,
    ) -> None:
        self.dispatcher = dispatcher
        self.watchdog = watchdog
        self.on_datagram = on_datagram
        self._clock = clock
        self._poll_interval = duration("poll_interval", poll_interval)
        self._sock: UdpSocket | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._poller: asyncio.Task[None] | None = None
        self._stopped: asyncio.Future[None] | None = None  # done once closed (or failed)
        self._unsent: deque[tuple[bytes, tuple[Any, ...]]] = deque()
        self._send_errors = 0
        self._writing = False  # a writer waits for room in the send buffer
        self._closed = False

    async def open(
        self, host: str = "127.0.0.1", port: int = 0, receive_buffer: int = RECEIVE_BUFFER
    ) -> None:
        """Bind ``host:port`` (port 0: any free one; the first of the host's addresses that
        binds), asking for ``receive_buffer`` bytes of receive buffer, and start reading (and
        polling the watchdog). ``open_udp`` does this."""
        import asyncio
        import socket

        from ._socket import UdpSocket  # socket and selectors: loaded in a loop, not by erc_codec

        count("receive_buffer", receive_buffer)
        if receive_buffer > _LARGEST_BUFFER:
            raise ValueError(
                f"receive_buffer must be at most {_LARGEST_BUFFER}, not {receive_buffer}"
            )
        assert self._sock is None, "the endpoint is open already"
        loop = asyncio.get_running_loop()
        found = await loop.getaddrinfo(host, port, type=socket.SOCK_DGRAM, flags=socket.AI_PASSIVE)
        failure: OSError | None = None
        for family, _, _, _, address in found:
            try:
                sock = UdpSocket(family, address, receive_buffer)
            except OSError as error:
                failure = failure or error
                continue
            self._sock, self._loop = sock, loop
            self._stopped = loop.create_future()
            loop.add_reader(sock.fileno(), self._readable)
            if self.watchdog is not None:
                self._poller = loop.create_task(self._poll(self.watchdog))
                self._poller.add_done_callback(self._poller_done)
            return
        raise failure or OSError(f"{host}:{port}: no address to bind")

    @property
    def address(self) -> tuple[str, int]:
        """The local (host, port) the endpoint is bound to."""
        assert self._sock is not None, "the endpoint is not open"
        host, port = self._sock.address[:2]
        return host, port

    @property
    def send_errors(self) -> int:
        """Sends that failed, and errors the kernel reported for earlier sends."""
        errors = self._sock.errors if self._sock is not None else 0
        return self._send_errors + errors

    def send(self, message: Message, to: tuple[str, int], mode: Mode = "strip") -> int:
        """Encode ``message`` (a payload or an envelope) and send it; the datagram's length.
        While the kernel's send buffer is full, datagrams wait in the endpoint, in order."""
        assert self.dispatcher is not None, "an endpoint without a dispatcher has no codec"
        return self.send_datagram(self.dispatcher.codec.encode(message, mode), to)

    def send_datagram(self, data: bytes, to: tuple[Any, ...]) -> int:
        """Send ``data`` as it is (waiting in order while the send buffer is full); its length."""
        sock = self._sock
        assert sock is not None, "the endpoint is not open"
        assert not self._closed, "the endpoint is closed"
        if not self._unsent:  # the usual case, sent at once (benchmarks/bench_relay.py)
            try:
                sock.sendto(data, to)
                return len(data)
            except (BlockingIOError, InterruptedError):
                pass  # the send buffer is full: wait in order, below
            except OSError:  # e.g. an ICMP error of an earlier send, or no route
                self._send_errors += 1
                return len(data)
        self._unsent.append((data, to))
        if len(self._unsent) == 1:
            self._send_unsent()
        return len(data)

    def stats(self) -> UdpStats:
        """A snapshot of the counters (the kernel's drop count read now, while open)."""
        assert self._sock is not None, "the endpoint is not open"
        sock = self._sock
        return UdpStats(
            sock.received, sock.kernel_dropped(), sock.unread, self.send_errors, sock.buffer
        )

    @property
    def closed(self) -> bool:
        """Whether the endpoint has closed (``close()``, or a failure ``wait_closed()`` raises)."""
        return self._closed

    async def wait_closed(self) -> None:
        """Until the endpoint closes: it returns after ``close()``, and raises what stopped it
        otherwise (an exception from the watchdog's polling: its clock, ``on_timeout``)."""
        import asyncio

        assert self._stopped is not None, "the endpoint is not open"
        await asyncio.shield(self._stopped)

    def close(self) -> None:
        """Stop polling the watchdog and reading; count what is still queued (``unread``) and
        what could not be sent yet (``send_errors``); close the socket."""
        self._stop(None)

    def _poller_done(self, poller: "asyncio.Task[None]") -> None:
        if not poller.cancelled():
            self._stop(poller.exception())

    def _stop(self, failure: BaseException | None) -> None:
        """Close once: the first failure (or none, for ``close()``) is what ``wait_closed``
        reports."""
        if self._closed:
            return
        self._closed = True
        if self._stopped is not None and failure is None:
            self._stopped.set_result(None)
        elif self._stopped is not None and failure is not None:
            self._stopped.set_exception(failure)
        if self._poller is not None:
            self._poller.cancel()
            self._poller = None
        if self._sock is not None and self._loop is not None:
            self._loop.remove_reader(self._sock.fileno())
            if self._writing:
                self._loop.remove_writer(self._sock.fileno())
            self._send_errors += len(self._unsent)
            self._unsent.clear()
            self._sock.close()

    def _readable(self) -> None:
        """Read what is queued, up to a batch, each datagram heard and dispatched in turn (an
        exception from ``on_datagram`` or the watchdog's clock leaves the rest queued, for the
        next call; the dispatcher catches its handlers' own)."""
        assert self._sock is not None
        receive = self._sock.receive
        feed = self.dispatcher.feed if self.dispatcher is not None else None
        for _ in range(_BATCH):
            received = receive()
            if received is None:
                return
            if self.on_datagram is not None:
                self.on_datagram(*received)
            if feed is not None:
                feed(received[0])
            if self._closed:  # on_datagram or a handler closed the endpoint: read no more
                return

    def _send_unsent(self) -> None:
        """Send what waits, in order, until the kernel's send buffer is full (then again once
        it has room)."""
        sock, loop = self._sock, self._loop
        assert sock is not None
        assert loop is not None
        while self._unsent:
            data, to = self._unsent[0]
            try:
                sock.sendto(data, to)
            except (BlockingIOError, InterruptedError):
                if not self._writing:
                    loop.add_writer(sock.fileno(), self._send_unsent)
                    self._writing = True
                return
            except OSError:  # e.g. an ICMP error of an earlier send, or no route
                self._send_errors += 1
            self._unsent.popleft()
        if self._writing:
            loop.remove_writer(sock.fileno())
            self._writing = False

    async def _poll(self, watchdog: Watchdog) -> None:
        import asyncio

        while True:
            await asyncio.sleep(self._poll_interval)
            watchdog.poll(self._clock())


async def open_udp(
    dispatcher: Dispatcher | None,
    host: str = "127.0.0.1",
    port: int = 0,
    watchdog: Watchdog | None = None,
    poll_interval: float = 0.05,
    clock: Clock = time.monotonic,
    on_datagram: Heard | None = None,
    receive_buffer: int = RECEIVE_BUFFER,
) -> UdpEndpoint:
    """A UDP endpoint bound to ``host:port``, feeding ``dispatcher``.

    - ``port`` 0 binds any free port.
    - With ``dispatcher`` ``None``, only ``on_datagram`` hears what arrives.
    - With a ``watchdog``, every decoded kind counts as an arrival.
    - The watchdog is polled every ``poll_interval`` seconds, so its ``on_timeout`` fires while
      the loop runs.
    - ``on_datagram`` hears every datagram, with its sender, before the dispatcher does.
    - ``receive_buffer`` is the bytes of receive buffer asked for.
    - ``stats().receive_buffer`` says what was granted; Linux caps it at twice
      ``net.core.rmem_max``.
    """
    endpoint = UdpEndpoint(dispatcher, watchdog, clock, poll_interval, on_datagram)
    await endpoint.open(host, port, receive_buffer)
    if watchdog is not None and dispatcher is not None:
        previous = dispatcher.on_arrival

        def arrived(kind: str, timeout: float | None) -> None:
            watchdog.seen(kind, clock(), timeout)  # the sender's advertised timeout too
            if previous is not None:
                previous(kind, timeout)

        dispatcher.on_arrival = arrived
    return endpoint


async def read_serial(
    reader: "asyncio.StreamReader",
    dispatcher: Dispatcher,
    deframer: Deframer | None = None,
    chunk: int = 4096,
) -> Deframer:
    """Feed every framed payload arriving on ``reader`` to ``dispatcher`` until the stream ends.

    ``reader`` may be a serial port through pyserial-asyncio, a socket or a pipe.
    It returns the deframer, for its counters.
    The deframer is flushed, so a frame cut off by the end of the stream counts as ``unfinished``
    bytes."""
    count("chunk", chunk)
    deframer = deframer or Deframer.for_codec(dispatcher.codec)
    while data := await reader.read(chunk):
        for payload in deframer.feed(data):
            dispatcher.feed(payload)
    deframer.flush()  # a frame cut off by the end of the stream is counted as unfinished
    return deframer
