"""Thin asyncio shells around a sans-IO ``Node``: Proton over UDP and over a serial byte stream.

Everything that decides lives in the node (what is due, what a message means, who is alive).
The framing lives in ``erc_codec.runtime.frame`` and ``erc_codec.runtime.Deframer``.
These shells only move bytes and read the clock, polling the node every ``tick`` seconds.

Errors:
- A message that does not decode, or that the node does not consume, is counted by its
  ``DecodeError`` reason and handed to ``on_error``; the link goes on.
- Anything else that goes wrong stops the link, never silently.
  Examples: the node refusing the clock, a handler or ``on_peer`` raising, a write that fails
  because the device went away.
- ``run_proton_serial`` raises it.
- A UDP link closes, and ``wait_closed()`` raises it.

Like erc_codec's own UDP endpoint, this module does not import asyncio at import time.
So ``import erc_codec.proton`` stays cheap.
Its code runs inside an event loop, where asyncio is loaded.
``ProtonUdp`` implements asyncio's datagram protocol methods itself.

UDP, as Proton's udp4 transport:
- One message goes per datagram, with no CRC.
- A 2.0 sender's optional 4-byte header is read; none is sent.
- A datagram's sender is the peer at its address.
- From an address no peer has, the sender is the node whose id its header names (any id, 0
  included).
- The local address and the peers' addresses come from the configuration's connections (a udp4
  endpoint each) unless given.
"""

import time
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any, NamedTuple, cast

from erc_schema import DecodeError

from ..runtime import Deframer, frame
from ..runtime.checks import duration
from ._node import Node, Sent
from ._udp_header import split_udp_header

if TYPE_CHECKING:
    import asyncio

__all__ = ["LinkStats", "ProtonUdp", "open_proton_udp", "run_proton_serial"]

Clock = Callable[[], float]
OnError = Callable[[DecodeError], object]
_MAX_FRAME = 0xFFFF
_SEND_FAILED = "send_failed"


class LinkStats(NamedTuple):
    """A link's counters: messages received and applied, messages sent, failures by reason
    (a ``DecodeError`` reason, or ``"send_failed"`` for a datagram the kernel reported
    undeliverable), and the fields received messages carried that Proton does not define
    (skipped: ``Bundle.unknown_fields``)."""

    received: int
    sent: int
    errors: dict[str, int]
    unknown_fields: int


class _Counters:
    def __init__(self, on_error: OnError | None) -> None:
        self.received = self.sent = self.unknown_fields = 0
        self.errors: dict[str, int] = {}
        self.on_error = on_error

    def receive(self, node: Node, data: bytes, clock: Clock, peer: str | None) -> None:
        try:
            bundle = node.receive(data, clock(), peer)
        except DecodeError as error:
            self.count(error.reason)
            if self.on_error is not None:
                self.on_error(error)
            return
        self.received += 1
        self.unknown_fields += len(bundle.unknown_fields)

    def count(self, reason: str) -> None:
        self.errors[reason] = self.errors.get(reason, 0) + 1

    def stats(self) -> LinkStats:
        return LinkStats(self.received, self.sent, dict(self.errors), self.unknown_fields)


class ProtonUdp:
    """A node running on a UDP socket, as ``open_proton_udp`` returns it (it is not made
    directly): its ``address``, its ``stats()``, ``close()`` and ``wait_closed()``. The
    remaining methods are asyncio's datagram protocol, called by the event loop."""

    def __init__(
        self,
        node: Node,
        addresses: dict[str, tuple[str, int]],
        clock: Clock,
        tick: float,
        on_error: OnError | None,
    ) -> None:
        import asyncio  # loaded: open_proton_udp runs inside an event loop

        self._node = node
        self._addresses = addresses
        self._senders = {address: name for name, address in addresses.items()}
        self._ids = {n.id: n.name for n in node.codec.config.nodes if n.name in node.peers}
        self._clock = clock
        self._tick = tick
        self._counters = _Counters(on_error)
        self._transport: asyncio.DatagramTransport | None = None
        self._poller: asyncio.Task[None] | None = None
        self._closed: asyncio.Future[None] = asyncio.get_running_loop().create_future()

    # -- asyncio.DatagramProtocol ----------------------------------------------------------------

    def connection_made(self, transport: "asyncio.BaseTransport") -> None:
        import asyncio

        self._transport = cast("asyncio.DatagramTransport", transport)
        self._poller = asyncio.get_running_loop().create_task(self._polling())
        self._poller.add_done_callback(self._poller_done)

    def connection_lost(self, exc: Exception | None) -> None:
        self._stop(exc)

    def datagram_received(self, data: bytes, addr: Any) -> None:
        if self._closed.done():
            return
        header, message = split_udp_header(data)
        peer = self._senders.get((addr[0], addr[1]))
        if peer is None and header is not None:
            peer = self._ids.get(header.node_id)
        try:
            self._counters.receive(self._node, message, self._clock, peer)
        except Exception as error:  # a handler, on_peer or the clock: the link stops, loudly
            self._stop(error)

    def error_received(self, exc: Exception) -> None:
        self._counters.count(_SEND_FAILED)  # e.g. ICMP port unreachable after a send

    def pause_writing(self) -> None:
        """The kernel's send buffer is full; datagrams queue in the transport meanwhile."""

    def resume_writing(self) -> None:
        """The send buffer has room again."""

    # -- the link --------------------------------------------------------------------------------

    @property
    def address(self) -> tuple[str, int]:
        """The local (host, port) the socket is bound to."""
        assert self._transport is not None
        host, port = self._transport.get_extra_info("sockname")[:2]
        return host, port

    @property
    def closed(self) -> bool:
        """Whether the link has stopped (``close()``, or a failure ``wait_closed()`` raises)."""
        return self._closed.done()

    def stats(self) -> LinkStats:
        """The link's counters."""
        return self._counters.stats()

    def close(self) -> None:
        """Stop the node's polling and close the socket."""
        self._stop(None)

    async def wait_closed(self) -> None:
        """Until the link stops: it returns after ``close()``, and raises what stopped it
        otherwise (an exception from the node, a handler, ``on_peer``, the clock or the
        socket)."""
        import asyncio

        await asyncio.shield(self._closed)

    async def _polling(self) -> None:
        import asyncio

        while True:
            for sent in self._node.poll(self._clock()):
                for peer in sent.peers:
                    if peer in self._addresses:
                        self._sendto(sent.data, self._addresses[peer])
            await asyncio.sleep(self._tick)

    def _sendto(self, data: bytes, address: tuple[str, int]) -> None:
        assert self._transport is not None
        self._transport.sendto(data, address)
        self._counters.sent += 1

    def _poller_done(self, poller: "asyncio.Task[None]") -> None:
        if not poller.cancelled():
            self._stop(poller.exception())

    def _stop(self, failure: BaseException | None) -> None:
        """Stop once: the first failure (or none, for ``close()``) is what ``wait_closed``
        reports."""
        if self._closed.done():
            return
        if failure is None:
            self._closed.set_result(None)
        else:
            self._closed.set_exception(failure)
        if self._poller is not None:
            self._poller.cancel()
        if self._transport is not None:
            self._transport.close()


