"""erc_codec.proton's BundleCodec: Proton's wire format, 2.0 and 1.0, byte for byte.

The expected bytes here are worked out by hand from Proton's .proto files (2.0-d269668/proto and
1.0-8c898cf/proto); tests/proton/test_proton_interop.py checks the same against Proton's C
libraries, and test_protons_own_proto_files_read_the_same_bytes below against Google protobuf with
Proton's own .proto files.
"""

import contextlib
import os
from pathlib import Path
from typing import Any, NamedTuple

import pytest
from conftest import REPO
from google.protobuf import descriptor_pool, message_factory
from google.protobuf.message import Message
from hypothesis import given, settings
from hypothesis import strategies as st
from proton_values import TYPES_1_0, TYPES_2_0, same, values

import erc_codec
from erc_codec.proton import (
    Bundle,
    BundleCodec,
    ProtonConfigError,
    UnknownField,
    Value,
    parse_config,
)
from erc_schema import compile_files, encode_varint, next_field

V2 = BundleCodec(TYPES_2_0)
V1 = BundleCodec(TYPES_1_0, "1.0")
SHARED = REPO.parent / "shared" / "peers" / "proton"


def field(number: int, wire_type: int, content: bytes) -> bytes:
    """A tag and its value; a LEN value gets its length prefix."""
    key = encode_varint(number << 3 | wire_type)
    return key + (encode_varint(len(content)) + content if wire_type == 2 else content)


def signal2(value: bytes, signal_id: int) -> bytes:
    return field(2, 2, value + (field(19, 0, encode_varint(signal_id)) if signal_id else b""))


def bundle2(bundle_id: int, *signals: bytes) -> bytes:
    content = (field(1, 0, encode_varint(bundle_id)) if bundle_id else b"") + b"".join(signals)
    return field(1, 2, content)


def test_protocol_2_0_by_hand() -> None:
    # Proton { bundle = 1 } > Bundle { id = 1, signals = 2 } > Signal { value, id = 19 }
    assert V2.encode("heartbeat", {"beat": 5}) == bytes.fromhex("0a07 1205 2805 98011d")
    assert V2.encode("int32s", {"an_int32": -1}) == bytes.fromhex(
        "0a13 088202 120e 18ffffffffffffffffff01 980112"  # sign-extended to 10 bytes
    )
    strings = V2.encode("strings", {"text_1": "", "text_8": "abc", "text_300": ""})
    assert strings == bytes.fromhex(  # each string with its NUL: strlen + 1 bytes
        "0a1e 088702 1206 420100 980117 1209 420461626300 980118 1206 420100 980119"
    )
    assert V2.encode("nothing", {}) == bytes.fromhex("0a03 088006")
    zero = V2.encode("doubles", {"a_double": 0.0})
    assert zero == bytes.fromhex("0a11 088002 120c 090000000000000000 980110")  # a oneof: sent
    everything = V2.encode("everything", _defaults(V2, "everything"))
    assert bytes.fromhex("1202 2800") in everything  # signal id 0: its id is not sent
    assert V2.decode(everything).signals["id_zero"] == 0


def test_protocol_1_0_by_hand() -> None:
    # Bundle { id = 1, signals = 2 } > Signal { value }: no Proton wrapper, no signal ids
    assert V1.encode("heartbeat", {"beat": 5}) == bytes.fromhex("1202 2805")
    mixed = V1.encode(
        "mixed",
        {"texts": ["a", "", "bcd"], "a_double": 1.0, "blobs": [b"\x01\x02\x03\x04", bytes(4)]},
    )
    assert mixed == bytes.fromhex(
        "088202"
        "120d 8a010a 0a0161 0a00 0a03626364"  # strings without their NUL
        "1209 09000000000000f03f"
        "120f 92010c 0a0401020304 0a0400000000"  # bytes as their whole buffer
    )
    lists = V1.encode("lists", _defaults(V1, "lists"))
    assert lists.startswith(bytes.fromhex("088102 121d 521b 09" + "00" * 8 + "09"))  # unpacked


def _defaults(codec: BundleCodec, bundle: str) -> dict[str, object]:
    config = codec.config
    return {name: config.signal(name).default for name in config.bundle(bundle).signals}


@pytest.mark.parametrize(
    ("codec", "bundle"),
    [(V2, b.name) for b in TYPES_2_0.bundles] + [(V1, b.name) for b in TYPES_1_0.bundles],
)
@given(data=st.data())
@settings(max_examples=60, deadline=None)
def test_every_value_comes_back(codec: BundleCodec, bundle: str, data: st.DataObject) -> None:
    config = codec.config
    sent = {
        name: data.draw(values(config.signal(name), codec.version), label=name)
        for name in config.bundle(bundle).signals
    }
    encoded = codec.encode(bundle, sent)
    decoded = codec.decode(encoded)
    assert (decoded.name, decoded.id) == (bundle, config.bundle(bundle).id)
    assert list(decoded.signals) == list(sent)
    assert all(same(decoded.signals[name], codec.check(name, sent[name])) for name in sent)
    assert codec.encode(bundle, decoded.signals) == encoded


