"""The asyncio shells, over real sockets on 127.0.0.1.

``import erc_codec`` never imports asyncio (the shells run inside a loop that has it already): the
imports are watched in a fresh interpreter. Kernel drops are made real: a flood into a small
receive buffer while the loop, and so the endpoint's reader, is not running.
"""

import asyncio
import math
import socket
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from google.protobuf.message import Message

import erc_codec

CODEC = erc_codec.Codec.default()
GPS = CODEC.message_class("SensorBoardGPSInfo")
MOTOR = CODEC.message_class("DrivingBoardMotorMessage")


async def until(condition: "asyncio.Future[object] | object", seconds: float = 10.0) -> None:
    deadline = asyncio.get_running_loop().time() + seconds
    while not condition() and asyncio.get_running_loop().time() < deadline:  # type: ignore[operator]
        await asyncio.sleep(0.005)


def test_udp_endpoints_talk_over_loopback() -> None:
    async def scenario() -> tuple[list[Message], erc_codec.runtime.DispatchStats, tuple[str, int]]:
        got: list[Message] = []
        receiver = erc_codec.runtime.Dispatcher(CODEC)
        receiver.register("gps_info", got.append)
        listening = await erc_codec.transport.open_udp(receiver)
        sender = await erc_codec.transport.open_udp(erc_codec.runtime.Dispatcher(CODEC))
        fix = GPS(latitude=52.2389, satellites=9)
        sender.send(fix, listening.address)
        sender.send(MOTOR(), listening.address, mode="pad")  # decodes, no handler
        raw = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        raw.sendto(bytes(300), listening.address)  # longer than PBEnvelope_size
        raw.close()
        await until(lambda: sum(receiver.stats().undecodable.values()) == 1 and got)
        await until(lambda: receiver.stats().unhandled)
        address = listening.address
        listening.close()
        sender.close()
        return got, receiver.stats(), address

    got, stats, address = asyncio.run(scenario())
    assert got == [GPS(latitude=52.2389, satellites=9)]
    assert stats.unhandled == {"drive_motor": 1}
    assert stats.undecodable == {"too_long": 1}
    assert address[0] == "127.0.0.1"


def test_the_watchdog_engages_when_a_stream_stops() -> None:
    async def scenario() -> list[str]:
        events: list[str] = []
        watchdog = erc_codec.runtime.Watchdog(
            on_timeout=lambda kind: events.append(f"timeout {kind}"),
            on_recover=lambda kind: events.append(f"recover {kind}"),
        )
        watchdog.watch("drive_motor", period=0.02, timeout=0.3)  # ample for a busy CI
        listening = await erc_codec.transport.open_udp(
            erc_codec.runtime.Dispatcher(CODEC), watchdog=watchdog, poll_interval=0.01
        )
        sender = await erc_codec.transport.open_udp(erc_codec.runtime.Dispatcher(CODEC))
        for _ in range(5):
            sender.send(MOTOR(distance_to_go=1.0), listening.address)
            await asyncio.sleep(0.02)
        await until(lambda: events)  # the sender stopped: brakes on
        sender.send(MOTOR(), listening.address)
        await until(lambda: len(events) > 1)
        listening.close()
        sender.close()
        return events

    # After the one recovering message the stream stops again, so a later timeout may follow.
    assert asyncio.run(scenario())[:2] == [
        "timeout drive_motor",
        "recover drive_motor",
    ]


def test_open_udp_watches_a_kind_by_the_timeout_its_sender_advertises() -> None:
    """Nobody configured drive_motor: its sender's advertised timeout (300 ms on the wire) makes
    the watchdog watch it, so its silence engages the brakes; a kind sent without one is only
    measured."""

    async def scenario() -> tuple[list[str], dict[str, float]]:
        events: list[str] = []
        watchdog = erc_codec.runtime.Watchdog(
            on_timeout=lambda kind: events.append(f"timeout {kind}")
        )
        arrivals: dict[str, float] = {}
        dispatcher = erc_codec.runtime.Dispatcher(CODEC)
        dispatcher.on_arrival = lambda kind, timeout: arrivals.setdefault(kind, timeout or 0.0)
        listening = await erc_codec.transport.open_udp(
            dispatcher, watchdog=watchdog, poll_interval=0.01
        )
        sender = await erc_codec.transport.open_udp(erc_codec.runtime.Dispatcher(CODEC))
        advertising = CODEC.encode(MOTOR(distance_to_go=1.0), timeout=300)
        sender.send_datagram(advertising, listening.address)
        sender.send(GPS(latitude=1.0), listening.address)
        await until(lambda: events)
        listening.close()
        sender.close()
        return events, arrivals

    events, arrivals = asyncio.run(scenario())
    assert events == ["timeout drive_motor"]
    assert arrivals == {"drive_motor": 0.3, "gps_info": 0.0}  # what was hooked before stays


