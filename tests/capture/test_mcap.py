"""MCAP recordings, read back as any MCAP tool reads them: the ``mcap`` library's readers with CRC
checks on, payloads decoded by mcap-protobuf-support's decoder factory from the schema name and
FileDescriptorSet each channel carries (as Foxglove decodes them), never by erc_codec."""

import io
import os
import random
import shutil
import struct
import subprocess
import sys
from pathlib import Path
from typing import Any, BinaryIO, cast

import pytest
from conftest import REPO
from datagrams import MODES, beside, random_payloads
from google.protobuf import descriptor_pb2
from recording_support import (
    enhanced,
    frame,
    interface,
    metadata,
    need,
    need_program,
    read_back,
    section,
    simple,
    write_pcap,
)

import erc_codec
from erc_codec.codec._unknown import MAX_UNKEPT_NUMBERS
from erc_schema import descriptor_of

T0 = 1_700_000_000_000_000_000
GARBAGE = [
    (bytes.fromhex("b20100"), "unknown_member"),  # member 22: a newer schema's
    (bytes.fromhex("6205ff"), "corrupt"),
    (bytes(erc_codec.Codec.default().max_size("PBEnvelope") + 1), "too_long"),
    (b"\0\0", "no_payload"),
    (b"", "empty"),
]


def test_every_kind_in_every_form_reads_back_exactly(
    codec: erc_codec.Codec, tmp_path: Path
) -> None:
    need("mcap")
    sent = [
        (kind, payload, mode) for kind, payload in random_payloads(codec, 7, 3) for mode in MODES
    ]
    path = tmp_path / "run.mcap"
    with erc_codec.capture.McapWriter(path, codec, source="test") as writer:
        for number, (kind, payload, mode) in enumerate(sent):
            data = codec.encode(payload, mode)
            assert writer.write(data, T0 + number, f"10.0.0.{number % 3}:7") == kind
        for number, (data, _) in enumerate(GARBAGE, start=len(sent)):
            assert writer.write(data, T0 + number, "10.0.0.9:7", "10.0.0.1:5000") is None
    assert writer.stats().drops == {reason: 1 for _, reason in GARBAGE}
    messages = read_back(path)
    assert len(messages) == len(sent) + len(GARBAGE)
    for number, ((kind, payload, _), read) in enumerate(zip(sent, messages, strict=False)):
        assert read.channel.topic == f"/erc/{kind}"
        assert read.channel.message_encoding == "protobuf"
        assert read.schema.encoding == "protobuf"
        assert read.schema.name == descriptor_of(type(payload)).full_name
        # The reader's class comes from its own pool: compare what it would send.
        assert read.decoded_message.SerializeToString() == payload.SerializeToString()
        assert read.message.data == payload.SerializeToString()  # the exact form
        assert read.message.log_time == read.message.publish_time == T0 + number
        assert read.message.sequence == number + 1
    for (data, reason), read in zip(GARBAGE, messages[len(sent) :], strict=True):
        drop = read.decoded_message
        assert read.channel.topic == "/erc-codec/drops"
        assert read.schema.name == "erc_codec.DroppedDatagram"
        assert (drop.reason, drop.data, drop.length) == (reason, data, len(data))
        assert (drop.source, drop.destination) == ("10.0.0.9:7", "10.0.0.1:5000")
        assert drop.error  # the decoder's words, one line
        assert "\n" not in drop.error


def test_read_mcap_yields_kinds_messages_and_drops(codec: erc_codec.Codec, tmp_path: Path) -> None:
    need("mcap")
    gps = codec.message_class("SensorBoardGPSInfo")(latitude=52.2389, satellites=9)
    path = tmp_path / "run.mcap"
    with erc_codec.capture.McapWriter(path, codec) as writer:
        writer.write(codec.encode(gps), T0)
        writer.write(bytes.fromhex("b20100"), T0 + 5, "10.0.0.9:7")
        writer.message("gps_info", gps, T0 + 9)
    recorded = list(erc_codec.capture.read_mcap(path))
    assert all(isinstance(r, erc_codec.capture.Recorded) for r in recorded)
    first, drop, last = recorded
    fix, dropped = cast(Any, first.message), cast(Any, drop.message)
    assert (first.log_time, first.kind) == (T0, "gps_info")
    assert first.message.SerializeToString() == gps.SerializeToString()
    assert fix.latitude == 52.2389
    assert (drop.log_time, drop.kind, dropped.reason) == (T0 + 5, None, "unknown_member")
    assert dropped.data == bytes.fromhex("b20100")
    assert (last.log_time, last.kind) == (T0 + 9, "gps_info")