def test_decode_accepts_any_order_and_packed_lists() -> None:
    beat = field(5, 0, b"\x07")
    reordered = field(1, 2, field(2, 2, field(19, 0, b"\x1d") + beat))  # the id first
    assert V2.decode(reordered) == Bundle("heartbeat", 0, {"beat": 7})
    unpacked = V1.encode("lists", _defaults(V1, "lists"))
    one_tag_each = field(2, 2, field(11, 2, b"".join(field(1, 5, bytes(4)) for _ in range(4))))
    packed = field(2, 2, field(11, 2, field(1, 2, bytes(16))))  # Google protobuf's spelling
    assert one_tag_each in unpacked  # 1.0's Bundle is the whole message: no length around it
    decoded = V1.decode(unpacked.replace(one_tag_each, packed))
    assert decoded.signals["floats"] == [0.0] * 4


# -- what decode accepts and refuses, and what Proton's C library does with the same bytes ------
#
# Each case records what Proton's C library does with the message, as the drivers of
# tests/proton/test_proton_interop.py report it (a fresh peer, its registry at the configuration's
# defaults): a refusal ("ERR 5", the driver's answer; "" where it crashes), or the bundle and the
# values it reads instead (over the bundle's defaults), a misreading. test_proton_interop.py asks
# the C libraries and checks every one; here erc_codec's side.


class Refused(NamedTuple):
    data: bytes
    reason: str
    problem: str
    c: str | tuple[str, dict[str, object]]
    before: bytes = b""  # a message the C library decodes first, in the same registry


class Accepted(NamedTuple):
    data: bytes
    bundle: str
    signals: dict[str, Value]
    unknown: tuple[UnknownField, ...] = ()


HEARTBEAT = signal2(field(5, 0, b"\x05"), 0x1D)
A_BOOL = signal2(field(7, 0, b"\x01"), 0x16)
TEXT_1, TEXT_300 = signal2(field(8, 2, b"\0"), 0x17), signal2(field(8, 2, b"\0"), 0x19)


def text_8(content: bytes) -> bytes:
    """The strings bundle (0x107), text_8 carrying ``content``: its signal at offset 13."""
    return bundle2(0x107, TEXT_1, signal2(content, 0x18), TEXT_300)