def test_a_serial_stream_is_deframed_and_dispatched() -> None:
    async def scenario() -> tuple[list[Message], erc_codec.runtime.DeframerStats]:
        got: list[Message] = []
        dispatcher = erc_codec.runtime.Dispatcher(CODEC)
        dispatcher.register("gps_info", got.append)
        ours, theirs = socket.socketpair()
        reader, writer = await asyncio.open_connection(sock=ours)
        stream = b"\x00noise" + erc_codec.runtime.frame(CODEC.encode(GPS(latitude=1.0)))
        stream += erc_codec.runtime.frame(CODEC.encode(GPS(latitude=2.0)))
        for i in range(0, len(stream), 5):  # arrives in pieces
            theirs.sendall(stream[i : i + 5])
        theirs.close()
        deframer = await erc_codec.transport.read_serial(reader, dispatcher)
        writer.close()
        await writer.wait_closed()
        return got, deframer.stats()

    got, stats = asyncio.run(scenario())
    assert [m.latitude for m in got] == [1.0, 2.0]  # type: ignore[attr-defined]
    assert stats.frames == 2
    assert stats.discarded_bytes == {"garbage": 6}


def test_a_watchdog_poll_that_fails_closes_the_endpoint_and_wait_closed_raises_it() -> None:
    """A clock reading NaN once killed the poller task in silence: the watchdog stopped, the
    endpoint went on as if guarded."""
    readings = iter([0.0, 0.01])

    def clock() -> float:
        return next(readings, math.nan)

    def on_timeout(kind: str) -> None:
        raise RuntimeError(f"brakes on {kind} failed")

    async def scenario(
        clock: Callable[[], float], failing: bool
    ) -> tuple[BaseException | None, bool, bool]:
        watchdog = erc_codec.runtime.Watchdog(on_timeout=on_timeout if failing else None)
        watchdog.watch("drive_motor", period=0.001)
        watchdog.seen("drive_motor", 0.0)
        endpoint = await erc_codec.transport.open_udp(
            erc_codec.runtime.Dispatcher(CODEC), watchdog=watchdog, poll_interval=0.001, clock=clock
        )
        failure = None
        try:
            await asyncio.wait_for(endpoint.wait_closed(), 10)
        except (ValueError, RuntimeError) as error:
            failure = error
        reopened = await erc_codec.transport.open_udp(erc_codec.runtime.Dispatcher(CODEC))
        reopened.close()
        await reopened.wait_closed()  # a close() is no failure
        return failure, endpoint.closed, reopened.closed

    failure, closed, reopened = asyncio.run(scenario(clock, failing=False))
    assert isinstance(failure, ValueError)
    assert str(failure) == "now must be a finite clock reading in seconds, not nan"
    assert (closed, reopened) == (True, True)
    failure, closed, _ = asyncio.run(scenario(iter(range(10**6)).__next__, failing=True))
    assert isinstance(failure, RuntimeError)
    assert str(failure) == "brakes on drive_motor failed"
    assert closed


def test_a_frame_cut_off_by_the_end_of_the_stream_is_counted() -> None:
    async def scenario() -> tuple[erc_codec.runtime.DeframerStats, int]:
        dispatcher = erc_codec.runtime.Dispatcher(CODEC)
        ours, theirs = socket.socketpair()
        reader, writer = await asyncio.open_connection(sock=ours)
        whole = erc_codec.runtime.frame(CODEC.encode(GPS(latitude=1.0)))
        theirs.sendall(whole + whole[:-3])  # the second frame loses its last three bytes
        theirs.close()
        deframer = await erc_codec.transport.read_serial(reader, dispatcher)
        writer.close()
        await writer.wait_closed()
        assert dispatcher.stats().unhandled == {"gps_info": 1}
        return deframer.stats(), len(whole)

    stats, length = asyncio.run(scenario())
    assert stats.frames == 1
    assert stats.discarded_bytes == {"unfinished": length - 3}


