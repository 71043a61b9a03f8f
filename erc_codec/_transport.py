"""Thin asyncio shells around the sans-IO core: a UDP endpoint and a serial (byte-stream) reader.

Everything that decides lives in the core (codec, ``Dispatcher``, ``Watchdog``, ``Deframer``);
these only move bytes and read the clock. The UDP endpoint binds 127.0.0.1 unless told otherwise.
Datagrams longer than the envelope's maximum are dropped and counted by the dispatcher, as every
undecodable datagram is (reason ``too_long``).

This module does not import asyncio: ``import erc_codec`` must not pay its 20 to 40 ms of start-up
(erc-lint imports erc_codec and is measured against buf in ``benchmarks/bench_lint.py``). Code here
runs inside an event loop, where asyncio is loaded already; ``UdpEndpoint`` therefore implements
asyncio's datagram protocol methods itself instead of inheriting them, and
``tests/test_transport.py`` holds it to ``asyncio.DatagramProtocol``'s method list.
"""

import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, cast

from google.protobuf.message import Message

from ._dispatch import Dispatcher
from ._envelope import Mode
from ._framing import Deframer
from ._watchdog import Watchdog

if TYPE_CHECKING:
    import asyncio

__all__ = ["UdpEndpoint", "open_udp", "read_serial"]

Clock = Callable[[], float]
Heard = Callable[[bytes, Any], object]


class UdpEndpoint:
    """Every datagram received goes to the dispatcher; ``send`` encodes and sends a message.

    It is an asyncio datagram protocol; with a watchdog it polls it every ``poll_interval``
    seconds while the socket is open, so ``on_timeout`` fires while the loop runs.
    ``on_datagram(data, sender)`` (an attribute, too) hears every datagram before the dispatcher
    does, with the sender's address."""

    def __init__(
        self,
        dispatcher: Dispatcher,
        watchdog: Watchdog | None = None,
        clock: Clock = time.monotonic,
        poll_interval: float = 0.05,
        on_datagram: Heard | None = None,
    ) -> None:
        self.dispatcher = dispatcher
        self.watchdog = watchdog
        self.on_datagram = on_datagram
        self._clock = clock
        self._poll_interval = poll_interval
        self._transport: asyncio.DatagramTransport | None = None
        self._poller: asyncio.Task[None] | None = None
        self.send_errors = 0

    # -- asyncio.DatagramProtocol ----------------------------------------------------------------

    def connection_made(self, transport: "asyncio.BaseTransport") -> None:
        self._transport = cast("asyncio.DatagramTransport", transport)
        if self.watchdog is not None:
            import asyncio  # loaded: this runs inside an event loop

            self._poller = asyncio.get_running_loop().create_task(self._poll(self.watchdog))

    def connection_lost(self, exc: Exception | None) -> None:
        if self._poller is not None:
            self._poller.cancel()
            self._poller = None

    def datagram_received(self, data: bytes, addr: Any) -> None:
        if self.on_datagram is not None:
            self.on_datagram(data, addr)
        self.dispatcher.feed(data)

    def error_received(self, exc: Exception) -> None:
        self.send_errors += 1  # e.g. ICMP port unreachable after a send

    def pause_writing(self) -> None:
        """The kernel's send buffer is full; datagrams queue in the transport meanwhile."""

    def resume_writing(self) -> None:
        """The send buffer has room again."""

    # -- the endpoint ----------------------------------------------------------------------------

    @property
    def address(self) -> tuple[str, int]:
        """The local (host, port) the endpoint is bound to."""
        assert self._transport is not None
        host, port = self._transport.get_extra_info("sockname")[:2]
        return host, port

    def send(self, message: Message, to: tuple[str, int], mode: Mode = "strip") -> int:
        """Encode ``message`` (a payload or an envelope) and send it; the datagram's length."""
        assert self._transport is not None, "the endpoint is not open"
        data = self.dispatcher.codec.encode(message, mode)
        self._transport.sendto(data, to)
        return len(data)

    def close(self) -> None:
        """Stop polling the watchdog and close the socket."""
        self.connection_lost(None)
        if self._transport is not None:
            self._transport.close()

    async def _poll(self, watchdog: Watchdog) -> None:
        import asyncio

        while True:
            await asyncio.sleep(self._poll_interval)
            watchdog.poll(self._clock())


async def open_udp(
    dispatcher: Dispatcher,
    host: str = "127.0.0.1",
    port: int = 0,
    watchdog: Watchdog | None = None,
    poll_interval: float = 0.05,
    clock: Clock = time.monotonic,
    on_datagram: Heard | None = None,
) -> UdpEndpoint:
    """A UDP endpoint bound to ``host:port`` (port 0: any free one) feeding ``dispatcher``.

    With a ``watchdog``, every decoded kind counts as an arrival and the watchdog is polled every
    ``poll_interval`` seconds, so its ``on_timeout`` fires while the loop runs. ``on_datagram``
    hears every datagram, with its sender, before the dispatcher does.
    """
    import asyncio

    if watchdog is not None:
        previous = dispatcher.on_decoded

        def arrived(kind: str) -> None:
            watchdog.seen(kind, clock())
            if previous is not None:
                previous(kind)

        dispatcher.on_decoded = arrived
    endpoint = UdpEndpoint(dispatcher, watchdog, clock, poll_interval, on_datagram)
    protocol = cast("asyncio.DatagramProtocol", endpoint)
    await asyncio.get_running_loop().create_datagram_endpoint(
        lambda: protocol, local_addr=(host, port)
    )
    return endpoint


async def read_serial(
    reader: "asyncio.StreamReader",
    dispatcher: Dispatcher,
    deframer: Deframer | None = None,
    chunk: int = 4096,
) -> Deframer:
    """Feed every framed payload arriving on ``reader`` (a serial port through pyserial-asyncio,
    a socket, a pipe) to ``dispatcher`` until the stream ends; the deframer, for its counters."""
    deframer = deframer or Deframer.for_codec(dispatcher.codec)
    while data := await reader.read(chunk):
        for payload in deframer.feed(data):
            dispatcher.feed(payload)
    return deframer