REFUSED_2_0 = [
    Refused(b"", "empty", "no bytes", "ERR 15"),
    Refused(field(2, 2, b""), "unsupported_operation", "field 2 at offset 0 is an op", "ERR 15"),
    Refused(bundle2(0x999), "unknown_bundle", "bundle id 0x999 is not in", "ERR 1"),
    Refused(
        bundle2(0),
        "corrupt",
        "bundle 'heartbeat' (0x0): lacks 'beat'",
        ("heartbeat", {"beat": 5}),  # the last message's value again
        before=bundle2(0, HEARTBEAT),
    ),
    Refused(bundle2(0), "corrupt", "lacks 'beat'", "ERR 1"),
    Refused(
        bundle2(0, HEARTBEAT, signal2(field(5, 0, b"\x07"), 0x1D)),
        "corrupt",
        "signal 'beat' again at offset 9",
        ("heartbeat", {"beat": 7}),  # the last; protobuf holds two
    ),
    Refused(
        bundle2(0x106, A_BOOL) + bundle2(0x106, signal2(field(7, 0, b"\x00"), 0x16)),
        "corrupt",
        "signal 'a_bool' again at offset 17",  # two Proton.bundle fields merge
        ("bools", {"a_bool": False}),
    ),
    Refused(
        bundle2(0, signal2(field(3, 0, b"\x05"), 0x1D)),
        "corrupt",
        "signal 'beat' at offset 2 is sent as int32; the configuration says uint32",
        "ERR 1",
    ),
    Refused(
        bundle2(0, signal2(field(5, 0, b"\x05"), 0x1E)),
        "corrupt",
        "signal id 0x1e at offset 2 is not in it",
        "ERR 5",
    ),
    Refused(
        bundle2(
            0x106, field(2, 2, field(19, 0, b"\x16") + field(7, 0, b"\x01") + field(19, 0, b"\x10"))
        ),
        "corrupt",
        "signal id 0x10 at offset 5 is not in it",  # the last id given counts
        "ERR 5",
    ),
    Refused(
        bundle2(0, signal2(field(5, 0, b"\x80\x80\x80\x80\x10"), 0x1D)),
        "corrupt",
        "its value is 4294967296, out of uint32's range",
        "ERR 5",
    ),
    Refused(
        bundle2(0x105, signal2(field(6, 0, b"\xff" * 9 + b"\x03"), 0x15)),
        "corrupt",
        "its value (36893488147419103231) does not fit 64 bits",
        "ERR 5",
    ),
    Refused(
        bundle2(0x106, signal2(field(7, 0, b"\x80\x80\x80\x80\x10"), 0x16)),
        "corrupt",
        "its value (4294967296) has bits past 32: Proton's C library reads a bool with "
        "pb_decode_varint32, which refuses it",
        "ERR 5",
    ),
    Refused(
        bundle2(0, signal2(field(5, 0, b"\x05") + field(6, 0, b"\x05"), 0x1D)),
        "corrupt",
        "signal 'beat' at offset 2 is sent as uint64",  # the last value counts
        "ERR 1",
    ),
    Refused(
        text_8(field(8, 2, b"ab\0") + field(8, 2, b"cd\0")),
        "corrupt",
        "signal 'text_8' at offset 13 carries two values (fields 8 and 8): Proton's C library "
        "reads a string only as a signal's first value",
        "ERR 5",
    ),
    Refused(
        text_8(field(1, 1, bytes(8)) + field(8, 2, b"cd\0")),
        "corrupt",
        "carries two values (fields 1 and 8)",
        "ERR 5",
    ),
    Refused(
        bundle2(0, signal2(b"", 0x1D)), "corrupt", "signal at offset 2 carries no value", "ERR 1"
    ),
    Refused(
        bundle2(0, signal2(field(10, 2, b""), 0x1D)),
        "corrupt",
        "carries no value (field 10, 1.0's list_double, is not 2.0's)",
        "ERR 1",
    ),
    Refused(
        bundle2(0, signal2(field(5, 2, b"\x05"), 0x1D)),
        "corrupt",
        "its uint32 has wire type LEN, not VARINT",
        "ERR 5",
    ),
    Refused(bundle2(0, HEARTBEAT)[:-1], "corrupt", "not protobuf", "ERR 5"),
    Refused(bundle2(0, HEARTBEAT) + b"\x00", "corrupt", "not protobuf: field number 0", "ERR 5"),
    Refused(
        field(1, 2, field(2, 2, b"\x28")), "corrupt", "not protobuf: varint at offset 5", "ERR 5"
    ),
    Refused(
        field(1, 0, b"\x01"), "corrupt", "the bundle at offset 0 has wire type VARINT", "ERR 5"
    ),
    Refused(
        field(1, 2, field(1, 0, b"\x86\x02") + field(2, 0, b"\x01")),
        "corrupt",
        "the signal at offset 5 has wire type VARINT, not LEN",
        "ERR 5",
    ),
    Refused(
        field(1, 2, field(1, 0, b"\x80\x80\x80\x80\x10") + A_BOOL),
        "corrupt",
        "the bundle id at offset 2 is 4294967296, out of uint32's range",
        "ERR 5",
    ),
    Refused(
        field(1, 2, A_BOOL + field(1, 0, b"\x86\x02")),
        "corrupt",
        "the signal at offset 2 comes before bundle id 0x106 (at offset 9): Proton's C core reads "
        "a signal against the bundle id given before it (0x0)",
        "ERR 5",
    ),
    Refused(
        field(1, 2, field(1, 0, b"\x86\x02") + A_BOOL + field(1, 0, b"\x87\x02")),
        "corrupt",
        "the signal at offset 5 comes before bundle id 0x107",
        "ERR 1",
    ),
    Refused(
        bundle2(0x106, A_BOOL) + bundle2(0x107),
        "corrupt",
        "the signal at offset 5 comes before bundle id 0x107 (at offset 14)",
        "ERR 1",
    ),
    Refused(
        bundle2(
            0x107,
            signal2(field(8, 2, b""), 0x17),
            signal2(field(8, 2, b"\0"), 0x18),
            TEXT_300,
        ),
        "corrupt",
        "signal 'text_1' at offset 5: lacks its terminating NUL",
        ("strings", {"text_1": ""}),  # held as 0 bytes: no NUL, sent back so
    ),
    Refused(
        text_8(field(8, 2, b"ab")),
        "corrupt",
        "signal 'text_8' at offset 13: lacks its terminating NUL",
        ("strings", {"text_8": "ab"}),  # held unterminated
    ),
    Refused(
        text_8(field(8, 2, b"a\0b\0")),
        "corrupt",
        "holds bytes after its terminating NUL at offset 18",
        ("strings", {"text_8": "a"}),  # as a C string; protobuf reads "a\0b\0"
    ),
    Refused(
        text_8(field(8, 2, b"abcdefgh\0")),
        "corrupt",
        "is 9 bytes with its NUL, over its capacity of 8",
        "ERR 5",
    ),
    Refused(
        text_8(field(8, 2, b"\xff\0")),
        "corrupt",
        "is not UTF-8 at offset 17",
        ("strings", {"text_8": b"\xff"}),  # protobuf refuses it: a string is UTF-8
    ),
    Refused(
        bundle2(0x108, signal2(field(9, 2, b"ab"), 0x1A), signal2(field(9, 2, b""), 0x1B)),
        "corrupt",
        "signal 'blob_1' at offset 5: is 2 bytes; its capacity takes at most 1",
        "ERR 5",
    ),
]

