"""The live Foxglove view, watched by a real WebSocket client (the ``websockets`` package) on
127.0.0.1: what the server advertises, and what arrives, decoded with the advertised schemas
only (as Foxglove decodes them).

foxglove-sdk 0.30 speaks the subprotocol ``foxglove.sdk.v1`` and refuses a client that offers
only ``foxglove.websocket.v1`` (HTTP 400); the client here offers the one it accepts.
"""

import asyncio
import base64
import json
import socket
import struct
import subprocess
import sys
import time
from collections.abc import Callable
from typing import Any

from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from google.protobuf.message import Message
from recording_support import need

import erc_codec
from erc_schema import descriptor_of

SUBPROTOCOL = "foxglove.sdk.v1"


def message_class(channel: dict[str, Any]) -> type[Message]:
    """The class a client builds from an advertised protobuf channel, and nothing else."""
    assert channel["schemaEncoding"] == "protobuf"
    files = descriptor_pb2.FileDescriptorSet.FromString(base64.b64decode(channel["schema"]))
    pool = descriptor_pool.DescriptorPool()
    for file in files.file:  # dependencies first, so each adds cleanly
        pool.Add(file)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(channel["schemaName"]))


class Client:
    """A Foxglove WebSocket client: channels advertised, subscriptions, messages by topic."""

    def __init__(self, ws: Any) -> None:
        self.ws = ws
        self.channels: dict[str, dict[str, Any]] = {}
        self._topics: dict[int, str] = {}

    async def advertised(self, topics: set[str]) -> None:
        while not topics <= set(self.channels):
            frame = json.loads(await asyncio.wait_for(self.ws.recv(), 10))
            if frame["op"] == "advertise":
                for channel in frame["channels"]:
                    self.channels[channel["topic"]] = channel

    async def subscribe(self, topics: list[str]) -> None:
        subscriptions = []
        for number, topic in enumerate(topics, start=1):
            self._topics[number] = topic
            subscriptions.append({"id": number, "channelId": self.channels[topic]["id"]})
        await self.ws.send(json.dumps({"op": "subscribe", "subscriptions": subscriptions}))

    async def first_of_each(
        self, topics: set[str], poke: Callable[[], object]
    ) -> dict[str, tuple[int, bytes]]:
        """The first message on each topic (log time, payload), calling ``poke`` (which sends
        something) until all have come: what is logged before a subscription lands is lost."""
        got: dict[str, tuple[int, bytes]] = {}
        deadline = time.monotonic() + 20
        while not topics <= set(got):
            assert time.monotonic() < deadline, f"only {sorted(got)} arrived"
            poke()
            try:
                frame = await asyncio.wait_for(self.ws.recv(), 0.1)
            except asyncio.TimeoutError:  # not the builtin TimeoutError before Python 3.11
                continue
            if isinstance(frame, bytes) and frame[0] == 0x01:  # message data
                number, log_time = struct.unpack_from("<IQ", frame, 1)
                got.setdefault(self._topics[number], (log_time, frame[13:]))
        return got


def test_the_view_serves_every_kind_the_fix_drops_and_rates(codec: erc_codec.Codec) -> None:
    need("foxglove")
    websockets = need("websockets")
    view = erc_codec.capture.FoxgloveView(codec, port=0, interval=0.1)
    assert view.address[0] == "127.0.0.1"  # bound to loopback unless told otherwise
    gps = codec.message_class("SensorBoardGPSInfo")(
        latitude=52.2389,
        longitude=6.8566,
        altitude=40.5,
        fix_quality=2,
        utc_timestamp=1_700_000_000_250,
    )
    lost = codec.message_class("SensorBoardGPSInfo")(latitude=1.0, fix_quality=0)  # NO_FIX
    error = erc_codec.DecodeError("payload number 22 is not a member", "unknown_member")
    drop = erc_codec.runtime.Drop("unknown_member", None, bytes.fromhex("b20100"), error)

    def poke() -> None:
        view.message("gps_info", lost, log_time=1)
        view.message("gps_info", gps, log_time=2)
        view.drop(drop, "10.0.0.9:7", log_time=3)

    async def watch() -> dict[str, tuple[int, bytes]]:
        uri = "ws://{}:{}".format(*view.address)
        async with websockets.connect(uri, subprotocols=[SUBPROTOCOL]) as ws:
            assert ws.subprotocol == SUBPROTOCOL
            client = Client(ws)
            members = {f"/erc/{kind}" for kind in codec.kinds().values()}
            ours = {"/erc-codec/drops", "/erc-codec/fix", "/erc-codec/stats"}
            await client.advertised(members | ours)
            assert set(client.channels) == members | ours
            for kind in codec.kinds().values():
                channel = client.channels[f"/erc/{kind}"]
                payload = descriptor_of(codec.payload_class(kind)).full_name
                assert (channel["encoding"], channel["schemaName"]) == ("protobuf", payload)
                assert message_class(channel).DESCRIPTOR.full_name == payload
            watched.update(client.channels)
            await client.subscribe(["/erc/gps_info", *sorted(ours)])
            return await client.first_of_each({"/erc/gps_info", *ours}, poke)

    watched: dict[str, dict[str, Any]] = {}
    try:
        got = asyncio.run(watch())
    finally:
        view.close()
    _, data = got["/erc/gps_info"]
    assert data in (lost.SerializeToString(), gps.SerializeToString())
    advertised: Any = message_class(watched["/erc/gps_info"]).FromString(data)
    assert advertised.SerializeToString() == data
    fix: Any = message_class(watched["/erc-codec/fix"]).FromString(got["/erc-codec/fix"][1])
    assert watched["/erc-codec/fix"]["schemaName"] == "foxglove.LocationFix"
    assert (fix.latitude, fix.longitude, fix.altitude) == (
        52.2389,
        6.8566,
        40.5,
    )  # not the lost one
    assert (fix.timestamp.seconds, fix.timestamp.nanos) == (1_700_000_000, 250_000_000)
    assert fix.frame_id == "gps_info"
    dropped: Any = message_class(watched["/erc-codec/drops"]).FromString(got["/erc-codec/drops"][1])
    assert (dropped.reason, dropped.data, dropped.source) == (
        "unknown_member",
        drop.data,
        "10.0.0.9:7",
    )
    assert got["/erc-codec/drops"][0] == 3
    stats_channel = watched["/erc-codec/stats"]
    assert (stats_channel["encoding"], stats_channel["schemaEncoding"]) == ("json", "jsonschema")
    stats = json.loads(got["/erc-codec/stats"][1])
    assert set(stats) == {"received", "messages", "rates", "drops", "drop_rate", "view_errors"}
    assert stats["view_errors"] == 0
    assert stats["received"] == stats["messages"].get("gps_info", 0) + stats["drops"].get(
        "unknown_member", 0
    )
    assert set(stats["rates"]) <= {"gps_info"}