def test_each_schema_is_its_payloads_file_and_imports_dependencies_first(
    codec: erc_codec.Codec, tmp_path: Path
) -> None:
    need("mcap")
    path = tmp_path / "run.mcap"
    with erc_codec.capture.McapWriter(path, codec) as writer:
        for kind, payload in random_payloads(codec, 3, 1):
            writer.message(kind, payload, T0)
    reader = need("mcap.reader")
    with path.open("rb") as file:
        summary = reader.make_reader(file).get_summary()
    assert len(summary.channels) == len(codec.kinds())
    for schema in summary.schemas.values():
        files = descriptor_pb2.FileDescriptorSet.FromString(schema.data).file
        names = [file.name for file in files]
        assert len(set(names)) == len(names)
        for position, proto in enumerate(files):
            assert set(proto.dependency) <= set(names[:position]), (schema.name, names)
        top = descriptor_of(codec.message_class(schema.name)).file.name
        assert names[-1] == top  # the payload's own file last, after all it imports
        assert not any(file.HasField("source_code_info") for file in files)


def test_the_file_says_where_its_schema_came_from_and_what_it_holds(
    codec: erc_codec.Codec, tmp_path: Path
) -> None:
    need("mcap")
    path = tmp_path / "run.mcap"
    gps = codec.message_class("SensorBoardGPSInfo")()
    with erc_codec.capture.McapWriter(path, codec, source="udp 127.0.0.1:5000") as writer:
        writer.message("gps_info", gps, T0, "10.0.0.2:7")
        writer.message("gps_info", gps, T0, "10.0.0.2:7")
        writer.message("gps_info", gps, T0, "10.0.0.3:7")
        writer.drop(b"\x01", T0, "corrupt", "bad")
    found = metadata(path)
    origin = found["erc-codec"]
    assert origin["schema_root"] == "PBEnvelope"
    assert origin["PBEnvelope_size"] == str(codec.max_size("PBEnvelope"))
    assert Path(origin["schema_tree"]) == codec.schema.tree
    assert origin["schema_digest"].startswith("sha256:")
    assert len(origin["schema_digest"]) == len("sha256:") + 64
    assert origin["source"] == "udp 127.0.0.1:5000"
    assert "schema_revision" in origin  # a commit inside a git work tree, "" outside one
    assert found["erc-codec.summary"] == {
        "datagrams": "4",
        "messages": "3",
        "drops": "1",
        "messages.gps_info": "3",
        "drops.corrupt": "1",
        "senders.gps_info": "10.0.0.2:7 2, 10.0.0.3:7 1",
    }


def test_the_schema_revision_is_the_trees_commit_dirty_for_a_change_inside_it(
    tmp_path: Path,
) -> None:
    need("mcap")
    git = need_program("git", "apt-get install git")
    repository, tree = tmp_path / "fleet", tmp_path / "fleet" / "proto"
    shutil.copytree(REPO / "proto", tree)

    def in_repository(*args: str) -> str:
        done = subprocess.run(
            [git, "-C", str(repository), *args], capture_output=True, text=True, check=True
        )
        return done.stdout.strip()

    codec = erc_codec.Codec.from_path(tree)
    path = tmp_path / "run.mcap"

    def revision() -> str:
        path.unlink(missing_ok=True)
        with erc_codec.capture.McapWriter(path, codec):
            pass
        return metadata(path)["erc-codec"]["schema_revision"]

    in_repository("init", "-q")
    assert revision() == ""  # no commit yet
    in_repository("add", ".")
    in_repository("-c", "user.name=t", "-c", "user.email=t@example.org", "commit", "-qm", "tree")
    head = in_repository("rev-parse", "HEAD")
    assert revision() == head
    (repository / "notes.txt").write_text("beside the tree, not in it\n")
    assert revision() == head
    (tree / "scratch.proto").write_text('syntax = "proto3";\n')  # untracked, inside
    assert revision() == f"{head}-dirty"
    (tree / "scratch.proto").unlink()
    envelope = tree / "components" / "common" / "envelope.proto"
    envelope.write_text(envelope.read_text() + "\n")  # a tracked file changed
    assert revision() == f"{head}-dirty"


