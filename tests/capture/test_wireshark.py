"""The generated Lua dissector, run by Debian's tshark on captures the tests write, against
``erc-codec decode`` on the same captures: the same kinds, reasons and field values, every form.

tshark runs a Lua script that fails with exit status 0 (the error goes to stderr), so every run
here checks that stderr holds no Lua error and that the dissector saw the frames. Without tshark
the tests skip, saying why, except under ERC_REQUIRE_INTEROP=1 (CI installs it).
"""

import base64
import json
import math
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ElementTree
from pathlib import Path
from typing import Any

import pytest
from conftest import REPO
from datagrams import (
    AMBIGUOUS,
    MODES,
    TRUNCATED,
    h,
    hostile_datagrams,
    random_payloads,
    valid_datagrams,
)
from google.protobuf.descriptor import Descriptor, FieldDescriptor
from google.protobuf.message import Message
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st
from recording_support import need_program, write_pcap

import erc_codec
from erc_codec.strategies import messages
from erc_schema import descriptor_of, enum_of, message_of

TREE = REPO / "tests" / "wireshark_tree"
_T = FieldDescriptor
GARBAGE = [
    bytes.fromhex("b20100"),  # member 22, unknown to this schema
    bytes.fromhex("6205ff"),  # gps_info, its payload a wire type 7
    bytes(erc_codec.Codec.default().max_size("PBEnvelope") + 1),  # longer than PBEnvelope_size
    b"\0\0\0",  # zeros only
    bytes.fromhex("6005"),  # gps_info's number on wire type VARINT
    bytes.fromhex("620b") + bytes(9) + b"\x01",  # non-zero after the padding
]


def erc_codec_cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "erc_codec", *args], capture_output=True, text=True, timeout=120
    )


@pytest.fixture(scope="module")
def tshark() -> str:
    return need_program("tshark", "apt-get install tshark")


def dissector(tmp_path: Path, *args: str) -> Path:
    done = erc_codec_cli("wireshark", *args)
    assert done.returncode == 0, done.stderr
    path = tmp_path / "erc_envelope.lua"
    path.write_text(done.stdout)
    return path