def test_a_fix_whose_time_a_timestamp_cannot_hold_is_shown_at_its_arrival(
    codec: erc_codec.Codec,
) -> None:
    need("foxglove")
    websockets = need("websockets")
    view = erc_codec.capture.FoxgloveView(codec, port=0)
    gps = codec.message_class("SensorBoardGPSInfo")(
        latitude=45.0, longitude=7.0, fix_quality=1, utc_timestamp=2**62
    )
    arrived = 1_700_000_000_123_456_789

    async def watch() -> dict[str, tuple[int, bytes]]:
        async with websockets.connect(
            "ws://{}:{}".format(*view.address), subprotocols=[SUBPROTOCOL]
        ) as ws:
            client = Client(ws)
            await client.advertised({"/erc-codec/fix"})
            watched.update(client.channels)
            await client.subscribe(["/erc-codec/fix"])
            return await client.first_of_each(
                {"/erc-codec/fix"}, lambda: view.message("gps_info", gps, log_time=arrived)
            )

    watched: dict[str, dict[str, Any]] = {}
    try:
        view.message("gps_info", gps, log_time=arrived)  # it raised OverflowError, unsubscribed
        got = asyncio.run(watch())
    finally:
        view.close()
    fix: Any = message_class(watched["/erc-codec/fix"]).FromString(got["/erc-codec/fix"][1])
    assert (fix.latitude, fix.longitude) == (45.0, 7.0)
    assert (fix.timestamp.seconds, fix.timestamp.nanos) == (1_700_000_000, 123_456_789)


def test_listen_foxglove_shows_what_arrives(codec: erc_codec.Codec) -> None:
    need("foxglove")
    websockets = need("websockets")
    listener = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "erc_codec",
            "listen",
            "127.0.0.1:0",
            "--foxglove",
            "--foxglove-address",
            "127.0.0.1:0",
            "--format",
            "json",
            "--seconds",
            "60",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert listener.stderr is not None
    served = listener.stderr.readline()
    assert served.startswith("foxglove on ws://127.0.0.1:"), served + listener.stderr.read()
    listening = listener.stderr.readline()
    assert listening.startswith("listening on 127.0.0.1:"), listening
    port = int(listening.rsplit(":", 1)[1])
    motor = codec.message_class("DrivingBoardMotorMessage")(distance_to_go=1.5, turning_radius=-2.0)
    datagram = codec.encode(motor)  # stripped, as the fleet sends it
    sender = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)

    async def watch() -> dict[str, tuple[int, bytes]]:
        async with websockets.connect(served.split()[2], subprotocols=[SUBPROTOCOL]) as ws:
            client = Client(ws)
            await client.advertised({"/erc/drive_motor"})
            watched.update(client.channels)
            await client.subscribe(["/erc/drive_motor"])
            return await client.first_of_each(
                {"/erc/drive_motor"}, lambda: sender.sendto(datagram, ("127.0.0.1", port))
            )

    watched: dict[str, dict[str, Any]] = {}
    try:
        before = time.time_ns()
        got = asyncio.run(watch())
    finally:
        sender.close()
        listener.send_signal(2)  # Ctrl-C
        out, err = listener.communicate(timeout=60)
    assert listener.returncode == 0, err
    log_time, data = got["/erc/drive_motor"]
    assert before <= log_time <= time.time_ns()  # the arrival time
    decoded: Any = message_class(watched["/erc/drive_motor"]).FromString(data)
    assert decoded.SerializeToString() == motor.SerializeToString()
    assert (decoded.distance_to_go, decoded.turning_radius) == (1.5, -2.0)
    lines = [json.loads(line) for line in out.splitlines()]  # listen's own output goes on
    assert lines
    assert {line["kind"] for line in lines} == {"drive_motor"}
    assert err.splitlines()[-1].startswith("counters: ")