def test_a_damaged_file_is_caught(codec: erc_codec.Codec, tmp_path: Path) -> None:
    need("mcap")
    reader = need("mcap.reader")
    path = tmp_path / "run.mcap"
    payloads = [payload for _, payload in random_payloads(codec, 5, 20)]
    with erc_codec.capture.McapWriter(path, codec, chunk_size=1024, compression="none") as writer:
        for number, payload in enumerate(payloads):
            writer.write(codec.encode(payload), T0 + number)
    whole = path.read_bytes()
    with path.open("rb") as file:
        chunk = reader.make_reader(file).get_summary().chunk_indexes[1]
    damaged = bytearray(whole)
    damaged[chunk.chunk_start_offset + chunk.chunk_length - 3] ^= 0x01  # inside its records
    path.write_bytes(damaged)
    with pytest.raises(erc_codec.CodecError, match="is not a readable MCAP recording"):
        list(erc_codec.capture.read_mcap(path))
    # A byte outside every chunk (a message index): only the data section's CRC sees it.
    damaged = bytearray(whole)
    offset = min(chunk.message_index_offsets.values())
    damaged[offset + 9 + 2 + 4 + 8] ^= 0x01  # opcode, length, channel, array length: a time
    stream = reader.NonSeekingReader(io.BytesIO(bytes(damaged)), validate_crcs=True)
    with pytest.raises(need("mcap.stream_reader").CRCValidationError):
        list(stream.iter_messages())


def test_the_output_must_be_seekable(codec: erc_codec.Codec) -> None:
    need("mcap")
    pipe = subprocess.Popen(["cat"], stdin=subprocess.PIPE, stdout=subprocess.DEVNULL)
    assert pipe.stdin is not None
    try:
        with pytest.raises(erc_codec.CodecError, match="seekable file, not a pipe"):
            erc_codec.capture.McapWriter(cast(BinaryIO, pipe.stdin), codec)
    finally:
        pipe.stdin.close()
        pipe.wait()


def run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "erc_codec", *args], capture_output=True, text=True, timeout=120
    )


def test_decode_pcap_mcap_writes_a_capture(codec: erc_codec.Codec, tmp_path: Path) -> None:
    need("dpkt")
    need("mcap")
    feedback = codec.message_class("ArmBoardMovementFeedback")()  # all default: 22 00
    gps = codec.message_class("SensorBoardGPSInfo")(latitude=52.2389, altitude=1e-40)
    datagrams = [codec.encode(p, m) for p in (feedback, gps) for m in MODES]
    datagrams += [data for data, _ in GARBAGE if data]  # an empty UDP payload is a datagram too
    capture, out = tmp_path / "field.pcap", tmp_path / "field.mcap"
    times = write_pcap(capture, datagrams, start=1_700_000_000.123456, step=0.25)
    done = run("decode", "--pcap", str(capture), "--mcap", str(out))
    assert done.returncode == 1, done.stderr  # as decode: some datagrams did not decode
    assert done.stdout == ""
    assert done.stderr == (
        f"10 datagrams, 4 undecodable, 0 packets skipped; {out}: 6 messages on 2 channels, "
        "4 drops\n"
    )
    messages = read_back(out)
    assert [m.channel.topic for m in messages] == [
        *["/erc/arm_feedback"] * 3,
        *["/erc/gps_info"] * 3,
        *["/erc-codec/drops"] * 4,
    ]
    for read, time in zip(messages, times, strict=True):
        assert read.message.log_time == round(time * 1e6) * 1000  # microseconds, exactly
    assert [m.message.data for m in messages[:6]] == [feedback.SerializeToString()] * 3 + [
        gps.SerializeToString()
    ] * 3
    drops = [m.decoded_message for m in messages[6:]]
    assert [d.data for d in drops] == datagrams[6:]
    assert {d.source for d in drops} == {"192.168.0.20:40000"}
    assert {d.destination for d in drops} == {"192.168.0.2:5000"}
    assert metadata(out)["erc-codec"]["source"] == "capture field.pcap"
    again = run("decode", "--pcap", str(capture), "--mcap", str(out))
    assert (again.returncode, again.stderr) == (
        2,
        f"Error: {out} exists: remove it or choose another name\n",
    )
    assert run("decode", "00", "--mcap", str(tmp_path / "x.mcap")).returncode == 2
    linked, target = tmp_path / "linked.mcap", tmp_path / "elsewhere"
    linked.symlink_to(target)  # dangling: exists() sees nothing; the open itself refuses
    refused = run("decode", "--pcap", str(capture), "--mcap", str(linked))
    assert (refused.returncode, refused.stderr) == (
        2,
        f"Error: {linked} exists: remove it or choose another name\n",
    )
    assert not target.exists()