def run_tshark(tshark: str, lua: Path, capture: Path, *args: str) -> str:
    done = subprocess.run(
        [tshark, "-X", f"lua_script:{lua}", "-r", str(capture), *args],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    for text in (done.stdout, done.stderr):  # a Lua error shows in the tree, or on stderr
        assert "Lua Error" not in text, text[-2000:]
        assert "Lua: Error" not in text, text[-2000:]
    return done.stdout


def layers(tshark: str, lua: Path, capture: Path) -> list[dict[str, Any] | None]:
    """Each frame's ERC layer, as ``tshark -T json`` shows it (None: not dissected as ERC)."""
    out = run_tshark(tshark, lua, capture, "-T", "json", "-J", "erc udp", "--no-duplicate-keys")
    return [frame["_source"]["layers"].get("erc") for frame in json.loads(out)]


def trees(tshark: str, lua: Path, capture: Path) -> list[ElementTree.Element | None]:
    """Each frame's ERC tree as PDML: every item with the label a user sees (``showname``)."""
    out = run_tshark(tshark, lua, capture, "-T", "pdml")
    return [
        packet.find("proto[@name='erc']") for packet in ElementTree.fromstring(out).iter("packet")
    ]


def decoded(capture: Path, *schema: str) -> list[dict[str, Any]]:
    done = erc_codec_cli("decode", "--pcap", str(capture), *schema)
    assert done.returncode in (0, 1), done.stderr
    return [json.loads(line) for line in done.stdout.splitlines()]


# -- what a tree says, in decode's words -------------------------------------------------------


def _value(field: FieldDescriptor, label: str) -> Any:
    """A field's label text (after ``name: ``) as decode's JSON writes that value."""
    if field.type in (_T.TYPE_DOUBLE, _T.TYPE_FLOAT):
        return label if label in ("NaN", "Infinity", "-Infinity") else float(label)
    if field.type in (_T.TYPE_INT64, _T.TYPE_UINT64, _T.TYPE_SINT64, _T.TYPE_FIXED64):
        return str(int(label))
    if field.type == _T.TYPE_SFIXED64:
        return str(int(label))
    if field.type == _T.TYPE_BOOL:
        return {"true": True, "false": False}[label]
    if field.type == _T.TYPE_ENUM:
        name, _, number = label.rpartition(" (")
        return int(number.rstrip(")")) if name == "undeclared" else name
    return int(label)


def _wire(item: ElementTree.Element, descriptor: Descriptor) -> dict[str, Any]:
    """What the items under ``item`` say, merged as protobuf merges the wire (a scalar given twice
    keeps the last, a message given twice merges, a oneof member clears the others), without
    defaults: ``_with_defaults`` adds those after merging, as a later occurrence of a message
    lacks the fields it merges into the earlier one."""
    found: dict[str, Any] = {}
    for child in item.findall("field"):
        _, _, name = child.attrib["name"].rpartition(".")
        field = descriptor.fields_by_name.get(name)
        if child.attrib["name"] == "_ws.expert":
            continue  # expert info on the message ("given again later on the wire")
        if field is None:
            assert child.attrib["name"] == "erc.unknown", child.attrib
            continue
        empty = child.attrib["size"] == "0" and not field.has_presence and not field.is_repeated
        if empty and name not in found:
            # generated: a default not on the wire (or an empty string, as good); after a value
            # of the field, it is an empty string on the wire, the value protobuf keeps
            continue
        if field.containing_oneof is not None:
            for other in field.containing_oneof.fields:
                if other.name != name:
                    found.pop(other.name, None)
        if field.type == _T.TYPE_MESSAGE:
            _add_message(found, field, _wire(child, message_of(field)))
        elif field.type in (_T.TYPE_STRING, _T.TYPE_BYTES):  # the bytes: labels escape text
            raw = bytes.fromhex(child.attrib.get("value", ""))
            value = raw.decode() if field.type == _T.TYPE_STRING else base64.b64encode(raw).decode()
            if field.is_repeated:
                found.setdefault(name, []).append(value)
            else:
                found[name] = value
        else:
            value = _value(field, child.attrib["showname"].split(": ", 1)[1])
            if field.is_repeated:
                found.setdefault(name, []).append(value)
            else:
                found[name] = value
    return found


def _merge(old: dict[str, Any], new: dict[str, Any]) -> dict[str, Any]:
    return {
        **old,
        **{k: _merge(old[k], v) if isinstance(v, dict) and k in old else v for k, v in new.items()},
    }


def _with_defaults(found: dict[str, Any], descriptor: Descriptor) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for field in descriptor.fields:
        if field.name in found:
            value = found[field.name]
            if field.type == _T.TYPE_MESSAGE and not field.is_repeated:
                value = _with_defaults(value, message_of(field))
            elif field.type == _T.TYPE_MESSAGE and not _is_map(field):
                value = [_with_defaults(v, message_of(field)) for v in value]
            out[field.name] = value
        elif field.is_repeated:
            out[field.name] = {} if field.message_type and _is_map(field) else []
        elif not field.has_presence:
            out[field.name] = _default(field)
    return out


def _add_message(found: dict[str, Any], field: FieldDescriptor, sub: dict[str, Any]) -> None:
    """A submessage's item into ``found``: a map's entry, a repeated item, or merged."""
    if _is_map(field):
        found.setdefault(field.name, {}).update(_map_item(_with_defaults(sub, message_of(field))))
    elif field.is_repeated:
        found.setdefault(field.name, []).append(sub)
    else:
        found[field.name] = _merge(found.get(field.name, {}), sub)


def _map_item(entry: dict[str, Any]) -> dict[str, Any]:
    """A map entry as the JSON mapping writes it: ``{key: value}``, the key as text."""
    key = entry["key"]
    return {
        ("true" if key else "false") if isinstance(key, bool) else str(key): entry.get("value", {})
    }


def _is_map(field: FieldDescriptor) -> bool:
    return bool(message_of(field).GetOptions().map_entry)


def _default(field: FieldDescriptor) -> Any:
    if field.type in (_T.TYPE_DOUBLE, _T.TYPE_FLOAT):
        return 0.0
    if field.type in (
        _T.TYPE_INT64,
        _T.TYPE_UINT64,
        _T.TYPE_SINT64,
        _T.TYPE_FIXED64,
        _T.TYPE_SFIXED64,
    ):
        return "0"
    if field.type == _T.TYPE_BOOL:
        return False
    if field.type == _T.TYPE_ENUM:
        return enum_of(field).values_by_number[0].name
    if field.type in (_T.TYPE_STRING, _T.TYPE_BYTES):
        return ""
    return 0


def outcome(tree: ElementTree.Element | None, codec: erc_codec.Codec) -> dict[str, Any]:
    """A dissected datagram as decode reports it: kind, message and metadata, or the reason."""
    assert tree is not None, "not dissected as ERC"
    items = {field.attrib["name"]: field for field in tree.findall("field")}
    if "erc.reason" in items:
        assert "erc.kind" not in items
        assert not [name for name in items if name.startswith(f"erc.{codec.root}.")]  # no fields
        return {"reason": items["erc.reason"].attrib["show"]}
    kind = items["erc.kind"].attrib["show"]
    # The envelope's fields, merged as protobuf merges them: the last member on the wire is the
    # payload (protobuf keeps the last of a oneof), an earlier occurrence of it merged into it;
    # beside it, the metadata, the last of each kept.
    root = descriptor_of(codec.message_class(codec.root))
    envelope = ElementTree.Element("envelope")
    envelope.extend(
        f for f in tree.findall("field") if f.attrib["name"].startswith(f"erc.{root.full_name}.")
    )
    found = _wire(envelope, root)
    payload = descriptor_of(codec.payload_class(kind))
    result = {"kind": kind, "message": _with_defaults(found.pop(kind), payload)}
    metadata = {k: v for k, v in found.items() if _carried(root.fields_by_name[k], v)}
    return {**result, "metadata": metadata} if metadata else result


def _carried(field: FieldDescriptor, value: Any) -> bool:
    """Whether decode lists a metadata field the tree shows: protobuf lists a field without
    presence only when it holds no default (-0.0 is not 0.0 to it)."""
    if field.has_presence:
        return True
    if isinstance(value, float):
        return value != 0 or math.copysign(1.0, value) < 0
    return bool(value != _default(field))


def expected(record: dict[str, Any]) -> dict[str, Any]:
    if "kind" in record:
        result = {"kind": record["kind"], "message": record["message"]}
        return {**result, "metadata": record["metadata"]} if "metadata" in record else result
    return {"reason": record["reason"]}


def same(left: Any, right: Any) -> bool:
    """Equal, a NaN equal to itself (decode writes "NaN", so only floats need this)."""
    if isinstance(left, float) and isinstance(right, float):
        return left == right or (math.isnan(left) and math.isnan(right))
    if isinstance(left, dict) and isinstance(right, dict):
        return left.keys() == right.keys() and all(same(left[k], right[k]) for k in left)
    if isinstance(left, list) and isinstance(right, list):
        return len(left) == len(right) and all(same(a, b) for a, b in zip(left, right, strict=True))
    return bool(left == right)


def assert_as_decode(
    tshark: str, lua: Path, capture: Path, codec: erc_codec.Codec, *schema: str
) -> list[dict[str, Any]]:
    """Every frame of ``capture`` dissects to what ``erc-codec decode`` says of it."""
    records = decoded(capture, *schema)
    seen = trees(tshark, lua, capture)
    assert len(seen) == len(records)
    for number, (record, tree) in enumerate(zip(records, seen, strict=True), start=1):
        assert same(outcome(tree, codec), expected(record)), (number, record)  # 1-based frame
    return records


# -- the tests ---------------------------------------------------------------------------------


def test_a_fleet_capture_dissects_as_decode_reads_it(
    tshark: str, codec: erc_codec.Codec, tmp_path: Path
) -> None:
    lua = dissector(tmp_path)
    sent = [codec.encode(p, m) for _, p in random_payloads(codec, 11, 3) for m in MODES]
    sent += valid_datagrams(codec) + GARBAGE
    capture = tmp_path / "fleet.pcap"
    write_pcap(capture, sent)
    records = assert_as_decode(tshark, lua, capture, codec)
    assert {r.get("reason") for r in records} >= {
        "unknown_member",
        "corrupt",
        "too_long",
        "no_payload",
    }
    for data, layer in zip(sent, layers(tshark, lua, capture), strict=True):
        assert layer is not None
        refused = refusal(codec, data)
        if refused:
            assert layer["erc.reason"] == refused
            assert "erc.refused" in layer["_ws.expert"]
            assert "erc.kind" not in layer
            continue
        kind, message = codec.decode(data)
        exact = codec.encode(message, "exact")
        form = "exact" if data == exact else "strip" if len(data) < len(exact) else "pad"
        assert (layer["erc.kind"], layer["erc.form"]) == (kind, form)
        assert layer["erc.member"] == str(next(n for n, k in codec.kinds().items() if k == kind))
        if form == "strip":
            assert layer["erc.restored"] == str(len(exact) - len(data))
        if form == "pad":
            assert layer["erc.padding"] == str(len(data) - len(exact))
        assert same(wireshark_values(layer[f"erc.PBEnvelope.{kind}"]), shown(message))


def refusal(codec: erc_codec.Codec, data: bytes) -> str:
    """Why ``codec`` refuses ``data`` (a DecodeError's reason), or ``""``."""
    try:
        codec.decode(data)
    except erc_codec.DecodeError as error:
        return error.reason
    return ""


def wireshark_values(layer: dict[str, Any]) -> dict[str, Any]:
    """A payload's subtree in tshark's JSON: field abbreviation → value text(s)."""
    return {key: value for key, value in layer.items() if not key.startswith("_ws")}


def shown(message: Message) -> dict[str, Any]:
    """What tshark's JSON shows for each field of ``message``: Wireshark's own formatting of
    the value (floats to 6 significant digits, doubles to 15, enums and bools as numbers),
    a field not on the wire at its default, a submessage as its subtree."""
    descriptor = descriptor_of(type(message))
    out: dict[str, Any] = {}
    for field in descriptor.fields:
        key = f"erc.{descriptor.full_name}.{field.name}"
        if field.is_repeated:
            values = [_shown(field, v) for v in getattr(message, field.name)]
            if values:
                out[key] = values[0] if len(values) == 1 else values
        elif field.type == _T.TYPE_MESSAGE:
            if message.HasField(field.name):
                out[key] = shown(getattr(message, field.name))
        elif not field.has_presence or message.HasField(field.name):
            out[key] = _shown(field, getattr(message, field.name))
    return out


def _shown(field: FieldDescriptor, value: Any) -> Any:
    if field.type == _T.TYPE_MESSAGE:
        return shown(value)
    if field.type == _T.TYPE_FLOAT:
        return "%.6g" % value  # noqa: UP031 (C's printf, as Wireshark formats it)
    if field.type == _T.TYPE_DOUBLE:
        return "%.15g" % value  # noqa: UP031
    if field.type == _T.TYPE_BOOL:
        return "1" if value else "0"
    if field.type == _T.TYPE_BYTES:
        return ":".join(f"{b:02x}" for b in value)
    return str(value)


# Every example runs tshark on 250 datagrams (seconds each): shrinking a failure would run it
# hundreds of times (once, 317 s of CI). No shrink phase, so a failure costs seconds, and
# assert_as_decode names the failing frame and decode's record of it, which is what to look at
# (hypothesis's own print of the 250 datagrams is long: its warning about that is no failure).
@pytest.mark.filterwarnings("ignore:Generating overly large repr")
@settings(
    max_examples=4,
    deadline=None,
    phases=[Phase.explicit, Phase.reuse, Phase.generate],
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
@given(st.lists(hostile_datagrams(erc_codec.Codec.default()), min_size=250, max_size=250))
def test_whatever_arrives_dissects_as_decode_reads_it(
    tshark: str, tmp_path_factory: pytest.TempPathFactory, datagrams: list[bytes]
) -> None:
    codec = erc_codec.Codec.default()
    folder = tmp_path_factory.mktemp("hostile")
    lua = dissector(folder)
    capture = folder / "hostile.pcap"
    write_pcap(capture, [d for d in datagrams if d])  # UDP hands an empty one to no dissector
    assert_as_decode(tshark, lua, capture, codec)


def test_every_kind_of_field_dissects_as_decode_reads_it(tshark: str, tmp_path: Path) -> None:
    codec = erc_codec.Codec.from_path(TREE, "Env")
    schema = ("--proto", str(TREE), "--root", "Env")
    lua = dissector(tmp_path, *schema)
    sent: list[bytes] = []

    @settings(max_examples=60, deadline=None, database=None)
    @given(st.sampled_from(sorted(codec.kinds().values())).flatmap(_payload_of(codec)))
    def draw(drawn: tuple[str, Any]) -> None:
        kind, payload = drawn
        if kind == "closed" and not payload.HasField("id"):
            payload.id = 0  # required: the strategy leaves it unset
        envelope = codec.message_class("Env")()
        getattr(envelope, kind).CopyFrom(payload)
        sent.extend(codec.encode(envelope, mode) for mode in MODES)

    draw()
    sent.append(bytes.fromhex("0a05 4a0141 4a00"))  # text "A", then "": protobuf keeps ""
    closed = codec.message_class("Closed")(id=-7, modes=[1, 0])
    # mode = 5, then modes packed [1, 2]: 5 and 2 are no Mode, kept aside as unknown fields
    undeclared = closed.SerializeToString() + bytes.fromhex("0805 1202 0102")
    sent.append(b"\x12" + bytes([len(undeclared)]) + undeclared)
    sent.append(bytes.fromhex("0a03 4a01ff"))  # text: 0xff is not UTF-8 in a proto3 string
    sent.append(bytes.fromhex("0a07 a80105 b2010141"))  # left = 5, then right = "A": the last
    capture = tmp_path / "every.pcap"
    write_pcap(capture, sent)
    records = assert_as_decode(tshark, lua, capture, codec, *schema)
    assert records[-4]["message"]["text"] == ""
    assert records[-2]["reason"] == "corrupt"
    assert records[-1]["message"]["right"] == "A"
    assert "left" not in records[-1]["message"]
    assert records[-3]["message"]["modes"] == ["ON", "OFF", "ON"]
    assert "mode" not in records[-3]["message"]
    for data, layer in zip(sent[: 60 * 3], layers(tshark, lua, capture), strict=False):
        kind, message = codec.decode(data)
        assert same(wireshark_values(layer[f"erc.Env.{kind}"]), shown(message))  # type: ignore[index]


def _payload_of(codec: erc_codec.Codec) -> Any:
    def payload(kind: str) -> st.SearchStrategy[tuple[str, Message]]:
        name = descriptor_of(codec.payload_class(kind)).full_name
        return messages(codec, name).map(lambda message: (kind, message))

    return payload


def test_floats_are_labelled_with_the_value_decode_prints(
    tshark: str, codec: erc_codec.Codec, tmp_path: Path
) -> None:
    lua = dissector(tmp_path)
    gps = codec.message_class("SensorBoardGPSInfo")
    floats = [0.1, 1e-45, 1.17549435e-38, 3.4028235e38, -0.0, 16777217.0, math.inf, math.nan]
    doubles = [0.1 + 0.2, 5e-324, 1e300, -math.inf, 52.2389, 1 / 3, 2.0**53 + 2, math.nan]
    sent = [
        codec.encode(gps(altitude=f, latitude=d), "exact")
        for f, d in zip(floats, doubles, strict=True)
    ]
    capture = tmp_path / "floats.pcap"
    write_pcap(capture, sent)
    records = assert_as_decode(tshark, lua, capture, codec)
    labels = [
        (
            tree.find(".//field[@name='erc.SensorBoardGPSInfo.altitude']").attrib["showname"],  # type: ignore[union-attr]
            tree.find(".//field[@name='erc.SensorBoardGPSInfo.latitude']").attrib["showname"],  # type: ignore[union-attr]
        )
        for tree in trees(tshark, lua, capture)
        if tree is not None
    ]
    assert labels[0] == ("altitude: 0.1", "latitude: 0.30000000000000004")
    assert labels[5][0] == "altitude: 16777216"
    assert labels[3][1] == "latitude: -Infinity"
    assert labels[4] == ("altitude: -0", "latitude: 52.2389")
    assert labels[6] == ("altitude: Infinity", "latitude: 9007199254740994")
    assert labels[7] == ("altitude: NaN", "latitude: NaN")
    assert [r["message"]["altitude"] for r in records[:4]] == [
        0.1,
        1.4013e-45,  # protobuf's JSON printer starts at 6 digits, as the dissector does
        1.1754944e-38,
        3.4028235e38,
    ]


def test_unknown_fields_and_members_are_marked_never_shown_as_fields(
    tshark: str, codec: erc_codec.Codec, tmp_path: Path
) -> None:
    lua = dissector(tmp_path)
    gps = codec.message_class("SensorBoardGPSInfo")(satellites=9).SerializeToString()
    newer = gps + bytes.fromhex("7a0101")  # field 15, which a newer sender added
    sent = [
        b"\x62" + bytes([len(newer)]) + newer,
        bytes.fromhex("6200") + bytes.fromhex("b20100"),  # gps_info, then member 22
    ]
    capture = tmp_path / "newer.pcap"
    write_pcap(capture, sent)
    assert_as_decode(tshark, lua, capture, codec)
    first, second = trees(tshark, lua, capture)
    assert first is not None
    assert second is not None
    (unknown,) = first.findall(".//field[@name='erc.unknown']")
    assert unknown.attrib["showname"] == "Unknown field 15 (LEN)"
    assert unknown.find("field[@name='erc.unknown.number']").attrib["show"] == "15"  # type: ignore[union-attr]
    assert unknown.find(".//field[@name='erc.unknown_field']") is not None  # the expert info
    payload = first.find("field[@name='erc.PBEnvelope.gps_info']")
    assert payload is not None
    assert len(payload.findall("field[@name='erc.unknown']")) == 1
    assert second.find("field[@name='erc.kind']").attrib["show"] == "gps_info"  # type: ignore[union-attr]
    (member,) = second.findall("field[@name='erc.unknown']")
    assert member.attrib["showname"] == "Unknown member 22 (LEN)"
    assert member.find(".//field[@name='erc.unknown_member']") is not None


def test_the_ports_are_the_fleets_unless_told(
    tshark: str, codec: erc_codec.Codec, tmp_path: Path
) -> None:
    data = codec.encode(codec.message_class("SensorBoardGPSInfo")(satellites=9))
    for port, ports, dissected in [
        (5000, (), True),  # the comms node's port
        (7, (), True),  # the boards broadcast to port 7
        (6000, (), False),
        (6000, ("--port", "6000"), True),
        (5000, ("--port", "6000"), False),
    ]:
        lua = dissector(tmp_path, *ports)
        capture = tmp_path / "port.pcap"
        write_pcap(capture, [data], dport=port)
        (layer,) = layers(tshark, lua, capture)
        assert (layer is not None) == dissected, (port, ports)


def test_a_folder_name_is_never_lua_code(tshark: str, tmp_path: Path) -> None:
    tree = tmp_path / 't\nprint("INJECTED")\n--'
    shutil.copytree(TREE, tree)
    lua = dissector(tmp_path, "--proto", str(tree), "--root", "Env")
    assert "--   schema_tree: " + str(tree).replace("\n", "\\n") + "\n" in lua.read_text()
    codec = erc_codec.Codec.from_path(tree, "Env")
    capture = tmp_path / "one.pcap"
    write_pcap(capture, [codec.encode(codec.message_class("Inner")())])
    done = subprocess.run(
        [tshark, "-X", f"lua_script:{lua}", "-r", str(capture)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    assert "INJECTED" not in done.stdout + done.stderr


def test_a_schema_the_dissector_cannot_read_is_one_line(tmp_path: Path) -> None:
    (tmp_path / "e.proto").write_text(
        'edition = "2023";\nmessage Env { oneof p { G g = 1; } }\nmessage G { int32 x = 1; }\n'
    )
    done = erc_codec_cli("wireshark", "--proto", str(tmp_path), "--root", "Env")
    assert (done.returncode, done.stdout) == (2, "")
    assert done.stderr == "Error: e.proto: editions files are not supported by the dissector\n"


def _groups(depth: int) -> bytes:
    """Unknown group field 7, nested ``depth`` deep: a payload nobody's encoder writes."""
    return bytes([7 << 3 | 3]) * depth + bytes([7 << 3 | 4]) * depth


def _gps(payload: bytes, length_bytes: int) -> bytes:
    """gps_info (member 12) holding ``payload``, its length in 2 bytes, or 3 (non-canonical)."""
    n = len(payload)
    length = (
        bytes([n & 0x7F | 0x80, n >> 7])
        if length_bytes == 2
        else bytes([n & 0x7F | 0x80, n >> 7 | 0x80, 0])
    )
    return b"\x62" + length + payload


EDGES = [
    # 100 levels of nesting are upb's limit; a payload parsed on its own (decode's usual path)
    # has one more to spend than one parsed inside the envelope (a 3-byte length forces that).
    *[_gps(_groups(depth), width) for depth in (99, 100, 101) for width in (2, 3)],
    bytes.fromhex("620b 40 ffffffffffffffffff7f"),  # a 10-byte varint: bits past 64 dropped
    bytes.fromhex("620c 40 ffffffffffffffffffff01"),  # 11 bytes: corrupt
    bytes.fromhex("620a 8880808000 0000000000000000"),  # a 5-byte tag
    bytes.fromhex("6207 f8ffffff0f01"),  # the largest field number
    bytes.fromhex("6206 8880808010 01"),  # a tag over 32 bits (else: field 1, an unknown VARINT)
    bytes.fromhex("e20000"),  # a non-canonical two-byte tag for member 12 (general path)
    bytes.fromhex("628000"),  # a non-canonical two-byte length 0
    bytes.fromhex("6a00 6200"),  # two members: the last is the payload
    bytes.fromhex("6200 b20100"),  # a member, then an unknown one
    bytes.fromhex("b20100 6200"),
    bytes.fromhex("6005 6200"),  # a member on the wrong wire type, then a good one
    bytes.fromhex("6b6c"),  # groups at the top: refused
    bytes.fromhex("6202 0b0c"),  # an unknown group in the payload: kept aside
    bytes.fromhex("6201 0c"),  # an end-group that closes nothing
    bytes.fromhex("620a 0d00000000 0d01000000"),  # a field given twice: the last wins
    bytes.fromhex("62024003 6200"),  # a member given twice: protobuf merges the two
    bytes.fromhex("5a02 3280"),  # a submessage cut inside its length
]


def test_the_edges_of_the_wire_format_dissect_as_decode_reads_them(
    tshark: str, codec: erc_codec.Codec, tmp_path: Path
) -> None:
    lua = dissector(tmp_path)
    capture = tmp_path / "edges.pcap"
    write_pcap(capture, EDGES)
    records = assert_as_decode(tshark, lua, capture, codec)
    reasons = [record.get("reason", "ok") for record in records[:6]]
    assert reasons == ["ok", "ok", "ok", "corrupt", "corrupt", "corrupt"]


# The envelope's metadata (the rover's timeout, field 30) alone, beside the payload, before or
# after it: (datagram, decode's reason, or "" where it decodes).
METADATA = [
    ("f0 01 05", "no_payload"),  # metadata and no payload
    ("f0 01 05 00 00", "no_payload"),  # the same, zero-padded
    ("f0 01 05 f0 01 06", "no_payload"),  # given twice
    ("f2 01 00", "no_payload"),  # its number on another wire type
    ("f0 01 05 b2 01 00", "no_payload"),  # then an unknown member: decode names the first field
    ("b2 01 00 f0 01 05", "unknown_member"),
    ("00 00 00", "no_payload"),
    ("f0 01", "truncated"),  # stripped to its tag: a timeout of 0, which no encoder sends
    ("62 00 f0 01", "truncated"),
    ("62 02 40 03 f0 01 ac 02", ""),  # after the payload, where encode writes it
    ("f0 01 05 62 00", ""),  # before it
    ("f0 01 05 62 00 f0 01 06", ""),  # given twice: the last kept
    ("62 00 f0 01 00", ""),  # an explicit 0, which decode does not list
    ("62 00 f2 01 00", ""),  # on another wire type: an unknown field
]


def test_envelope_metadata_dissects_as_decode_reads_it(
    tshark: str, codec: erc_codec.Codec, tmp_path: Path
) -> None:
    """Metadata is never the payload: alone it is refused with decode's reason and words; beside
    a payload it shows as the envelope's field, with the value decode lists."""
    lua = dissector(tmp_path)
    capture = tmp_path / "metadata.pcap"
    write_pcap(capture, [h(data) for data, _ in METADATA])
    records = assert_as_decode(tshark, lua, capture, codec)  # the metadata values too
    seen = trees(tshark, lua, capture)
    for (data, reason), record, tree in zip(METADATA, records, seen, strict=True):
        assert tree is not None
        assert record.get("reason", "") == reason, (data, record)
        if reason:
            error = tree.find("field[@name='erc.error']")
            assert error is not None
            assert error.attrib["show"] == record["error"], data  # decode's words
            assert tree.find(".//field[@name='erc.refused']") is not None  # the expert info
        else:
            kind = tree.find("field[@name='erc.kind']")
            assert kind is not None
            assert kind.attrib["show"] == "gps_info"
    shown = {data: tree for (data, _), tree in zip(METADATA, seen, strict=True) if tree is not None}
    assert records[9]["metadata"] == {"timeout": 300}
    timeout = "field[@name='erc.PBEnvelope.timeout']"
    (only,) = shown["62 02 40 03 f0 01 ac 02"].findall(timeout)
    assert only.attrib["showname"] == "timeout: 300"
    first, last = shown["f0 01 05 62 00 f0 01 06"].findall(timeout)
    assert first.find(".//field[@name='erc.overridden']") is not None
    assert last.find(".//field[@name='erc.overridden']") is None
    (unknown,) = shown["62 00 f2 01 00"].findall("field[@name='erc.unknown']")
    assert unknown.attrib["showname"] == "Unknown field 30 (LEN)"
    assert unknown.find(".//field[@name='erc.unknown_field']") is not None


# -- cut, not stripped -------------------------------------------------------------------------

SCHEMAS: dict[str, tuple[str, ...]] = {
    "rover": (),
    "limits": ("--proto", str(REPO / "tests" / "contract_tree"), "--root", "LimitsEnvelope"),
    "presence": ("--proto", str(REPO / "tests" / "schema_trees" / "presence"), "--root", "Env"),
    "every": ("--proto", str(TREE), "--root", "Env"),
    "json": ("--proto", str(REPO / "tests" / "json_tree"), "--root", "JsonEnvelope"),
}
# Beside tests/datagrams.py's TRUNCATED and AMBIGUOUS: (schema, datagram, what decode's error
# names, or "" where it decodes). Every kind of field, oneofs and optionals, merged occurrences
# (the index of an item counts the merged message's), map keys of every kind.
CUTS: list[tuple[str, str, str]] = [
    ("presence", "0a 02 08", "Counter.id = 0"),
    *[("presence", d, "") for d in ("0a 02 10", "0a 05 2d", "0a 05 1d 05", "12 02 10", "0a")],
    ("every", "0a 03 88 01", "AllTypes.s64 = 0"),
    ("every", "0a 02 40", "AllTypes.b = false"),
    ("every", "0a 05 3d", "AllTypes.f32 = 0,"),
    ("every", "0a 02 4a", 'AllTypes.text = ""'),
    ("every", "0a 02 5a", 'AllTypes.raw = ""'),
    ("every", "0a 03 92 01", "AllTypes.many = [] (an empty packed list)"),
    ("every", "0a 05 92 01 02 85", "its last byte in AllTypes.many continues a varint"),
    ("every", "0a 04 52 02 10", "AllTypes.inner.c = RED"),
    ("every", "0a 08 9a 01 00 9a 01 02 08", "AllTypes.inners[1].s = 0"),
    ("every", "0a 03 9a 01 00 0a 05 9a 01 02 08", "AllTypes.inners[1].s = 0"),  # merged
    ("every", "0a 03 9a 01 00 1a 00 0a 05 9a 01 02 08", "AllTypes.inners[0].s = 0"),  # cleared
    ("every", "a2 01 02 68", "AllTypes.color = RED"),  # a two-byte member tag
    ("every", "1a 02 08", "Inner.s = 0"),
    ("every", "12 04 12 02 81", "its last byte in Closed.modes continues a varint"),
    ("every", "12 04 12 02 01", ""),  # proto2, its required id missing: it parses
    ("every", "12 02 08", ""),  # proto2: explicit presence
    *[("every", d, "") for d in ("0a 09 79 01", "0a 03 a0 01", "0a 03 a8 01", "0a 03 b2 01")],
    ("every", "0a 06 bd 01", ""),  # an unpacked float item
    ("every", "0a 05 92 01 02 05", ""),  # a packed list ending in 0
    ("every", "0a 05 45", ""),  # a known number on another wire type: unknown
    ("every", "0a 04 f8 01 85", ""),  # an unknown field's varint
    ("json", "1a 11 0a 0f 08 fd ff ff ff ff ff ff ff ff 01 12 02 08",
     "JsonMaps.by_int32[key=-3].colour = JSON_COLOUR_NONE"),
    ("json", "1a 06 0a 04 12 02 08", "JsonMaps.by_int32[key=0].colour = JSON_COLOUR_NONE"),
    ("json", "1a 07 1a 05 08 01 10 85", "in JsonMaps.by_bool[key=true] continues"),
    ("json", "1a 09 22 07 0a 02 61 62 12 80", "in JsonMaps.by_string[key=ab] continues"),
    ("json", "1a 0a 2a 08 15 00 00 80 3f 08 81", "in JsonMaps.by_sint64[key=-1] continues"),
    ("json", "1a 0a 32 08 0d 07 00 00 00 10 85", "in JsonMaps.by_fixed32[key=7] continues"),
    ("json", "1a 13 12 11 11 00 00 00 00 00 00 f0 3f 08 80 80 80 80 80 a0",
     "in JsonMaps.by_uint64[key=1099511627776] continues"),
]  # fmt: skip


@pytest.mark.parametrize("schema", sorted(SCHEMAS))
def test_a_cut_datagram_dissects_as_decode_refuses_it(
    tshark: str, tmp_path: Path, schema: str
) -> None:
    """Each case of the truncation rules: refused as truncated with decode's own words, or
    restored, exactly where decode does either."""
    args = SCHEMAS[schema]
    codec = erc_codec.Codec.from_path(Path(args[1]), args[3]) if args else erc_codec.Codec.default()
    cases = [(h(c[2]), c[3]) for c in TRUNCATED if c[1] == schema]
    cases += [(h(c[2]), "") for c in AMBIGUOUS if c[1] == schema]
    cases += [(h(data), named) for name, data, named in CUTS if name == schema]
    lua = dissector(tmp_path, *args)
    capture = tmp_path / "cut.pcap"
    write_pcap(capture, [data for data, _ in cases])
    records = assert_as_decode(tshark, lua, capture, codec, *args)
    for (data, named), record, tree in zip(
        cases, records, trees(tshark, lua, capture), strict=True
    ):
        assert tree is not None
        if not named:
            assert "kind" in record, (data.hex(), record)
            continue
        assert record["reason"] == "truncated", (data.hex(), record)
        assert named in record["error"], (data.hex(), record)
        error = tree.find("field[@name='erc.error']")
        assert error is not None
        assert error.attrib["show"] == record["error"]  # decode's words, path and all
        assert tree.find(".//field[@name='erc.refused']") is not None  # the expert info


def test_a_map_entry_holding_an_unknown_field_is_kept_aside_whole(
    tshark: str, tmp_path: Path
) -> None:
    """upb keeps a map entry holding a field the entry does not know out of the map, as one
    unknown field of the message; a field the map's value does not know stays in the value."""
    args = SCHEMAS["limits"]
    codec = erc_codec.Codec.from_path(Path(args[1]), args[3])
    sent = [
        h("0a 06 32 04 08 01 30 0c"),  # palette: key 1, then field 6
        h("0a 0a 52 08 08 07 12 02 10 05 30 01"),  # places: key 7, x = -3, then field 6
        h("0a 08 52 06 08 07 12 02 18 01"),  # places: key 7, its value holding field 3
    ]
    lua = dissector(tmp_path, *args)
    capture = tmp_path / "maps.pcap"
    write_pcap(capture, sent)
    records = assert_as_decode(tshark, lua, capture, codec, *args)
    assert [(r["message"]["palette"], list(r["message"]["places"])) for r in records] == [
        ({}, []),
        ({}, []),
        ({}, ["7"]),
    ]
    first, second, third = trees(tshark, lua, capture)
    for tree, shown in [(first, "Unknown field 6 (LEN)"), (second, "Unknown field 10 (LEN)")]:
        assert tree is not None
        (entry,) = tree.findall(".//field[@name='erc.unknown']")
        assert entry.attrib["showname"] == shown
        why = entry.find(".//field[@name='_ws.expert.message']")
        assert why is not None
        assert "a map entry holding a field it does not know" in why.attrib["show"]
    assert third is not None
    (inside,) = third.findall(
        ".//field[@name='erc.LimitsRecord.places']//field[@name='erc.unknown']"
    )
    assert inside.attrib["showname"] == "Unknown field 3 (VARINT)"