def rcvbuf_errors() -> int:
    """Every UDP socket's receive-buffer drops on this machine (``/proc/net/snmp``)."""
    lines = Path("/proc/net/snmp").read_text().splitlines()
    names, values = (line.split()[1:] for line in lines if line.startswith("Udp:"))
    return int(dict(zip(names, values, strict=True))["RcvbufErrors"])


def flood(address: tuple[str, int], count: int) -> None:
    """``count`` datagrams sent at once, the loop (and the endpoint's reader) not running."""
    data = CODEC.encode(MOTOR(distance_to_go=1.0))
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as raw:
        for _ in range(count):
            raw.sendto(data, address)


def accounted(stats: "erc_codec.transport.UdpStats") -> int:
    """The datagrams an endpoint read or knows the kernel dropped."""
    assert stats.kernel_dropped is not None, "Linux tells the drops"
    return stats.received + stats.kernel_dropped


@pytest.mark.skipif(sys.platform != "linux", reason="the kernel's drop count is Linux's")
def test_every_datagram_is_received_or_counted_as_dropped_by_the_kernel() -> None:
    async def scenario() -> "list[erc_codec.transport.UdpStats]":
        dispatcher = erc_codec.runtime.Dispatcher(CODEC)
        endpoint = await erc_codec.transport.open_udp(
            dispatcher, receive_buffer=1
        )  # the least there is
        seen = []
        sent = 0
        for count in (2000, 2000, 1):  # the last one, queued after drops, carries their count
            flood(endpoint.address, count)
            sent += count
            await until(lambda total=sent: accounted(endpoint.stats()) >= total)
            await asyncio.sleep(0.05)  # nothing more comes
            seen.append(endpoint.stats())
        endpoint.close()
        seen.append(endpoint.stats())
        assert sum(dispatcher.stats().unhandled.values()) == seen[-1].received
        return seen

    before = rcvbuf_errors()
    first, second, third, closed = asyncio.run(scenario())
    after = rcvbuf_errors()
    assert [accounted(first), accounted(second), accounted(third)] == [2000, 4000, 4001]
    assert first.received < 10  # a buffer of a few datagrams: the rest were dropped
    assert third.kernel_dropped == second.kernel_dropped  # counted once, from either source
    assert closed == third  # the counts survive close
    assert after - before >= accounted(third) - third.received  # the system saw them too
    assert third.receive_buffer < 10_000  # Linux's minimum


@pytest.mark.skipif(sys.platform != "linux", reason="the buffer granted is Linux's arithmetic")
def test_the_receive_buffer_asked_for_is_granted_up_to_the_systems_cap() -> None:
    async def scenario() -> tuple[int, int]:
        default = await erc_codec.transport.open_udp(erc_codec.runtime.Dispatcher(CODEC))
        small = await erc_codec.transport.open_udp(
            erc_codec.runtime.Dispatcher(CODEC), receive_buffer=100_000
        )
        granted = default.stats().receive_buffer, small.stats().receive_buffer
        default.close()
        small.close()
        return granted

    cap = int(Path("/proc/sys/net/core/rmem_max").read_text())
    default, small = asyncio.run(scenario())
    assert default == 2 * min(4 << 20, cap)  # Linux doubles the request, for its bookkeeping
    assert small == 2 * min(100_000, cap)


def test_what_is_still_queued_at_close_is_counted_as_unread() -> None:
    async def scenario() -> "erc_codec.transport.UdpStats":
        dispatcher = erc_codec.runtime.Dispatcher(CODEC)
        endpoint = await erc_codec.transport.open_udp(dispatcher)
        flood(endpoint.address, 100)
        endpoint.close()  # before the loop ran the reader
        assert dispatcher.stats().unhandled == {}
        return endpoint.stats()

    stats = asyncio.run(scenario())
    assert (stats.received, stats.unread, stats.kernel_dropped or 0) == (0, 100, 0)


