"""erc_codec.proton's asyncio shells: two nodes over real UDP sockets on 127.0.0.1, and a node on
a serial byte stream (a socket pair), with the clock and the sockets real."""

import asyncio
import math
import socket
import subprocess
import sys

import pytest
from proton_values import TYPES_2_0

import erc_codec
from erc_codec.proton import (
    Bundle,
    BundleCodec,
    LinkStats,
    Node,
    UdpHeader,
    open_proton_udp,
    parse_config,
    run_proton_serial,
    split_udp_header,
)
from erc_codec.runtime import Liveness

CODEC = BundleCodec(TYPES_2_0)
COMMAND = CODEC.encode("command", {"set_speed": 1.25, "set_name": "go", "set_mask": b""})


async def until(condition: object, seconds: float = 10.0) -> None:
    deadline = asyncio.get_running_loop().time() + seconds
    while not condition() and asyncio.get_running_loop().time() < deadline:  # type: ignore[operator]
        await asyncio.sleep(0.005)


def test_two_nodes_over_udp() -> None:
    async def scenario() -> tuple[Liveness, object, int, dict[str, int]]:
        pc, mcu = Node(TYPES_2_0, "pc"), Node(TYPES_2_0, "mcu")
        pc_link = await open_proton_udp(pc, "127.0.0.1", 0, peers={})
        mcu_link = await open_proton_udp(mcu, "127.0.0.1", 0, peers={"pc": pc_link.address})
        mcu.set("a_double", 6.25)
        await until(lambda: pc.get("a_double") == 6.25)  # "everything", every 100 ms
        state = pc.peer_state("mcu")  # its heartbeats arrive every 50 ms
        raw = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            raw.sendto(b"\x0a\x03\x08\x99\x09", pc_link.address)  # a bundle no one configured
            await until(lambda: pc_link.stats().errors)
        finally:
            raw.close()
        pc_link.close()
        mcu_link.close()
        return state, pc.get("a_double"), mcu_link.stats().sent, pc_link.stats().errors

    state, value, sent, errors = asyncio.run(scenario())
    assert state is Liveness.ACTIVE
    assert value == 6.25
    assert sent >= 2
    assert errors == {"unknown_bundle": 1}


def test_a_2_0_senders_header_node_id_0_names_node_0() -> None:
    """Proton's proton_udp4_fill_header writes the sender's own node id: 0 is pc here."""
    config = parse_config(
        """\
nodes:
  - {name: pc, id: 0, endpoints: [{id: 0, type: udp4, ip: 127.0.0.1, port: 11416}]}
  - {name: mcu, id: 1, endpoints: [{id: 0, type: udp4, ip: 127.0.0.1, port: 11417}]}
connections:
  - {first: {node: pc, id: 0}, second: {node: mcu, id: 0}}
signals:
  - {name: beat, id: 1, type: uint32}
bundles:
  - {name: pulse, id: 1, producers: [pc], consumers: [mcu], signals: [1], period_ms: 50}
"""
    )
    pulse = BundleCodec(config).encode("pulse", {"beat": 1})

    async def scenario() -> Liveness:
        mcu = Node(config, "mcu")
        link = await open_proton_udp(mcu, "127.0.0.1", 0, peers={})  # pc's address unknown
        raw = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            raw.sendto(bytes([1, 0, 0, 0]) + pulse, link.address)
            await until(lambda: link.stats().received)
        finally:
            raw.close()
            link.close()
        return mcu.peer_state("pc")

    assert asyncio.run(scenario()) is Liveness.ACTIVE


def test_a_handler_that_raises_stops_a_udp_link_and_says_why() -> None:
    """Not a traceback per datagram logged by asyncio while the node goes on: the link
    closes, and wait_closed raises what stopped it."""

    async def scenario() -> tuple[bool, LinkStats]:
        mcu = Node(TYPES_2_0, "mcu")

        @mcu.on("command")
        def broken(bundle: Bundle) -> None:
            raise RuntimeError("the handler failed")

        link = await open_proton_udp(mcu, "127.0.0.1", 0, peers={})
        raw = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            raw.sendto(COMMAND, link.address)
            with pytest.raises(RuntimeError, match="the handler failed"):
                await asyncio.wait_for(link.wait_closed(), 10)
        finally:
            raw.close()
        return link.closed, link.stats()

    closed, stats = asyncio.run(scenario())
    assert closed
    assert stats.received == 0


def test_a_poller_that_fails_stops_a_udp_link_and_says_why() -> None:
    """The node refusing the clock (here: NaN) stops the sending, and says so."""

    async def scenario() -> bool:
        readings = iter([0.0, 0.01, math.nan])
        link = await open_proton_udp(
            Node(TYPES_2_0, "mcu"), "127.0.0.1", 0, peers={}, clock=lambda: next(readings)
        )
        with pytest.raises(ValueError, match="now must be a finite number of seconds, not nan"):
            await asyncio.wait_for(link.wait_closed(), 10)
        return link.closed

    assert asyncio.run(scenario())


def test_a_closed_udp_link_waits_for_nothing() -> None:
    async def scenario() -> LinkStats:
        link = await open_proton_udp(Node(TYPES_2_0, "mcu"), "127.0.0.1", 0, peers={})
        link.close()
        link.close()
        await asyncio.wait_for(link.wait_closed(), 10)
        return link.stats()

    assert asyncio.run(scenario()) == LinkStats(0, 0, {}, 0)