async def open_proton_udp(
    node: Node,
    host: str | None = None,
    port: int | None = None,
    peers: Mapping[str, tuple[str, int]] | None = None,
    clock: Clock = time.monotonic,
    tick: float = 0.005,
    on_error: OnError | None = None,
) -> ProtonUdp:
    """``node`` on UDP.

    - It is bound to ``host:port``; the default is its endpoint of its first udp4 connection.
    - It sends each due bundle to its consumers' addresses.
    - ``peers`` gives those addresses by name; the default is their endpoints of those
      connections.
    - It is polled every ``tick`` seconds until closed or until something stops it.
    - ``ProtonUdp.wait_closed`` raises what stopped it."""
    import asyncio

    tick = duration("tick", tick)
    local, addresses = _udp_addresses(node)
    addresses.update(peers or {})
    link = ProtonUdp(node, addresses, clock, tick, on_error)
    bound_host, bound_port = local or ("127.0.0.1", 0)
    protocol = cast("asyncio.DatagramProtocol", link)
    await asyncio.get_running_loop().create_datagram_endpoint(
        lambda: protocol,
        local_addr=(bound_host if host is None else host, bound_port if port is None else port),
    )
    return link


def _udp_addresses(node: Node) -> tuple[tuple[str, int] | None, dict[str, tuple[str, int]]]:
    """The node's first udp4 endpoint in a connection, and its udp4 peers' addresses."""
    local: tuple[str, int] | None = None
    addresses: dict[str, tuple[str, int]] = {}
    for mine, peer, theirs in node.codec.config.peers(node.name):
        if mine.address is None or theirs.address is None:
            continue  # a serial connection
        local = local or mine.address
        addresses.setdefault(peer.name, theirs.address)
    return local, addresses


async def run_proton_serial(
    node: Node,
    reader: "asyncio.StreamReader",
    writer: "asyncio.StreamWriter",
    peer: str | None = None,
    clock: Clock = time.monotonic,
    tick: float = 0.005,
    on_error: OnError | None = None,
) -> LinkStats:
    """``node`` on a serial link, until ``reader`` ends; it returns the link's counters.

    - The link may be pyserial-asyncio's streams, a socket or a pipe.
    - Every frame that arrives is received from ``peer``.
    - Every due bundle for ``peer`` is framed and written; without a ``peer``, every due bundle.
    - Anything else that stops the reading or the writing stops both and is raised here.
      Examples: a failed write, a handler raising, the node refusing the clock."""
    import asyncio

    tick = duration("tick", tick)
    counters = _Counters(on_error)
    deframer = Deframer(max_length=_MAX_FRAME)

    async def reading() -> None:
        while data := await reader.read(4096):
            for payload in deframer.feed(data):
                counters.receive(node, payload, clock, peer)

    async def polling() -> None:
        while True:
            due: list[Sent] = node.poll(clock())
            for sent in due:
                if peer is None or peer in sent.peers:
                    writer.write(frame(sent.data))
                    counters.sent += 1
            if due:
                await writer.drain()
            await asyncio.sleep(tick)

    loop = asyncio.get_running_loop()
    tasks = (loop.create_task(reading()), loop.create_task(polling()))
    try:
        await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
    finally:
        for task in tasks:
            task.cancel()
        await asyncio.wait(tasks)
    for task in tasks:
        if not task.cancelled() and task.exception() is not None:
            raise cast(BaseException, task.exception())
    return counters.stats()