def test_an_endpoint_closed_by_its_listener_reads_no_further() -> None:
    async def scenario() -> "tuple[list[bytes], erc_codec.transport.UdpStats]":
        heard: list[bytes] = []
        endpoint: erc_codec.transport.UdpEndpoint

        def on_datagram(data: bytes, sender: object) -> None:
            heard.append(data)
            if len(heard) == 3:
                endpoint.close()

        endpoint = await erc_codec.transport.open_udp(
            erc_codec.runtime.Dispatcher(CODEC), on_datagram=on_datagram
        )
        flood(endpoint.address, 10)
        await until(lambda: len(heard) >= 3)
        await asyncio.sleep(0.05)
        return heard, endpoint.stats()

    heard, stats = asyncio.run(scenario())
    assert len(heard) == 3
    assert (stats.received, stats.unread) == (3, 7)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -1.0, 0.0])
def test_the_poll_interval_is_positive_finite_seconds(bad: float) -> None:
    async def scenario() -> None:
        watchdog = erc_codec.runtime.Watchdog()
        await erc_codec.transport.open_udp(
            erc_codec.runtime.Dispatcher(CODEC), watchdog=watchdog, poll_interval=bad
        )

    with pytest.raises(ValueError, match=r"^poll_interval must be a positive, finite number"):
        asyncio.run(scenario())


@pytest.mark.parametrize("bad", [0, -1, 1 << 31, 4.0, math.inf])
def test_the_receive_buffer_is_a_whole_number_of_bytes_a_socket_takes(bad: float) -> None:
    async def scenario() -> None:
        await erc_codec.transport.open_udp(erc_codec.runtime.Dispatcher(CODEC), receive_buffer=bad)  # type: ignore[arg-type]

    with pytest.raises(ValueError, match=r"^receive_buffer must be"):
        asyncio.run(scenario())


@pytest.mark.parametrize("bad", [0, -1, 1.5])
def test_the_serial_chunk_is_a_whole_number_of_bytes(bad: float) -> None:
    async def scenario() -> None:
        ours, theirs = socket.socketpair()
        theirs.close()  # the stream has ended: a chunk of -1 (read to the end) would not hang
        reader, writer = await asyncio.open_connection(sock=ours)
        try:
            dispatcher = erc_codec.runtime.Dispatcher(CODEC)
            await erc_codec.transport.read_serial(reader, dispatcher, chunk=bad)  # type: ignore[arg-type]
        finally:
            writer.close()
            await writer.wait_closed()

    with pytest.raises(ValueError, match=r"^chunk must be a whole number of at least 1"):
        asyncio.run(scenario())


@pytest.mark.parametrize("package", ["erc_codec", "erc_lint"])
def test_importing_a_package_does_not_import_asyncio(package: str) -> None:
    script = (  # nor socket (and selectors), which the UDP endpoint loads when it opens
        f"import sys, {package}\n"
        "print(sorted(n for n in sys.modules if n.split('.')[0] in ('asyncio', 'socket')))"
    )
    result = subprocess.run(  # -I: no PYTHON* variables, no user site, no working directory
        [sys.executable, "-I", "-c", script], capture_output=True, text=True, check=False
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "[]", f"import {package} imports {result.stdout.strip()}"


def test_an_endpoint_without_a_dispatcher_hears_and_sends_bytes_as_they_are() -> None:
    async def scenario() -> tuple[list[tuple[bytes, Any]], erc_codec.transport.UdpStats]:
        heard: list[tuple[bytes, Any]] = []
        relay = await erc_codec.transport.open_udp(
            None, on_datagram=lambda data, sender: heard.append((data, sender))
        )
        other = await erc_codec.transport.open_udp(None)
        for data in (b"\x4a", bytes(300), b"not protobuf"):  # bytes, judged by no one here
            other.send_datagram(data, relay.address)
        await until(lambda: len(heard) == 3)
        relay.close()
        other.close()
        return heard, relay.stats()

    heard, stats = asyncio.run(scenario())
    assert [data for data, _ in heard] == [b"\x4a", bytes(300), b"not protobuf"]
    assert heard[0][1][0] == "127.0.0.1"
    assert stats.received == 3