ACCEPTED_2_0 = [
    Accepted(
        bundle2(0x102, signal2(field(3, 0, b"\xff\xff\xff\xff\x0f"), 0x12)),
        "int32s",
        {"an_int32": -1},
    ),
    Accepted(  # bits past 32 in an int32: both keep the low 32
        bundle2(0x102, signal2(field(3, 0, b"\x85\x80\x80\x80\x10"), 0x12)),
        "int32s",
        {"an_int32": 5},
    ),
    Accepted(bundle2(0x106, signal2(field(7, 0, b"\x02"), 0x16)), "bools", {"a_bool": True}),
    Accepted(
        bundle2(0x106, signal2(field(7, 0, b"\xff" * 9 + b"\x01"), 0x16)), "bools", {"a_bool": True}
    ),
    Accepted(
        bundle2(0x106, signal2(field(7, 0, b"\xff\xff\xff\xff\x7f"), 0x16)),
        "bools",
        {"a_bool": True},
    ),
    Accepted(bundle2(0x106, signal2(field(7, 0, b"\x80\x00"), 0x16)), "bools", {"a_bool": False}),
    Accepted(
        bundle2(0x104, signal2(field(5, 0, b"\x85\x80\x80\x80\x80\x00"), 0x14)),
        "uint32s",
        {"a_uint32": 5},
    ),
    Accepted(  # the signal's id given twice: the last
        bundle2(0x106, signal2(field(7, 0, b"\x01") + field(19, 0, b"\x10"), 0x16)),
        "bools",
        {"a_bool": True},
    ),
    Accepted(  # the bundle's id given twice, before its signals: the last
        field(1, 2, field(1, 0, b"\x80\x02") + field(1, 0, b"\x86\x02") + A_BOOL),
        "bools",
        {"a_bool": True},
    ),
    Accepted(bundle2(0x106, A_BOOL) + field(1, 2, b""), "bools", {"a_bool": True}),  # merged
    Accepted(  # a value field given twice: the last
        bundle2(0x104, signal2(field(5, 0, b"\x05") + field(5, 0, b"\x07"), 0x14)),
        "uint32s",
        {"a_uint32": 7},
    ),
    Accepted(
        bundle2(0x104, signal2(field(6, 0, b"\x05") + field(5, 0, b"\x07"), 0x14)),
        "uint32s",
        {"a_uint32": 7},
    ),
    Accepted(
        bundle2(0x104, signal2(field(8, 2, b"ab\0") + field(5, 0, b"\x07"), 0x14)),
        "uint32s",
        {"a_uint32": 7},
    ),
    Accepted(field(1, 2, field(1, 0, b"\x00") + HEARTBEAT), "heartbeat", {"beat": 5}),
    Accepted(
        field(1, 2, field(2, 2, field(19, 0, b"\x1d") + field(5, 0, b"\x07"))),
        "heartbeat",
        {"beat": 7},
    ),
    Accepted(
        bundle2(0x106, signal2(field(20, 0, b"\x01") + field(7, 0, b"\x01"), 0x16)),
        "bools",
        {"a_bool": True},
        (UnknownField("Signal", 20, 7),),
    ),
    Accepted(
        bundle2(0x106, signal2(field(10, 2, b"") + field(7, 0, b"\x01"), 0x16)),
        "bools",
        {"a_bool": True},
        (UnknownField("Signal", 10, 7),),  # 1.0's list_double: not a field of 2.0's Signal
    ),
    Accepted(
        field(1, 2, field(1, 0, b"\x86\x02") + field(3, 2, b"xy") + A_BOOL),
        "bools",
        {"a_bool": True},
        (UnknownField("Bundle", 3, 5),),
    ),
    Accepted(
        bundle2(0x106, A_BOOL) + field(3, 5, b"abcd"),
        "bools",
        {"a_bool": True},
        (UnknownField("Proton", 3, 12),),
    ),
]


@pytest.mark.parametrize("case", REFUSED_2_0)
def test_what_proton_2_0_would_refuse_or_misread_is_a_decode_error(case: Refused) -> None:
    with pytest.raises(erc_codec.DecodeError) as caught:
        V2.decode(case.data)
    assert caught.value.reason == case.reason
    assert case.problem in str(caught.value), str(caught.value)


@pytest.mark.parametrize("case", ACCEPTED_2_0)
def test_what_protobuf_and_proton_2_0_read_alike_decodes(case: Accepted) -> None:
    assert V2.decode(case.data) == Bundle(
        case.bundle, TYPES_2_0.bundle(case.bundle).id, case.signals, case.unknown
    )


def test_floats_keep_their_bits_but_a_signalling_nan() -> None:
    """CPython holds a float32 signalling NaN as a quiet one (documented in _codec.py)."""
    for bits in ("7fc00001", "ffc00123", "80000000", "00000001", "7f7fffff"):
        message = bundle2(0x101, signal2(field(2, 5, bytes.fromhex(bits)[::-1]), 0x11))
        assert V2.encode("floats", V2.decode(message).signals) == message
    signalling = bundle2(0x101, signal2(field(2, 5, bytes.fromhex("7f800001")[::-1]), 0x11))
    quieted = bundle2(0x101, signal2(field(2, 5, bytes.fromhex("7fc00001")[::-1]), 0x11))
    assert V2.encode("floats", V2.decode(signalling).signals) == quieted


