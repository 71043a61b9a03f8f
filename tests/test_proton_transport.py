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
from erc_codec import Liveness
from erc_codec.proton import (
    BundleCodec,
    Node,
    UdpHeader,
    open_proton_udp,
    run_proton_serial,
    split_udp_header,
)

CODEC = BundleCodec(TYPES_2_0)


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
        command = CODEC.encode("command", {"set_speed": 1.25, "set_name": "go", "set_mask": b""})
        board_writer.write(b"noise" + erc_codec.frame(command)[:5])  # in two pieces
        await board_writer.drain()
        board_writer.write(erc_codec.frame(command)[5:] + erc_codec.frame(b"\x0a\x00"))
        await board_writer.drain()
        deframer = erc_codec.Deframer(max_length=0xFFFF)
        heard: set[str] = set()
        while not {"everything", "heartbeat", "slow"} <= heard:  # 100, 50 and 120 ms
            heard |= {CODEC.decode(p).name for p in deframer.feed(await board_reader.read(4096))}
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