def test_a_2_0_senders_udp_header_is_read_and_names_the_sender() -> None:
    assert split_udp_header(b"\x01\x07\x00\x00\x0a\x00") == (UdpHeader(1, 7, 0, 0), b"\x0a\x00")
    assert split_udp_header(b"\x0a\x00") == (None, b"\x0a\x00")
    heartbeat = CODEC.encode("heartbeat", {"beat": 9})

    async def scenario() -> tuple[Liveness, object]:
        pc = Node(TYPES_2_0, "pc")
        link = await open_proton_udp(pc, "127.0.0.1", 0, peers={})
        raw = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            raw.sendto(bytes([1, 1, 0, 0]) + heartbeat, link.address)  # node 1 is mcu
            await until(lambda: link.stats().received)
        finally:
            raw.close()
            link.close()
        return pc.peer_state("mcu"), pc.get("beat")

    assert asyncio.run(scenario()) == (Liveness.ACTIVE, 9)


def test_a_node_on_a_serial_stream() -> None:
    async def scenario() -> tuple[set[str], object, erc_codec.proton.LinkStats]:
        board_side, our_side = socket.socketpair()
        mcu = Node(TYPES_2_0, "mcu")
        reader, writer = await asyncio.open_connection(sock=our_side)
        board_reader, board_writer = await asyncio.open_connection(sock=board_side)
        link = asyncio.get_running_loop().create_task(run_proton_serial(mcu, reader, writer))
        board_writer.write(b"noise" + erc_codec.runtime.frame(COMMAND)[:5])  # in two pieces
        await board_writer.drain()
        board_writer.write(
            erc_codec.runtime.frame(COMMAND)[5:] + erc_codec.runtime.frame(b"\x0a\x00")
        )
        await board_writer.drain()
        deframer = erc_codec.runtime.Deframer(max_length=0xFFFF)
        heard: set[str] = set()

        async def hear_all() -> None:
            while not {"everything", "heartbeat", "slow"} <= heard:  # 100, 50 and 120 ms
                chunk = await board_reader.read(4096)
                assert chunk, "the link stopped writing"
                heard.update(CODEC.decode(p).name for p in deframer.feed(chunk))

        await asyncio.wait_for(hear_all(), 10)  # a deadline: never a hang
        await until(lambda: mcu.get("set_speed") == 1.25)
        board_writer.close()
        stats = await link
        writer.close()
        return heard, mcu.get("set_name"), stats

    heard, name, stats = asyncio.run(scenario())
    assert heard == {"everything", "heartbeat", "slow"}  # what the mcu sends on its own
    assert name == "go"
    assert stats.received == 1
    assert stats.errors == {"corrupt": 1}  # bundle 0 without its counter
    assert stats.sent >= 3


def test_a_serial_link_that_cannot_go_on_raises_what_stopped_it() -> None:
    """A write that fails (the device went away), a handler or on_peer raising, the node
    refusing the clock: run_proton_serial stops reading and writing and raises it, where the
    poller used to die unseen while the link went on receiving."""

    async def link(node: Node, board: bytes, clock: object = None, gone: bool = False) -> None:
        board_side, our_side = socket.socketpair()
        reader, writer = await asyncio.open_connection(sock=our_side)
        _, board_writer = await asyncio.open_connection(sock=board_side)
        board_writer.write(board)
        await board_writer.drain()
        writing = writer
        if gone:  # writes go to a device that is gone, while reading waits on
            device, ours = socket.socketpair()
            device.close()
            _, writing = await asyncio.open_connection(sock=ours)
        try:
            extra = {"clock": clock} if clock is not None else {}
            await asyncio.wait_for(run_proton_serial(node, reader, writing, **extra), 10)  # type: ignore[arg-type]
        finally:
            for stream in {writer, writing, board_writer}:
                stream.close()

    framed = erc_codec.runtime.frame(COMMAND)
    broken = Node(TYPES_2_0, "mcu")

    @broken.on("command")
    def handler(bundle: Bundle) -> None:
        raise RuntimeError("the handler failed")

    with pytest.raises(RuntimeError, match="the handler failed"):
        asyncio.run(link(broken, framed))
    readings = iter([0.0, 0.01, math.nan])
    with pytest.raises(ValueError, match="now must be a finite number of seconds, not nan"):
        asyncio.run(link(Node(TYPES_2_0, "mcu"), b"", lambda: next(readings)))
    with pytest.raises(ConnectionError):
        asyncio.run(link(Node(TYPES_2_0, "mcu"), b"", time_passing(), gone=True))
    noisy = Node(TYPES_2_0, "pc", on_peer=lambda peer, state: 1 / 0)
    heartbeat = erc_codec.runtime.frame(CODEC.encode("heartbeat", {"beat": 1}))
    with pytest.raises(ZeroDivisionError):
        asyncio.run(link(noisy, heartbeat))


def time_passing() -> object:
    """A clock a second on at every reading: every bundle due at every poll."""
    seconds = iter(range(1_000_000))
    return lambda: float(next(seconds))


def test_importing_erc_codec_proton_loads_neither_asyncio_nor_yaml() -> None:
    code = "import sys, erc_codec.proton; print(sorted({'asyncio', 'yaml'} & set(sys.modules)))"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "[]"


@pytest.mark.parametrize("bad", [math.nan, math.inf, 0.0, -0.005])
def test_the_tick_is_positive_finite_seconds(bad: float) -> None:
    async def scenario() -> None:
        ours, theirs = socket.socketpair()
        reader, writer = await asyncio.open_connection(sock=ours)
        try:
            with pytest.raises(ValueError, match=r"^tick must be a positive, finite number"):
                await open_proton_udp(Node(TYPES_2_0, "pc"), "127.0.0.1", 0, peers={}, tick=bad)
            with pytest.raises(ValueError, match=r"^tick must be a positive, finite number"):
                await run_proton_serial(Node(TYPES_2_0, "pc"), reader, writer, tick=bad)
        finally:
            theirs.close()
            writer.close()
            await writer.wait_closed()

    asyncio.run(scenario())