def test_a_string_padded_with_nuls_reads_as_the_c_registry_reads_it() -> None:
    """The generated registry sends a string at its whole capacity until it is first set."""
    padded = signal2(field(8, 2, b"foo" + bytes(5)), 0x18)
    decoded = V2.decode(
        bundle2(0x107, signal2(field(8, 2, b"\0"), 0x17), padded, signal2(field(8, 2, b"\0"), 0x19))
    )
    assert decoded.signals["text_8"] == "foo"


def bundle1(bundle: str, replaced: dict[str, bytes], first: bytes | None = None) -> bytes:
    """A 1.0 bundle of types_1_0.yaml at its defaults, some signals' fields ``replaced``;
    ``first``: what comes before its signals (its id, unless given)."""
    config = TYPES_1_0.bundle(bundle)
    encoded = V1.encode(bundle, _defaults(V1, bundle))
    contents, pos = [], 0
    while pos < len(encoded):
        span = next_field(encoded, pos)
        if span.number == 2:  # Bundle.signals
            contents.append(encoded[span.value : span.end])
        pos = span.end
    body = field(1, 0, encode_varint(config.id)) if first is None else first
    for name, content in zip(config.signals, contents, strict=True):
        body += field(2, 2, replaced.get(name, content))
    return body


def ints(number: int, *varints: bytes) -> bytes:
    """A 1.0 list type's field: items as varints, one tag each."""
    return field(number, 2, b"".join(field(1, 0, item) for item in varints))


REFUSED_1_0 = [
    Refused(
        field(2, 2, field(5, 0, b"\x05")) + field(2, 2, field(5, 0, b"\x07")),
        "corrupt",
        "2 signals; Proton 1.0 tells them by position and the bundle has 1",
        ("heartbeat", {"beat": 7}),  # one over the other
    ),
    Refused(
        field(2, 2, field(8, 2, b"a")) + field(1, 0, b"\x99\x01"),
        "corrupt",
        "the bundle id at offset 5 is not the message's first field",
        "ERR decode",  # PROTON_DecodeId finds no id: decoded as the heartbeat's bundle
    ),
    Refused(
        field(3, 0, b"\x01") + bundle1("scalars", {}),
        "corrupt",
        "the bundle id at offset 2 is not the message's first field",
        "ERR decode",
    ),
    Refused(
        bundle1("scalars", {}) + field(1, 0, encode_varint(0x101)),
        "corrupt",
        "the bundle id is 0x100, then 0x101 at offset 57: protonc decodes into the first one's "
        "bundle, protobuf reads the last",
        ("scalars", {}),
    ),
    Refused(
        bundle1("mixed", {"texts": field(17, 2, field(1, 2, b"a"))}),
        "corrupt",
        "its list holds 1 items, not its length 3",
        ("mixed", {"texts": ["a", "", ""]}),  # the rest: what the list held before
    ),
    Refused(
        bundle1("mixed", {"texts": field(17, 2, field(1, 2, b"a\0") * 3)}),
        "corrupt",
        "holds a NUL at offset",
        ("mixed", {"texts": ["a", "a", "a"]}),
    ),
    Refused(
        bundle1("mixed", {"blobs": field(18, 2, field(1, 2, b"ab") * 2)}),
        "corrupt",
        "is 2 bytes; its capacity takes exactly 4",
        ("mixed", {"blobs": [b"ab\0\0", b"ab\0\0"]}),  # the rest of each: what it held before
    ),
    Refused(
        bundle1("lists", {"bools": ints(16, *[b"\x01"] * 5) + ints(16, *[b"\x00"] * 5)}),
        "corrupt",
        "carries two values (fields 16 and 16)",
        ("lists", {}),  # the second list over the first; protobuf merges them into ten
    ),
    Refused(
        bundle1("scalars", {"an_int32": field(8, 2, b"ab") + field(3, 0, b"\x07")}),
        "corrupt",
        "signal 'an_int32' at offset 21 carries a string value: protonc decodes one only into a "
        "string signal's buffer",
        "ERR decode",
    ),
    Refused(
        bundle1("scalars", {"text_8": field(3, 0, b"\x07") + field(8, 2, b"ab")}),
        "corrupt",
        "carries two values (fields 3 and 8)",
        "",  # the string's buffer pointer overwritten by the number
    ),
    Refused(
        bundle1("lists", {"int32s": ints(12, b"\x85\x80\x80\x80\x10", b"\x01")}),
        "corrupt",
        "(4294967301) has bits past 32: Proton's C library reads a int32 item with "
        "pb_decode_varint32",
        "ERR decode",
    ),
    Refused(
        bundle1("lists", {"uint32s": ints(14, *[b"\x80\x80\x80\x80\x10"] * 3)}),
        "corrupt",
        "(4294967296) has bits past 32",
        "ERR decode",
    ),
    Refused(
        bundle1("scalars", {"a_bool": field(7, 0, b"\x80\x80\x80\x80\x10")}),
        "corrupt",
        "has bits past 32: Proton's C library reads a bool with pb_decode_varint32",
        "ERR decode",
    ),
    Refused(
        bundle1("scalars", {"a_uint32": field(5, 0, b"\x80\x80\x80\x80\x10")}),
        "corrupt",
        "its value is 4294967296, out of uint32's range",
        "ERR decode",
    ),
]

