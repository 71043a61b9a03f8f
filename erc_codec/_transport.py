"""Thin asyncio shells around the sans-IO core: a UDP endpoint and a serial (byte-stream) reader.

Everything that decides lives in the core (codec, ``Dispatcher``, ``Watchdog``, ``Deframer``);
these only move bytes and read the clock. The UDP endpoint binds 127.0.0.1 unless told otherwise.
Datagrams longer than the envelope's maximum are dropped and counted by the dispatcher, as every
undecodable datagram is (reason ``too_long``).
"""

import asyncio
import time
from collections.abc import Callable
from typing import Any, cast

from google.protobuf.message import Message

from ._dispatch import Dispatcher
from ._envelope import Mode
from ._framing import Deframer
from ._watchdog import Watchdog

__all__ = ["UdpEndpoint", "open_udp", "read_serial"]

Clock = Callable[[], float]


class UdpEndpoint(asyncio.DatagramProtocol):
    """Every datagram received goes to the dispatcher; ``send`` encodes and sends a message."""

    def __init__(
        self,
        dispatcher: Dispatcher,
        watchdog: Watchdog | None = None,
        clock: Clock = time.monotonic,
    ) -> None:
        self.dispatcher = dispatcher
        self.watchdog = watchdog
        self._clock = clock
        self._transport: asyncio.DatagramTransport | None = None
        self._poller: asyncio.Task[None] | None = None
        self.send_errors = 0

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        self._transport = cast(asyncio.DatagramTransport, transport)

    def datagram_received(self, data: bytes, addr: Any) -> None:
        self.dispatcher.feed(data)

    def error_received(self, exc: Exception) -> None:
        self.send_errors += 1  # e.g. ICMP port unreachable after a send

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
        if self._poller is not None:
            self._poller.cancel()
        if self._transport is not None:
            self._transport.close()

    async def _poll(self, interval: float) -> None:
        assert self.watchdog is not None
        while True:
            await asyncio.sleep(interval)
            self.watchdog.poll(self._clock())


async def open_udp(
    dispatcher: Dispatcher,
    host: str = "127.0.0.1",
    port: int = 0,
    watchdog: Watchdog | None = None,
    poll_interval: float = 0.05,
    clock: Clock = time.monotonic,
) -> UdpEndpoint:
    """A UDP endpoint bound to ``host:port`` (port 0: any free one) feeding ``dispatcher``.

    With a ``watchdog``, every decoded kind counts as an arrival and the watchdog is polled every
    ``poll_interval`` seconds, so its ``on_timeout`` fires while the loop runs.
    """
    if watchdog is not None:
        previous = dispatcher.on_decoded

        def arrived(kind: str) -> None:
            watchdog.seen(kind, clock())
            if previous is not None:
                previous(kind)

        dispatcher.on_decoded = arrived
    loop = asyncio.get_running_loop()
    _, endpoint = await loop.create_datagram_endpoint(
        lambda: UdpEndpoint(dispatcher, watchdog, clock), local_addr=(host, port)
    )
    if watchdog is not None:
        endpoint._poller = asyncio.create_task(endpoint._poll(poll_interval))
    return endpoint


async def read_serial(
    reader: asyncio.StreamReader,
    dispatcher: Dispatcher,
    deframer: Deframer | None = None,
    chunk: int = 4096,
) -> Deframer:
    """Feed every framed payload arriving on ``reader`` (a serial port through pyserial-asyncio,
    a socket, a pipe) to ``dispatcher`` until the stream ends; the deframer, for its counters."""
    deframer = deframer or Deframer(dispatcher.codec.max_size(dispatcher.codec.root))
    while data := await reader.read(chunk):
        for payload in deframer.feed(data):
            dispatcher.feed(payload)
    return deframer
