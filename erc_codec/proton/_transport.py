"""Thin asyncio shells around a sans-IO ``Node``: Proton over UDP and over a serial byte stream.

Everything that decides lives in the node (what is due, what a message means, who is alive) and
in the framing (``erc_codec.frame``, ``erc_codec.Deframer``); these only move bytes and read the
clock, polling the node every ``tick`` seconds. A message that does not decode, or that the node
does not consume, is counted by its ``DecodeError`` reason and handed to ``on_error``; the link
goes on. Like erc_codec's own UDP endpoint, this module does not import asyncio at import time
(``import erc_codec.proton`` stays cheap): its code runs inside an event loop, where asyncio is
loaded, and ``ProtonUdp`` implements asyncio's datagram protocol methods itself.

UDP, as Proton's udp4 transport: one message per datagram, no CRC; a 2.0 sender's optional 4-byte
header is read (its node id names the sender when its address does not) and none is sent. The
local address and the peers' addresses come from the configuration's connections (a udp4 endpoint
each) unless given.
"""

import time
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any, NamedTuple, cast

from .._checks import duration
from .._errors import DecodeError
from .._framing import Deframer, frame
from ._node import Node, Sent
from ._udp_header import split_udp_header

if TYPE_CHECKING:
    import asyncio

__all__ = ["LinkStats", "ProtonUdp", "open_datagrams", "open_proton_udp", "run_proton_serial"]

Clock = Callable[[], float]
Heard = Callable[[bytes, Any], object]
OnError = Callable[[DecodeError], object]
_MAX_FRAME = 0xFFFF


class LinkStats(NamedTuple):
    """A link's counters: messages received and applied, messages sent, failures by reason."""

    received: int
    sent: int
    errors: dict[str, int]


class _Counters:
    def __init__(self, on_error: OnError | None) -> None:
        self.received = self.sent = 0
        self.errors: dict[str, int] = {}
        self.on_error = on_error

    def receive(self, node: Node, data: bytes, clock: Clock, peer: str | None) -> None:
        try:
            node.receive(data, clock(), peer)
        except DecodeError as error:
            self.errors[error.reason] = self.errors.get(error.reason, 0) + 1
            if self.on_error is not None:
                self.on_error(error)
            return
        self.received += 1

    def stats(self) -> LinkStats:
        return LinkStats(self.received, self.sent, dict(self.errors))


class ProtonUdp:
    """A UDP socket as an asyncio datagram protocol: ``heard(data, sender)`` hears every
    datagram; ``sendto`` sends one. ``open_proton_udp`` makes one that runs a node."""

    def __init__(self, heard: Heard, stats: Callable[[], LinkStats] | None = None) -> None:
        """``stats``: the counters of the node the socket runs, if it runs one."""
        self.heard = heard
        self.on_close: Callable[[], object] | None = None
        self._transport: asyncio.DatagramTransport | None = None
        self._stats = stats
        self.send_errors = 0

    # -- asyncio.DatagramProtocol ----------------------------------------------------------------

    def connection_made(self, transport: "asyncio.BaseTransport") -> None:
        self._transport = cast("asyncio.DatagramTransport", transport)

    def connection_lost(self, exc: Exception | None) -> None:
        if self.on_close is not None:
            self.on_close()
            self.on_close = None

    def datagram_received(self, data: bytes, addr: Any) -> None:
        self.heard(data, addr)

    def error_received(self, exc: Exception) -> None:
        self.send_errors += 1  # e.g. ICMP port unreachable after a send

    def pause_writing(self) -> None:
        """The kernel's send buffer is full; datagrams queue in the transport meanwhile."""

    def resume_writing(self) -> None:
        """The send buffer has room again."""

    # -- the socket ------------------------------------------------------------------------------

    @property
    def address(self) -> tuple[str, int]:
        """The local (host, port) the socket is bound to."""
        assert self._transport is not None
        host, port = self._transport.get_extra_info("sockname")[:2]
        return host, port

    def sendto(self, data: bytes, address: tuple[str, int]) -> None:
        assert self._transport is not None, "the socket is not open"
        self._transport.sendto(data, address)

    def stats(self) -> LinkStats:
        """The node's link counters (all zero for a socket that runs no node)."""
        return self._stats() if self._stats is not None else LinkStats(0, 0, {})

    def close(self) -> None:
        """Stop the node's polling and close the socket."""
        if self._transport is not None:
            self._transport.close()
        self.connection_lost(None)


async def open_datagrams(heard: Heard, host: str, port: int) -> ProtonUdp:
    """A UDP socket bound to ``host:port`` (port 0: any free one) whose datagrams go to
    ``heard(data, sender)``."""
    return await _bound(ProtonUdp(heard), host, port)


async def _bound(endpoint: ProtonUdp, host: str, port: int) -> ProtonUdp:
    import asyncio

    protocol = cast("asyncio.DatagramProtocol", endpoint)
    await asyncio.get_running_loop().create_datagram_endpoint(
        lambda: protocol, local_addr=(host, port)
    )
    return endpoint


async def open_proton_udp(
    node: Node,
    host: str | None = None,
    port: int | None = None,
    peers: Mapping[str, tuple[str, int]] | None = None,
    clock: Clock = time.monotonic,
    tick: float = 0.005,
    on_error: OnError | None = None,
) -> ProtonUdp:
    """``node`` on UDP: bound to ``host:port`` (default: its endpoint of its first udp4
    connection), sending each due bundle to its consumers' addresses (``peers`` by name; default:
    their endpoints of those connections), polled every ``tick`` seconds until closed."""
    import asyncio

    duration("tick", tick)
    local, addresses = _udp_addresses(node)
    addresses.update(peers or {})
    senders = {address: name for name, address in addresses.items()}
    ids = {n.id: n.name for n in node.codec.config.nodes if n.name in node.peers}
    counters = _Counters(on_error)

    def heard(data: bytes, sender: Any) -> None:
        header, message = split_udp_header(data)
        peer = senders.get((sender[0], sender[1]))
        if peer is None and header is not None:
            peer = ids.get(header.node_id)
        counters.receive(node, message, clock, peer)

    bound_host, bound_port = local or ("127.0.0.1", 0)
    endpoint = await _bound(
        ProtonUdp(heard, counters.stats),
        bound_host if host is None else host,
        bound_port if port is None else port,
    )

    async def polling() -> None:
        while True:
            for sent in node.poll(clock()):
                for peer in sent.peers:
                    if peer in addresses:
                        endpoint.sendto(sent.data, addresses[peer])
                        counters.sent += 1
            await asyncio.sleep(tick)

    poller = asyncio.get_running_loop().create_task(polling())
    endpoint.on_close = poller.cancel
    return endpoint


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
    """``node`` on a serial link (pyserial-asyncio's streams, a socket, a pipe): every frame that
    arrives is received from ``peer``, every due bundle for ``peer`` (any bundle, without one) is
    framed and written, until ``reader`` ends; the link's counters."""
    import asyncio

    duration("tick", tick)
    counters = _Counters(on_error)
    deframer = Deframer(max_length=_MAX_FRAME)

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

    poller = asyncio.get_running_loop().create_task(polling())
    try:
        while data := await reader.read(4096):
            for payload in deframer.feed(data):
                counters.receive(node, payload, clock, peer)
    finally:
        poller.cancel()
    return counters.stats()