ACCEPTED_1_0 = [
    Accepted(
        bundle1("scalars", {"an_int32": field(3, 0, b"\xff\xff\xff\xff\x0f")}),
        "scalars",
        {"an_int32": -1},
    ),
    Accepted(
        bundle1("scalars", {"an_int32": field(3, 0, b"\x85\x80\x80\x80\x10")}),
        "scalars",
        {"an_int32": 5},
    ),
    Accepted(bundle1("scalars", {"a_bool": field(7, 0, b"\x02")}), "scalars", {"a_bool": True}),
    Accepted(
        bundle1("lists", {"int32s": ints(12, b"\xff\xff\xff\xff\x0f", b"\x01")}),
        "lists",
        {"int32s": [-1, 1]},
    ),
    Accepted(
        bundle1("lists", {"int32s": ints(12, b"\xff" * 9 + b"\x01", b"\x01")}),
        "lists",
        {"int32s": [-1, 1]},
    ),
    Accepted(
        bundle1("lists", {"int32s": field(12, 2, field(1, 2, b"\xff\xff\xff\xff\x0f\x01"))}),
        "lists",
        {"int32s": [-1, 1]},  # packed
    ),
    Accepted(  # a sign extension pb_decode_varint32 takes, and protobuf truncates alike
        bundle1("lists", {"uint32s": ints(14, *[b"\xff" * 9 + b"\x01"] * 3)}),
        "lists",
        {"uint32s": [0xFFFFFFFF] * 3},
    ),
    Accepted(
        bundle1("lists", {"bools": ints(16, b"\x02", *[b"\x00"] * 4)}),
        "lists",
        {"bools": [True, False, False, False, False]},
    ),
    Accepted(
        bundle1("lists", {"bools": field(16, 2, field(1, 2, b"\x02\x00\x00\x00\x07"))}),
        "lists",
        {"bools": [True, False, False, False, True]},
    ),
    Accepted(
        bundle1("scalars", {"an_int32": field(3, 0, b"\x05") + field(3, 0, b"\x07")}),
        "scalars",
        {"an_int32": 7},
    ),
    Accepted(
        bundle1("scalars", {"a_bool": field(7, 0, b"\x01") + field(19, 0, b"\x05")}),
        "scalars",
        {"a_bool": True},
        (UnknownField("Signal", 19, 41),),  # 2.0's signal id: not a field of 1.0's Signal
    ),
    Accepted(
        bundle1("scalars", {}) + field(3, 0, b"\x01"),
        "scalars",
        {},
        (UnknownField("Bundle", 3, 57),),
    ),
    Accepted(bundle1("scalars", {}) + field(1, 0, encode_varint(0x100)), "scalars", {}),
    Accepted(field(1, 0, b"\x00") + field(2, 2, field(5, 0, b"\x07")), "heartbeat", {"beat": 7}),
]


def _with_defaults(codec: BundleCodec, bundle: str, values_: dict[str, Value]) -> dict[str, Value]:
    """The bundle's signals at their configured defaults, but ``values_``."""
    config = codec.config
    signals = config.bundle(bundle).signals
    return {name: values_.get(name, config.signal(name).default) for name in signals}


@pytest.mark.parametrize("case", REFUSED_1_0)
def test_what_protonc_would_refuse_or_misread_is_a_decode_error(case: Refused) -> None:
    with pytest.raises(erc_codec.DecodeError) as caught:
        V1.decode(case.data)
    assert caught.value.reason == case.reason
    assert case.problem in str(caught.value), str(caught.value)


@pytest.mark.parametrize("case", ACCEPTED_1_0)
def test_what_protobuf_and_protonc_read_alike_decodes(case: Accepted) -> None:
    signals = _with_defaults(V1, case.bundle, case.signals)
    assert V1.decode(case.data) == Bundle(
        case.bundle, TYPES_1_0.bundle(case.bundle).id, signals, case.unknown
    )


def test_decode_raises_nothing_but_decode_errors() -> None:
    """Whatever the bytes: a DecodeError, never another exception (a cut-off varint inside a
    signal escaped as the wire layer's own error)."""

    @given(data=st.binary(max_size=64) | st.sampled_from(_mutations()))
    @settings(max_examples=500, deadline=None)
    def decodes_or_refuses(data: bytes) -> None:
        for codec in (V2, V1):
            with contextlib.suppress(erc_codec.DecodeError):
                codec.decode(data)

    decodes_or_refuses()


def _mutations() -> list[bytes]:
    """Every cut and every one-byte change of a few real messages."""
    messages = [V2.encode("heartbeat", {"beat": 300}), V1.encode("lists", _defaults(V1, "lists"))]
    messages.append(V2.encode("strings", {"text_1": "", "text_8": "abc", "text_300": "x"}))
    found = []
    for message in messages:
        for i in range(len(message)):
            found.append(message[:i])
            for byte in (0x00, 0x01, 0x7F, 0x80, 0xFF):
                found.append(message[:i] + bytes([byte]) + message[i + 1 :])
    return found


