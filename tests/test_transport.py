"""The asyncio shells, over real sockets on 127.0.0.1.

UdpEndpoint implements asyncio's datagram protocol itself rather than inheriting it, so that
``import erc_codec`` never imports asyncio: it is held to asyncio.DatagramProtocol's methods, and
the imports are watched in a fresh interpreter.
"""

import asyncio
import inspect
import socket
import subprocess
import sys
from collections.abc import Callable

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
    async def scenario() -> tuple[list[Message], erc_codec.DispatchStats, tuple[str, int]]:
        got: list[Message] = []
        receiver = erc_codec.Dispatcher(CODEC)
        receiver.register("gps_info", got.append)
        listening = await erc_codec.open_udp(receiver)
        sender = await erc_codec.open_udp(erc_codec.Dispatcher(CODEC))
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
    assert stats.unhandled == {"driving_motor_message": 1}
    assert stats.undecodable == {"too_long": 1}
    assert address[0] == "127.0.0.1"


def test_the_watchdog_engages_when_a_stream_stops() -> None:
    async def scenario() -> list[str]:
        events: list[str] = []
        watchdog = erc_codec.Watchdog(
            on_timeout=lambda kind: events.append(f"timeout {kind}"),
            on_recover=lambda kind: events.append(f"recover {kind}"),
        )
        watchdog.watch("driving_motor_message", period=0.02, timeout=0.3)  # ample for a busy CI
        listening = await erc_codec.open_udp(
            erc_codec.Dispatcher(CODEC), watchdog=watchdog, poll_interval=0.01
        )
        sender = await erc_codec.open_udp(erc_codec.Dispatcher(CODEC))
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
        "timeout driving_motor_message",
        "recover driving_motor_message",
    ]


def test_a_serial_stream_is_deframed_and_dispatched() -> None:
    async def scenario() -> tuple[list[Message], erc_codec.DeframerStats]:
        got: list[Message] = []
        dispatcher = erc_codec.Dispatcher(CODEC)
        dispatcher.register("gps_info", got.append)
        ours, theirs = socket.socketpair()
        reader, writer = await asyncio.open_connection(sock=ours)
        stream = b"\x00noise" + erc_codec.frame(CODEC.encode(GPS(latitude=1.0)))
        stream += erc_codec.frame(CODEC.encode(GPS(latitude=2.0)))
        for i in range(0, len(stream), 5):  # arrives in pieces
            theirs.sendall(stream[i : i + 5])
        theirs.close()
        deframer = await erc_codec.read_serial(reader, dispatcher)
        writer.close()
        await writer.wait_closed()
        return got, deframer.stats()

    got, stats = asyncio.run(scenario())
    assert [m.latitude for m in got] == [1.0, 2.0]  # type: ignore[attr-defined]
    assert stats.frames == 2
    assert stats.discarded_bytes == {"garbage": 6}


def parameters(method: Callable[..., object]) -> list[tuple[object, object]]:
    """How a method can be called: each parameter's kind and default (asyncio passes arguments
    by position, so the names are free)."""
    return [(p.kind, p.default) for p in inspect.signature(method).parameters.values()]


@pytest.mark.parametrize("protocol", [asyncio.BaseProtocol, asyncio.DatagramProtocol])
def test_the_endpoint_has_every_method_of_asyncios_datagram_protocol(protocol: type) -> None:
    names = [name for name in dir(protocol) if not name.startswith("_")]
    assert "connection_made" in names
    for name in names:
        theirs = getattr(protocol, name)
        ours = getattr(erc_codec.UdpEndpoint, name, None)
        assert callable(ours), f"UdpEndpoint lacks {protocol.__name__}.{name}"
        assert inspect.iscoroutinefunction(ours) == inspect.iscoroutinefunction(theirs), name
        assert parameters(ours) == parameters(theirs), name


@pytest.mark.parametrize("package", ["erc_codec", "erc_lint"])
def test_importing_a_package_does_not_import_asyncio(package: str) -> None:
    script = (
        f"import sys, {package}\n"
        "print(sorted(n for n in sys.modules if n == 'asyncio' or n.startswith('asyncio.')))"
    )
    result = subprocess.run(  # -I: no PYTHON* variables, no user site, no working directory
        [sys.executable, "-I", "-c", script], capture_output=True, text=True, check=False
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "[]", f"import {package} imports {result.stdout.strip()}"
