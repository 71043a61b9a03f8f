"""erc-codec record and replay, end to end over 127.0.0.1: a recorder process fed by a real socket,
read back with the mcap library; replays caught by a real socket, bytes and timing measured."""

import contextlib
import json
import os
import signal
import socket
import struct
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
from datagrams import MODES, beside
from recording_support import (
    enhanced,
    frame,
    interface,
    metadata,
    need,
    read_back,
    section,
    simple,
    write_pcap,
)

import erc_codec
from erc_codec.capture._recording import file_descriptor_set
from erc_codec.codec._unknown import MAX_UNKEPT_NUMBERS
from erc_schema import descriptor_of

SO_TIMESTAMPNS = getattr(socket, "SO_TIMESTAMPNS", 35)  # Linux's number, where Python lacks it


def start_recorder(out: Path, *args: str) -> tuple[subprocess.Popen[str], int]:
    recorder = subprocess.Popen(
        [sys.executable, "-m", "erc_codec", "record", "127.0.0.1:0", str(out), *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert recorder.stderr is not None
    first = recorder.stderr.readline()  # "recording on 127.0.0.1:PORT to OUT"
    assert first.startswith("recording on 127.0.0.1:"), first + recorder.stderr.read()
    return recorder, int(first.split()[2].rsplit(":", 1)[1])


def summary(err: str, prefix: str) -> dict[str, Any]:
    line = err.strip().splitlines()[-1]
    assert line.startswith(prefix), err
    result: dict[str, Any] = json.loads(line.removeprefix(prefix))
    return result


def fleet(codec: erc_codec.Codec) -> list[bytes]:
    """Datagrams as the fleet sends them: every form, all-default payloads, garbage."""
    gps = codec.message_class("SensorBoardGPSInfo")(latitude=52.2389, longitude=6.8566)
    feedback = codec.message_class("ArmBoardMovementFeedback")()
    motor = codec.message_class("DrivingBoardMotorMessage")(distance_to_go=1.5)
    return [codec.encode(p, m) for p in (gps, feedback, motor) for m in MODES] + [
        bytes.fromhex("b20100"),
        bytes.fromhex("6205ff"),
    ]


@pytest.mark.parametrize("stop", ["count", "sigterm", "sigint", "sighup"])
def test_record_writes_what_arrives(codec: erc_codec.Codec, tmp_path: Path, stop: str) -> None:
    need("mcap")
    out = tmp_path / "run.mcap"
    sent = fleet(codec)
    args = ["--count", str(len(sent))] if stop == "count" else ["--seconds", "60"]
    recorder, port = start_recorder(out, *args)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sender:
        sender.bind(("127.0.0.1", 0))
        source = f"127.0.0.1:{sender.getsockname()[1]}"
        before = time.time_ns()
        for data in sent:
            sender.sendto(data, ("127.0.0.1", port))
            time.sleep(0.002)
        if stop != "count":
            time.sleep(0.3)  # let them be read before the signal
            recorder.send_signal(getattr(signal, stop.upper()))  # SIGHUP: an ssh session drops
        _, err = recorder.communicate(timeout=60)
    after = time.time_ns()
    assert recorder.returncode == 0, err
    result = summary(err, "recorded: ")
    assert result["received"] == len(sent)
    assert result["messages"] == {
        "gps_info": 3,
        "arm_feedback": 3,
        "drive_motor": 3,
    }
    assert result["drops"] == {"unknown_member": 1, "corrupt": 1}
    assert result["dropped_by_kernel"] == 0
    assert result["bytes"] == out.stat().st_size
    messages = read_back(out)
    assert len(messages) == len(sent)
    times = [m.message.log_time for m in messages]
    assert before <= times[0]
    assert times == sorted(times)
    assert times[-1] <= after
    assert [m.message.sequence for m in messages] == list(range(1, len(sent) + 1))
    for data, read in zip(sent, messages, strict=True):
        if read.channel.topic == "/erc-codec/drops":
            assert (read.decoded_message.data, read.decoded_message.source) == (data, source)
        else:
            kind, message = codec.decode(data)
            assert read.channel.topic == f"/erc/{kind}"
            assert read.message.data == message.SerializeToString()


def test_record_counts_the_fields_beside_the_payload_it_cannot_keep(tmp_path: Path) -> None:
    need("mcap")
    out = tmp_path / "newer.mcap"
    sent = [bytes.fromhex("6200a00101"), bytes.fromhex("6200c2020201ff"), bytes.fromhex("6200")]
    recorder, port = start_recorder(out, "--count", str(len(sent)))
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sender:
        for data in sent:
            sender.sendto(data, ("127.0.0.1", port))
            time.sleep(0.002)
        _, err = recorder.communicate(timeout=60)
    assert recorder.returncode == 0, err
    result = summary(err, "recorded: ")
    assert (result["messages"], result["unkept"]) == ({"gps_info": 3}, {"20": 1, "40": 1})
    assert [m.message.data for m in read_back(out)] == [b""] * 3
    written = metadata(out)["erc-codec.summary"]
    assert (written["unkept.20"], written["unkept.40"]) == ("1", "1")


def test_record_counts_the_fields_past_its_unkept_tables_bound(tmp_path: Path) -> None:
    """Ever new field numbers beside the payload: the summaries list the first numbers to come,
    no more, and count every field of the others, once per datagram and number."""
    need("mcap")
    out = tmp_path / "newer.mcap"
    numbers = list(range(1000, 1000 + MAX_UNKEPT_NUMBERS + 100))
    rounds = [numbers[start : start + 50] for start in range(0, len(numbers), 50)]
    sent = [beside(numbers_of_one) for numbers_of_one in rounds * 2]
    recorder, port = start_recorder(out, "--count", str(len(sent)))
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sender:
        for data in sent:
            sender.sendto(data, ("127.0.0.1", port))
            time.sleep(0.002)
        _, err = recorder.communicate(timeout=60)
    assert recorder.returncode == 0, err
    result = summary(err, "recorded: ")
    assert result["messages"] == {"gps_info": len(sent)}
    assert result["unkept"] == {str(number): 2 for number in numbers[:MAX_UNKEPT_NUMBERS]}
    assert result["unkept_unlisted"] == 2 * 100
    written = metadata(out)["erc-codec.summary"]
    assert {key: n for key, n in written.items() if key.startswith("unkept.")} == {
        **{f"unkept.{number}": "2" for number in numbers[:MAX_UNKEPT_NUMBERS]},
        "unkept.unlisted": "200",
    }


def test_record_refuses_to_overwrite_and_to_bind_twice(tmp_path: Path) -> None:
    need("mcap")
    out = tmp_path / "old.mcap"
    out.write_bytes(b"last week's run")
    done = subprocess.run(
        [sys.executable, "-m", "erc_codec", "record", "127.0.0.1:0", str(out), "--seconds", "1"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert (done.returncode, done.stderr) == (
        2,
        f"Error: {out} exists: remove it or choose another name\n",
    )
    assert out.read_bytes() == b"last week's run"
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as taken:
        taken.bind(("127.0.0.1", 0))
        port = taken.getsockname()[1]
        done = subprocess.run(
            [
                sys.executable,
                "-m",
                "erc_codec",
                "record",
                f"127.0.0.1:{port}",
                str(tmp_path / "new.mcap"),
            ],
            capture_output=True,
            text=True,
            timeout=60,
        )
    assert done.returncode == 2
    assert done.stderr.startswith(f"Error: cannot listen on 127.0.0.1:{port}:")
    assert not (tmp_path / "new.mcap").exists()


def _children(pid: int) -> list[int]:
    found = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        with contextlib.suppress(OSError):
            fields = stat.read_text().rsplit(")", 1)[1].split()
            if int(fields[1]) == pid:
                found.append(int(stat.parent.name))
    return found


def _running(pid: int) -> bool:
    """Whether ``pid`` still runs (a zombie nobody reaps has finished)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def test_a_recorder_killed_leaves_its_writer_to_finish_the_file(
    codec: erc_codec.Codec, tmp_path: Path
) -> None:
    need("mcap")
    out = tmp_path / "run.mcap"
    sent = fleet(codec)
    recorder, port = start_recorder(out, "--seconds", "60")
    (writer,) = _children(recorder.pid)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sender:
        for data in sent:
            sender.sendto(data, ("127.0.0.1", port))
    time.sleep(0.5)  # read, and handed over (every 0.05 s)
    recorder.kill()  # SIGKILL: no handler runs in the recorder
    recorder.wait(timeout=60)
    deadline = time.monotonic() + 30
    while _running(writer) and time.monotonic() < deadline:
        time.sleep(0.05)
    lingers = _running(writer)
    if lingers:
        os.kill(writer, signal.SIGKILL)
    recorder.communicate(timeout=60)  # the pipes, which the writer held open too
    assert not lingers, "the writer lingers after its recorder died"
    assert len(read_back(out)) == len(sent)  # a complete file: indexed, CRCs right
    ended = metadata(out)["erc-codec.summary"]["ended"]
    assert ended == "the recording process stopped unannounced"


def test_record_never_writes_through_a_name_that_exists(tmp_path: Path) -> None:
    """The open itself refuses (O_EXCL), so nothing that appears at the name is written over
    or through: a link planted there, pointing nowhere yet, is no way to write elsewhere."""
    need("mcap")
    out, target = tmp_path / "run.mcap", tmp_path / "elsewhere"
    out.symlink_to(target)  # dangling: a check with exists() sees nothing there
    recorder = subprocess.run(
        [sys.executable, "-m", "erc_codec", "record", "127.0.0.1:0", str(out), "--seconds", "1"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert (recorder.returncode, recorder.stderr) == (
        2,
        f"Error: {out} exists: remove it or choose another name\n",
    )
    assert not target.exists()


# -- replay ------------------------------------------------------------------------------------


class Catcher:
    """A socket on 127.0.0.1 that keeps what arrives, with the kernel's arrival times (Linux's
    SO_TIMESTAMPNS: when the datagram was received, however late this process reads it)."""

    def __init__(self) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setsockopt(socket.SOL_SOCKET, SO_TIMESTAMPNS, 1)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(10)
        self.address = f"127.0.0.1:{self.sock.getsockname()[1]}"

    def take(self, count: int) -> list[tuple[float, bytes]]:
        got = []
        for _ in range(count):
            data, ancillary, _, _ = self.sock.recvmsg(65535, 64)
            (seconds, nanos) = next(
                struct.unpack("@qq", cmsg_data[:16])
                for level, kind, cmsg_data in ancillary
                if level == socket.SOL_SOCKET and kind == SO_TIMESTAMPNS
            )
            got.append((seconds + nanos / 1e9, data))
        self.sock.settimeout(0.2)
        with pytest.raises(TimeoutError):
            self.sock.recv(65535)  # nothing more
        return got

    def close(self) -> None:
        self.sock.close()


@pytest.fixture
def catcher() -> Any:
    caught = Catcher()
    yield caught
    caught.close()


def replay(source: Path, catcher: Catcher, *args: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-m", "erc_codec", "replay", str(source), catcher.address, *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


JITTER = 0.01  # seconds a receiver on a loaded machine may take a datagram late


def finished(process: subprocess.Popen[str]) -> dict[str, Any]:
    _, err = process.communicate(timeout=60)
    assert process.returncode == 0, err
    return summary(err, "replayed: ")


def test_replay_a_capture_at_its_timing(
    codec: erc_codec.Codec, tmp_path: Path, catcher: Catcher
) -> None:
    need("dpkt")
    sent = fleet(codec)
    capture = tmp_path / "field.pcap"
    write_pcap(capture, sent, step=0.1)
    process = replay(capture, catcher, "--speed", "2")
    got = catcher.take(len(sent) - 2)  # as they arrive
    result = finished(process)
    # Never early: each leaves at its recorded time from the first, halved (give or take how late
    # the catcher, on a loaded machine, took the first: an early send would be a whole step).
    for (first, _), (later, _), number in zip(
        [got[0]] * len(got), got, range(len(got)), strict=True
    ):
        assert later - first >= number * 0.05 - JITTER
    assert got[-1][0] - got[0][0] < (len(got) - 1) * 0.05 + 0.5
    assert [data for _, data in got] == [
        codec.encode(codec.decode(data).message) for data in sent[:-2]
    ]  # re-encoded stripped, the default
    assert result["sent"] == len(sent) - 2
    assert result["by_kind"] == {
        "arm_feedback": 3,
        "drive_motor": 3,
        "gps_info": 3,
    }
    assert result["skipped"] == {"drops": 2}
    assert result["recorded_seconds"] == pytest.approx((len(sent) - 3) * 0.1)
    assert result["latest_ms"] >= 0


def test_replay_a_pcapng_capture_at_its_timing(
    codec: erc_codec.Codec, tmp_path: Path, catcher: Catcher
) -> None:
    dpkt = need("dpkt")
    sent = fleet(codec)[:-2]
    capture = tmp_path / "field.pcapng"
    with capture.open("wb") as file:  # dpkt's pcapng writer: section, interface, packet blocks
        writer = dpkt.pcapng.Writer(file)
        for number, data in enumerate(sent):
            writer.writepkt(frame(data), ts=1_700_000_000 + number * 0.08)
    process = replay(capture, catcher, "--speed", "4", "--mode", "pad")
    got = catcher.take(len(sent))
    result = finished(process)
    for number, (at, _) in enumerate(got):
        assert at - got[0][0] >= number * 0.02 - JITTER  # never early
    assert got[-1][0] - got[0][0] < (len(sent) - 1) * 0.02 + 0.5
    assert [data for _, data in got] == [
        codec.encode(codec.decode(data).message, "pad") for data in sent
    ]
    assert result["sent"] == len(sent)
    assert result["recorded_seconds"] == pytest.approx((len(sent) - 1) * 0.08)


def test_replay_sends_a_simple_packet_blocks_datagram_right_after_the_one_before(
    codec: erc_codec.Codec, tmp_path: Path, catcher: Catcher
) -> None:
    """A Simple Packet Block carries no time: its datagram is sent, with no wait of its own."""
    need("dpkt")
    sent = fleet(codec)[:3]
    capture = tmp_path / "simple.pcapng"
    capture.write_bytes(
        section()
        + interface(1)
        + simple(frame(sent[0]))
        + enhanced(0, 1_700_000_000_000_000, frame(sent[1]))
        + simple(frame(sent[2]))
    )
    result = finished(replay(capture, catcher))
    got = [data for _, data in catcher.take(len(sent))]
    assert got == [codec.encode(codec.decode(data).message) for data in sent]
    assert (result["sent"], result["recorded_seconds"]) == (len(sent), 0.0)


def test_replay_of_a_damaged_capture_sends_what_came_before(
    codec: erc_codec.Codec, tmp_path: Path, catcher: Catcher
) -> None:
    need("dpkt")
    sent = fleet(codec)[:3]
    capture = tmp_path / "cut.pcap"
    write_pcap(capture, sent)
    capture.write_bytes(capture.read_bytes()[:-3])  # cut inside the last packet
    process = replay(capture, catcher, "--as-fast-as-possible")
    got = catcher.take(2)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 1, err
    assert [data for _, data in got] == [codec.encode(codec.decode(d).message) for d in sent[:2]]
    *_, line, error = err.splitlines()
    assert json.loads(line.removeprefix("replayed: "))["sent"] == 2
    assert error == f"Error: {capture} is cut off inside packet 3"


@pytest.mark.parametrize("mode", MODES)
def test_replay_a_recording_in_the_form_asked(
    codec: erc_codec.Codec, tmp_path: Path, catcher: Catcher, mode: str
) -> None:
    need("mcap")
    sent = fleet(codec)
    recording = tmp_path / "run.mcap"
    with erc_codec.capture.McapWriter(recording, codec) as writer:
        for number, data in enumerate(sent):
            writer.write(data, 1_700_000_000_000_000_000 + number * 1_000_000)
    result = finished(
        replay(recording, catcher, "--mode", mode, "--drops", "--as-fast-as-possible")
    )
    got = [data for _, data in catcher.take(len(sent))]
    expected = [codec.encode(codec.decode(d).message, mode) for d in sent[:-2]] + sent[-2:]  # type: ignore[arg-type]
    assert got == expected
    assert result["by_kind"]["drops"] == 2
    assert result["skipped"] == {}


def test_replay_sends_an_empty_datagram_recorded_as_a_drop(
    codec: erc_codec.Codec, tmp_path: Path, catcher: Catcher
) -> None:
    need("mcap")
    recording = tmp_path / "run.mcap"
    with erc_codec.capture.McapWriter(recording, codec) as writer:
        writer.write(b"", 1_700_000_000_000_000_000)  # an empty UDP payload is a datagram too
    result = finished(replay(recording, catcher, "--drops", "--as-fast-as-possible"))
    assert [data for _, data in catcher.take(1)] == [b""]
    assert (result["by_kind"], result["skipped"]) == ({"drops": 1}, {})


def test_replay_of_a_damaged_recording_is_a_read_error_not_a_send_error(
    codec: erc_codec.Codec, tmp_path: Path, catcher: Catcher
) -> None:
    need("mcap")
    recording = tmp_path / "run.mcap"
    with erc_codec.capture.McapWriter(recording, codec) as writer:
        for number, data in enumerate(fleet(codec)):
            writer.write(data, 1_700_000_000_000_000_000 + number)
    whole = recording.read_bytes()
    for cut in (len(whole) // 2, len(whole) - 20, len(whole) - 1):
        recording.write_bytes(whole[:cut])
        process = replay(recording, catcher, "--as-fast-as-possible")
        _, err = process.communicate(timeout=60)
        assert process.returncode in (1, 2), err
        assert err.splitlines()[-1].startswith(
            f"Error: {recording} is not a readable MCAP recording: "
        ), err


@pytest.mark.parametrize(
    ("encoding", "schema_encoding", "schema", "data", "why"),
    [
        ("json", "jsonschema", b"{}", b"", "/erc/gps_info is not protobuf"),
        ("protobuf", "protobuf", b"\xff", b"\x68\x05", "the schema of /erc/gps_info does not load"),
        ("protobuf", "protobuf", None, b"\xff", "a message on /erc/gps_info does not parse"),
    ],
)
def test_replay_refuses_a_recording_read_mcap_refuses(
    codec: erc_codec.Codec,
    tmp_path: Path,
    catcher: Catcher,
    encoding: str,
    schema_encoding: str,
    schema: bytes | None,
    data: bytes,
    why: str,
) -> None:
    """Another tool's MCAP whose /erc/gps_info holds what its schema does not read as the
    payload: replay sends none of it, with read_mcap's own error."""
    need("mcap")
    writer_module = need("mcap.writer")
    recording = tmp_path / "foreign.mcap"
    gps = codec.message_class("SensorBoardGPSInfo")
    with recording.open("wb") as file:
        foreign = writer_module.Writer(file)
        foreign.start()
        if schema is None:  # the payload's own schema, as record writes it
            schema = file_descriptor_set(descriptor_of(gps))
        name = descriptor_of(gps).full_name
        registered = foreign.register_schema(name, schema_encoding, schema)
        channel = foreign.register_channel("/erc/gps_info", encoding, registered)
        foreign.add_message(channel, 1_700_000_000_000_000_000, data, 1_700_000_000_000_000_000)
        foreign.finish()
    with pytest.raises(erc_codec.CodecError) as refused:
        list(erc_codec.capture.read_mcap(recording))
    assert str(refused.value).startswith(f"{recording} is not a readable MCAP recording: {why}")
    process = replay(recording, catcher, "--as-fast-as-possible")
    _, err = process.communicate(timeout=60)
    assert process.returncode == 1, err
    assert err.splitlines()[-1] == f"Error: {refused.value}"
    assert "Traceback" not in err
    assert catcher.take(0) == []  # nothing sent


def test_replay_only_the_kinds_asked(
    codec: erc_codec.Codec, tmp_path: Path, catcher: Catcher
) -> None:
    need("mcap")
    recording = tmp_path / "run.mcap"
    with erc_codec.capture.McapWriter(recording, codec) as writer:
        for number, data in enumerate(fleet(codec)):
            writer.write(data, 1_700_000_000_000_000_000 + number)
    result = finished(replay(recording, catcher, "--kind", "gps_info", "--kind", "drive_motor"))
    got = [codec.decode(data).kind for _, data in catcher.take(6)]
    assert got == ["gps_info"] * 3 + ["drive_motor"] * 3
    assert result["skipped"] == {"drops": 2, "other_kinds": 3}
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "erc_codec",
            "replay",
            str(recording),
            catcher.address,
            "--kind",
            "nope",
        ],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 2
    assert "'nope' is not a kind of PBEnvelope" in done.stderr


def test_replay_decodes_json_lines(
    codec: erc_codec.Codec, tmp_path: Path, catcher: Catcher
) -> None:
    need("dpkt")
    sent = fleet(codec)
    capture = tmp_path / "field.pcap"
    write_pcap(capture, sent, step=0.05)
    lines = tmp_path / "field.jsonl"
    decoded = subprocess.run(
        [sys.executable, "-m", "erc_codec", "decode", "--pcap", str(capture)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    lines.write_text(decoded.stdout + '{"kind": "gps_info", "message": {"nonsense": 1}}\n')
    process = replay(lines, catcher, "--drops")  # decode printed no bytes of the drops
    got = catcher.take(len(sent) - 2)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 1  # one line is not a valid message
    result = summary(err, "replayed: ")
    assert [data for _, data in got] == [codec.encode(codec.decode(d).message) for d in sent[:-2]]
    assert got[-1][0] - got[0][0] >= (len(sent) - 3) * 0.05 - JITTER  # "time" of decode --pcap
    assert result["skipped"] == {"drops_without_bytes": 2, "not_valid": 1}


def test_replay_of_a_capture_sends_the_fields_beside_the_payload_on(
    codec: erc_codec.Codec, tmp_path: Path, catcher: Catcher
) -> None:
    """A capture holds whole datagrams: what their envelopes carried is sent too; decode's JSON
    lines name unknown fields but hold no bytes of them, and the summary says they went unsent."""
    need("dpkt")
    newer = [
        bytes.fromhex("6200a00101"),  # field 20 as a varint beside gps_info
        bytes.fromhex("4a00c2020201fff001ac02"),  # a stop, field 40, the timeout metadata
        bytes.fromhex("62026805"),  # the payload's own unknown field
    ]
    capture = tmp_path / "newer.pcap"
    write_pcap(capture, newer, step=0.01)
    result = finished(replay(capture, catcher, "--as-fast-as-possible", "--mode", "exact"))
    got = [data for _, data in catcher.take(len(newer))]
    assert got == [
        bytes.fromhex("6200a00101"),
        bytes.fromhex("4a00f001ac02c2020201ff"),  # protobuf writes the fields it knows first
        bytes.fromhex("62026805"),
    ]
    assert "unknown_fields_unsent" not in result
    lines = tmp_path / "newer.jsonl"
    decoded = subprocess.run(
        [sys.executable, "-m", "erc_codec", "decode", "--pcap", str(capture)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    lines.write_text(decoded.stdout)
    result = finished(replay(lines, catcher, "--as-fast-as-possible", "--mode", "exact"))
    assert [data for _, data in catcher.take(len(newer))] == [
        bytes.fromhex("6200"),
        bytes.fromhex("4a00f001ac02"),  # the timeout, which the line shows as metadata
        bytes.fromhex("6200"),
    ]
    assert result["unknown_fields_unsent"] == 3


def test_a_recording_replayed_into_record_records_the_same(
    codec: erc_codec.Codec, tmp_path: Path
) -> None:
    need("mcap")
    sent = fleet(codec)
    first = tmp_path / "field.mcap"
    with erc_codec.capture.McapWriter(first, codec) as writer:
        for number, data in enumerate(sent):
            writer.write(data, 1_700_000_000_000_000_000 + number * 40_000_000)  # 40 ms apart
    second = tmp_path / "bench.mcap"
    recorder, port = start_recorder(second, "--count", str(len(sent)))
    played = subprocess.run(
        [sys.executable, "-m", "erc_codec", "replay", str(first), f"127.0.0.1:{port}", "--drops"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert played.returncode == 0, played.stderr
    _, err = recorder.communicate(timeout=60)
    assert recorder.returncode == 0, err
    assert summary(err, "recorded: ")["dropped_by_kernel"] == 0
    before, after = (
        list(erc_codec.capture.read_mcap(first)),
        list(erc_codec.capture.read_mcap(second)),
    )

    def content(recorded: erc_codec.capture.Recorded) -> tuple[Any, ...]:
        if recorded.kind is None:  # a drop: the same bytes and reason, from another sender
            drop: Any = recorded.message
            return None, drop.reason, drop.data
        return recorded.kind, recorded.message.SerializeToString()

    assert [content(r) for r in after] == [content(r) for r in before]
    assert len(after) == len(sent)
    # At the recording's timing: record's times are when it read each datagram, late by however
    # busy the machine is (the replay tests measure the kernel's arrival times, to the ms).
    span = after[-1].log_time - after[0].log_time
    assert (len(sent) - 1) * 40_000_000 - 100_000_000 <= span, span
    assert span < (len(sent) - 1) * 40_000_000 + 500_000_000, span


def test_replay_of_something_else_is_one_line(tmp_path: Path) -> None:
    notes = tmp_path / "notes.txt"
    notes.write_text("not a recording\n")
    done = subprocess.run(
        [sys.executable, "-m", "erc_codec", "replay", str(notes), "127.0.0.1:9"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 1
    assert done.stderr.splitlines()[-1] == (
        f"Error: {notes}:1: not a JSON line "
        "(replay reads MCAP, pcap, pcapng or decode's JSON lines)"
    )
    missing = subprocess.run(
        [sys.executable, "-m", "erc_codec", "replay", str(tmp_path / "none.mcap"), "127.0.0.1:9"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert missing.returncode == 2
    assert missing.stderr.startswith("Error: cannot read")