def test_a_capture_time_mcap_cannot_hold_is_a_counted_skip(
    codec: erc_codec.Codec, tmp_path: Path
) -> None:
    """pcapng times reach far past MCAP's (unsigned 64-bit nanoseconds: 1970 to 2554) and
    before 1970: each such datagram is skipped and counted, the rest written, exit 1; a Simple
    Packet Block, which has no time, is logged at the time of the datagram written before it."""
    need("dpkt")
    need("mcap")
    gps = codec.message_class("SensorBoardGPSInfo")
    fixes = [frame(codec.encode(gps(satellites=number))) for number in range(6)]
    capture, out = tmp_path / "far.pcapng", tmp_path / "far.mcap"
    capture.write_bytes(
        section()
        + interface(1, options=((9, b"\x00"),))  # whole seconds
        + interface(1, options=((14, struct.pack("<q", -(10**10))),))  # 10**10 s before
        + simple(fixes[0])  # before any time: the epoch
        + enhanced(0, 1 << 63, fixes[1])  # 2**63 seconds: some 3e11 years on
        + enhanced(0, T0 // 10**9, fixes[2])
        + simple(fixes[3])  # the time written last, never the one skipped
        + enhanced(1, 0, fixes[4])  # in 1653
        + enhanced(0, T0 // 10**9 + 1, fixes[5])
    )
    done = run("decode", "--pcap", str(capture), "--mcap", str(out))
    assert done.returncode == 1, done.stderr
    assert done.stderr == (
        "4 datagrams, 0 undecodable, 2 packets skipped (2 time outside MCAP's range); "
        f"{out}: 4 messages on 1 channel, 0 drops\n"
    )
    written = [(m.message.log_time, m.decoded_message.satellites) for m in read_back(out)]
    assert written == [(0, 0), (T0, 2), (T0, 3), (T0 + 10**9, 5)]
    assert metadata(out)["erc-codec.summary"]["capture.skipped.time outside MCAP's range"] == "2"
    with erc_codec.capture.McapWriter(io.BytesIO(), codec) as writer:
        for log_time in (-1, 1 << 64):
            with pytest.raises(erc_codec.CodecError, match=f"log time {log_time} ns is outside"):
                writer.write(codec.encode(gps()), log_time)
            with pytest.raises(erc_codec.CodecError, match="is outside what MCAP holds"):
                writer.drop(b"", log_time, "empty")
    assert writer.stats() == erc_codec.capture.RecordingStats({}, {})  # nothing written


def test_without_the_mcap_extra_one_line_names_it(tmp_path: Path) -> None:
    code = "import sys; sys.modules['mcap'] = None; from erc_codec.cli._main import main; main()"
    capture = tmp_path / "x.pcap"
    write_pcap(capture, [b"\x22"])
    done = subprocess.run(
        [
            sys.executable,
            "-c",
            code,
            "decode",
            "--pcap",
            str(capture),
            "--mcap",
            str(tmp_path / "x.mcap"),
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    if "dpkt" in done.stderr:
        need("dpkt")
    assert (done.returncode, done.stderr) == (
        2,
        "Error: writing MCAP needs the mcap package: pip install 'erc-codec[mcap]'\n",
    )
    assert not (tmp_path / "x.mcap").exists()  # nothing left to block the retry


def test_a_capture_whose_name_is_not_utf8_is_written(
    codec: erc_codec.Codec, tmp_path: Path
) -> None:
    need("dpkt")
    need("mcap")
    capture = tmp_path / os.fsdecode(b"r\xff.pcap")
    out = tmp_path / os.fsdecode(b"o\xff.mcap")
    write_pcap(capture, [codec.encode(codec.message_class("SensorBoardGPSInfo")(satellites=5))])
    done = run("decode", "--pcap", str(capture), "--mcap", str(out))
    assert done.returncode == 0, done.stderr
    assert len(read_back(out)) == 1
    assert metadata(out)["erc-codec"]["source"] == "capture r\\xff.pcap"  # its byte, escaped


def test_random_damage_is_a_codec_error_or_a_correct_read(
    codec: erc_codec.Codec, tmp_path: Path
) -> None:
    need("mcap")
    path = tmp_path / "run.mcap"
    with erc_codec.capture.McapWriter(path, codec, chunk_size=512) as writer:
        for number, (_, payload) in enumerate(random_payloads(codec, 7, 2)):
            writer.write(codec.encode(payload), T0 + number)
        writer.write(bytes.fromhex("6205ff"), T0 + 99)  # a drop
    whole = path.read_bytes()
    expected = [
        (r.log_time, r.kind, r.message.SerializeToString())
        for r in erc_codec.capture.read_mcap(path)
    ]
    rng = random.Random(20)
    damaged = [whole[:cut] for cut in sorted(rng.sample(range(len(whole)), 40))]
    for _ in range(300):
        flipped = bytearray(whole)
        flipped[rng.randrange(len(whole))] ^= 1 << rng.randrange(8)
        damaged.append(bytes(flipped))
    errors = []
    for data in damaged:
        path.write_bytes(data)
        try:
            read = [
                (r.log_time, r.kind, r.message.SerializeToString())
                for r in erc_codec.capture.read_mcap(path)
            ]
        except erc_codec.CodecError as error:  # anything else fails the test
            errors.append(str(error))
            continue
        assert read == expected  # a flip no CRC covers changes nothing read (padding, indexes)
    assert len(errors) > len(damaged) // 2
    for text in errors:
        assert text.startswith(f"{path} is not a readable MCAP recording: "), text
        assert not text.endswith(": "), text


def test_only_the_recordings_channels_are_read(codec: erc_codec.Codec, tmp_path: Path) -> None:
    need("mcap")
    reader, writer_module = need("mcap.reader"), need("mcap.writer")
    recording, mixed = tmp_path / "run.mcap", tmp_path / "mixed.mcap"
    gps = codec.message_class("SensorBoardGPSInfo")(satellites=5)
    with erc_codec.capture.McapWriter(recording, codec) as writer:
        writer.write(codec.encode(gps), T0)
        writer.write(bytes.fromhex("6205ff"), T0 + 2)
    with recording.open("rb") as source, mixed.open("wb") as file:
        copy = writer_module.Writer(file)
        copy.start()
        stats = copy.register_schema("stats", "jsonschema", b"{}")
        json_channel = copy.register_channel("/erc-codec/stats", "json", stats)
        copy.add_message(json_channel, T0 + 1, b'{"received": 1}', T0 + 1)
        schemas: dict[int, int] = {}
        channels: dict[int, int] = {}
        for schema, channel, message in reader.make_reader(source).iter_messages():
            if channel.id not in channels:
                if schema.id not in schemas:
                    schemas[schema.id] = copy.register_schema(
                        schema.name, schema.encoding, schema.data
                    )
                channels[channel.id] = copy.register_channel(
                    channel.topic, channel.message_encoding, schemas[schema.id]
                )
            copy.add_message(channels[channel.id], message.log_time, message.data, message.log_time)
        copy.finish()
    read = list(erc_codec.capture.read_mcap(mixed))
    assert [(r.log_time, r.kind) for r in read] == [(T0, "gps_info"), (T0 + 2, None)]
    assert read[0].message.SerializeToString() == gps.SerializeToString()


def test_a_damaged_capture_is_written_up_to_the_damage(
    codec: erc_codec.Codec, tmp_path: Path
) -> None:
    need("dpkt")
    need("mcap")
    capture, out = tmp_path / "cut.pcap", tmp_path / "cut.mcap"
    gps = codec.message_class("SensorBoardGPSInfo")(satellites=5)
    write_pcap(capture, [codec.encode(gps)] * 3)
    capture.write_bytes(capture.read_bytes()[:-3])  # cut inside the last packet
    done = run("decode", "--pcap", str(capture), "--mcap", str(out))
    assert done.returncode == 2
    summary, damage = done.stderr.splitlines()
    assert summary.startswith("2 datagrams, 0 undecodable")
    assert damage == f"Error: {capture} is cut off inside packet 3"
    assert len(read_back(out)) == 2  # a complete file of what came before
    assert metadata(out)["erc-codec.summary"]["capture.damage"] == damage.removeprefix("Error: ")


def test_record_without_the_mcap_extra_one_line_names_it(tmp_path: Path) -> None:
    code = "import sys; sys.modules['mcap'] = None; from erc_codec.cli._main import main; main()"
    out = tmp_path / "x.mcap"
    done = subprocess.run(
        [sys.executable, "-c", code, "record", "127.0.0.1:0", str(out), "--seconds", "5"],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert (done.returncode, done.stderr) == (
        2,
        "Error: writing MCAP needs the mcap package: pip install 'erc-codec[mcap]'\n",
    )
    assert not out.exists()


def test_fields_beside_the_payload_that_a_channel_cannot_hold_are_counted(
    codec: erc_codec.Codec, tmp_path: Path
) -> None:
    """An envelope's unknown field has no place on a payload's channel: the payload is written,
    the field counted in the summary (and the stats), never dropped without a word."""
    need("dpkt")
    need("mcap")
    beside = [bytes.fromhex("6200a00101"), bytes.fromhex("6200a00101c2020201ff")]
    capture, out = tmp_path / "newer.pcap", tmp_path / "newer.mcap"
    write_pcap(capture, [*beside, bytes.fromhex("6200")], start=1_700_000_000.0, step=0.25)
    done = run("decode", "--pcap", str(capture), "--mcap", str(out))
    assert done.returncode == 0, done.stderr
    assert done.stderr == (
        f"3 datagrams, 0 undecodable, 0 packets skipped; {out}: 3 messages on 1 channel, "
        "0 drops; not recorded: fields PBEnvelope does not know beside the payload: "
        "20 (2), 40 (1)\n"
    )
    assert [m.message.data for m in read_back(out)] == [b""] * 3  # the payloads, all of them
    summary = metadata(out)["erc-codec.summary"]
    assert (summary["unkept.20"], summary["unkept.40"]) == ("2", "1")
    with erc_codec.capture.McapWriter(io.BytesIO(), codec) as writer:
        assert writer.write(beside[1], T0) == "gps_info"
        writer.write(bytes.fromhex("62026805"), T0)  # the payload's own: kept on its channel
        assert writer.stats().unkept == {20: 1, 40: 1}


def test_the_unkept_table_stops_at_its_bound_and_counts_the_fields_past_it(
    codec: erc_codec.Codec, tmp_path: Path
) -> None:
    """A capture of ever new field numbers beside the payload: the writer lists the first
    numbers to come, no more, and counts every field of the others, in its stats, the file's
    summary and decode's summary line."""
    need("dpkt")
    need("mcap")
    numbers = list(range(1000, 1000 + MAX_UNKEPT_NUMBERS + 100))
    rounds = [numbers[start : start + 50] for start in range(0, len(numbers), 50)]
    datagrams = [beside(numbers_of_one) for numbers_of_one in rounds * 2]
    with erc_codec.capture.McapWriter(io.BytesIO(), codec) as writer:
        for number, data in enumerate(datagrams):
            assert writer.write(data, T0 + number) == "gps_info"
        writer.unkept([numbers[-1], numbers[-1]])  # a number given twice counts once
    stats = writer.stats()
    assert stats.unkept == {number: 2 for number in numbers[:MAX_UNKEPT_NUMBERS]}
    assert stats.unkept_unlisted == 2 * 100 + 1
    capture, out = tmp_path / "newer.pcap", tmp_path / "newer.mcap"
    write_pcap(capture, datagrams)
    done = run("decode", "--pcap", str(capture), "--mcap", str(out))
    assert done.returncode == 0, done.stderr
    listed = ", ".join(f"{number} (2)" for number in numbers[:MAX_UNKEPT_NUMBERS])
    assert done.stderr.endswith(f"beside the payload: {listed}, other numbers (200)\n")
    summary = metadata(out)["erc-codec.summary"]
    unkept = {key: n for key, n in summary.items() if key.startswith("unkept.")}
    assert unkept == {
        **{f"unkept.{number}": "2" for number in numbers[:MAX_UNKEPT_NUMBERS]},
        "unkept.unlisted": "200",
    }