@pytest.mark.parametrize(
    ("codec", "bundle", "values_", "problem"),
    [
        (V2, "heartbeat", {}, "bundle 'heartbeat' needs a value for beat"),
        (V2, "heartbeat", {"beat": 1, "extra": 2}, "signal 'extra' is not in bundle 'heartbeat'"),
        (V2, "heartbeat", {"beat": -1}, "signal 'beat' (uint32): -1 is out of uint32's range"),
        (V2, "heartbeat", {"beat": True}, "True is not an integer"),
        (V2, "heartbeat", {"beat": 1.0}, "1.0 is not an integer"),
        (V2, "floats", {"a_float": 1e39}, "1e+39 is out of float's range (32 bits)"),
        (V2, "doubles", {"a_double": 2**53 + 1}, "has no exact double"),
        (V2, "doubles", {"a_double": "1"}, "'1' is not a number"),
        (V2, "bools", {"a_bool": 1}, "1 is not a bool"),
        (
            V2,
            "strings",
            {"text_1": "a", "text_8": "", "text_300": ""},
            "signal 'text_1' (string): 'a' is 1 bytes of UTF-8; capacity 1 holds 0",
        ),
        (V2, "strings", {"text_1": "", "text_8": "é" * 4, "text_300": ""}, "is 8 bytes of UTF-8"),
        (V2, "strings", {"text_1": "", "text_8": "a\0b", "text_300": ""}, "holds a NUL at index 1"),
        (V2, "strings", {"text_1": "", "text_8": "\ud800", "text_300": ""}, "is not UTF-8 text"),
        (
            V2,
            "blobs",
            {"blob_1": b"ab", "blob_8": b"", "blob_512": b""},
            "is 2 bytes, over its capacity of 1",
        ),
        (V2, "blobs", {"blob_1": "a", "blob_8": b"", "blob_512": b""}, "'a' is not bytes"),
        (
            V1,
            "scalars",
            {**_defaults(V1, "scalars"), "blob_4": b"ab"},
            "Proton 1.0 sends a bytes value of capacity 4 as exactly 4",
        ),
        (
            V1,
            "lists",
            {**_defaults(V1, "lists"), "bools": [True]},
            "a list_bool of length 5 is sent as exactly 5",
        ),
        (
            V1,
            "lists",
            {**_defaults(V1, "lists"), "int32s": [1, 2**31]},
            "signal 'int32s' (list_int32): item 1: 2147483648 is out of int32's range",
        ),
    ],
)
def test_what_cannot_be_sent_unchanged_is_an_encode_error(
    codec: BundleCodec, bundle: str, values_: dict[str, object], problem: str
) -> None:
    with pytest.raises(erc_codec.EncodeError) as caught:
        codec.encode(bundle, values_)
    assert problem in str(caught.value), str(caught.value)


def test_list_types_are_protocol_1_0_only() -> None:
    with pytest.raises(
        ProtonConfigError,
        match=r"types_1_0\.yaml:29: signals\[10\]\.type: list_double \(signal 'doubles'\) is a "
        r"Proton 1\.0 type",
    ):
        BundleCodec(TYPES_1_0)
    with pytest.raises(ValueError, match="version must be"):
        BundleCodec(TYPES_2_0, "3.0")  # type: ignore[arg-type]


def test_a_name_the_configuration_does_not_have_is_a_key_error() -> None:
    with pytest.raises(KeyError, match="no bundle is called 'nowhere'"):
        V2.encode("nowhere", {})
    with pytest.raises(KeyError, match="no signal is called 'nowhere'"):
        V2.check("nowhere", 1)


LARGE = """\
nodes:
  - {name: pc, id: 0, endpoints: [{id: 0, type: udp4, ip: 127.0.0.1, port: 11416}]}
  - {name: mcu, id: 1, endpoints: [{id: 0, type: udp4, ip: 127.0.0.1, port: 11417}]}
connections:
  - {first: {node: pc, id: 0}, second: {node: mcu, id: 0}}
signals:
  - {name: text, id: 1, type: string, capacity: 600}
  - {name: blob, id: 2, type: bytes, capacity: 513}
bundles:
  - {name: long, id: 1, producers: [pc], consumers: [mcu], signals: [1, 2]}
"""


def test_capacities_protons_c_core_cannot_decode_are_refused_for_2_0() -> None:
    """Proton 2.0's core decodes every string and bytes value through its 512-byte scratch
    buffer (PROTON_SCRATCH_BUFFER_SIZE): a string of 512 bytes with its NUL, bytes over 512, are
    refused whatever the signal's capacity (tests/proton/test_proton_interop.py shows it)."""
    config = parse_config(LARGE, "large.yaml")
    with pytest.raises(ProtonConfigError) as caught:
        BundleCodec(config)
    assert str(caught.value).startswith(
        "large.yaml:7: signals[0].capacity: capacity 600 (signal 'text'): Proton 2.0's C core "
        "decodes a string value through its 512-byte scratch buffer (PROTON_SCRATCH_BUFFER_SIZE) "
        "and refuses one over 511 bytes with its NUL: give capacity 511 or less, or the scratch "
        "buffer size the board's core is built with"
    )
    with pytest.raises(ProtonConfigError, match=r"large\.yaml:8: signals\[1\]\.capacity: .* 512 b"):
        BundleCodec(parse_config(LARGE.replace("capacity: 600", "capacity: 511"), "large.yaml"))
    bigger = BundleCodec(config, scratch_buffer_size=1024)  # a board built with a larger one
    message = bigger.encode("long", {"text": "x" * 599, "blob": bytes(513)})
    assert bigger.decode(message).signals["text"] == "x" * 599
    assert BundleCodec(config, "1.0").version == "1.0"  # 1.0 decodes into each signal's buffer
    for wrong in (0, 65536, True, 512.0):
        with pytest.raises(ValueError, match=r"scratch_buffer_size must be 1\.\.65535"):
            BundleCodec(config, scratch_buffer_size=wrong)  # type: ignore[arg-type]


def test_protocol_1_0_reserves_bundle_0_for_the_heartbeat() -> None:
    text = LARGE.replace("600", "6").replace("513", "5").replace("id: 1, p", "id: 0, p")
    config = parse_config(text, "zero.yaml")
    assert BundleCodec(config).version == "2.0"  # 2.0 reserves no bundle id
    with pytest.raises(
        ProtonConfigError,
        match=r"zero\.yaml:10: bundles\[0\]\.id: bundle 'long': Proton 1\.0 reserves bundle id 0 "
        "for the heartbeat, exactly one uint32 signal",
    ):
        BundleCodec(config, "1.0")


# -- Proton's own .proto files, read by Google protobuf ----------------------------------------


def _classes(folder: Path, root: str) -> dict[str, type[Message]]:
    files = compile_files(folder, [root])
    pool = descriptor_pool.DescriptorPool()
    for proto in files.file:
        pool.AddSerializedFile(proto.SerializeToString())
    names = ("proton.Proton", "proton.Bundle", "proton.Signal")
    found = {}
    for name in names:
        try:
            found[name] = message_factory.GetMessageClass(pool.FindMessageTypeByName(name))
        except KeyError:
            continue
    return found


@pytest.fixture(scope="module")
def proton_protos() -> dict[str, dict[str, type[Message]]]:
    if not SHARED.is_dir():
        reason = f"Proton's sources are not beside the repository ({SHARED})"
        if os.environ.get("ERC_REQUIRE_INTEROP") == "1":
            pytest.fail(f"ERC_REQUIRE_INTEROP=1 but {reason}")
        pytest.skip(reason)
    return {
        "2.0": _classes(SHARED / "2.0-d269668" / "proto", "proton.proto"),
        "1.0": _classes(SHARED / "1.0-8c898cf" / "proto", "bundle.proto"),
    }


def _google_value(signal: Message, codec: BundleCodec, name: str) -> object:
    member = signal.WhichOneof("signal")
    assert member == f"{codec.config.signal(name).type}_value"
    value = getattr(signal, member)
    if member.startswith("list_"):
        return list(getattr(value, value.DESCRIPTOR.fields[0].name))
    if member == "string_value" and codec.version == "2.0":
        assert value.endswith("\0")  # the terminating NUL travels
        return value[:-1]
    return value


@pytest.mark.parametrize(
    ("codec", "bundle"),
    [(V2, b.name) for b in TYPES_2_0.bundles] + [(V1, b.name) for b in TYPES_1_0.bundles],
)
@given(data=st.data())
@settings(max_examples=40, deadline=None)
def test_protons_own_proto_files_read_the_same_bytes(
    proton_protos: dict[str, dict[str, type[Message]]],
    codec: BundleCodec,
    bundle: str,
    data: st.DataObject,
) -> None:
    config = codec.config
    names = config.bundle(bundle).signals
    sent = {n: codec.check(n, data.draw(values(config.signal(n), codec.version))) for n in names}
    encoded = codec.encode(bundle, sent)
    classes = proton_protos[codec.version]
    top: Any
    parsed: Any  # messages of classes made at run time: their fields are not typed
    if codec.version == "2.0":
        top = classes["proton.Proton"].FromString(encoded)
        parsed = top.bundle
        assert [s.id for s in parsed.signals] == [config.signal(n).id for n in names]
        assert top.SerializeToString() == encoded  # Google's bytes are Proton's, exactly
    else:
        top = parsed = classes["proton.Bundle"].FromString(encoded)
    assert parsed.id == config.bundle(bundle).id
    assert len(parsed.signals) == len(names)
    for name, signal in zip(names, parsed.signals, strict=True):
        assert same(_google_value(signal, codec, name), sent[name])
    # Google's own spelling (1.0: packed lists) decodes to the same values.
    assert all(same(codec.decode(top.SerializeToString()).signals[n], sent[n]) for n in names)
