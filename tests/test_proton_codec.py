"""erc_codec.proton's BundleCodec: Proton's wire format, 2.0 and 1.0, byte for byte.

The expected bytes here are worked out by hand from Proton's .proto files (2.0-d269668/proto and
1.0-8c898cf/proto); tests/test_proton_interop.py checks the same against Proton's C libraries, and
test_protons_own_proto_files_read_the_same_bytes below against Google protobuf with Proton's own
.proto files.
"""

import os
from pathlib import Path
from typing import Any

import pytest
from google.protobuf import descriptor_pool, message_factory
from google.protobuf.message import Message
from hypothesis import given, settings
from hypothesis import strategies as st
from proton_values import TYPES_1_0, TYPES_2_0, same, values

import erc_codec
from erc_codec.proton import Bundle, BundleCodec, ProtonConfigError
from erc_codec.schema import compile_files, encode_varint

V2 = BundleCodec(TYPES_2_0)
V1 = BundleCodec(TYPES_1_0, "1.0")
SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "peers" / "proton"


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


HEARTBEAT = signal2(field(5, 0, b"\x05"), 0x1D)


@pytest.mark.parametrize(
    ("data", "reason", "problem"),
    [
        (b"", "empty", "no bytes"),
        (field(2, 2, b""), "unsupported_operation", "field 2 at offset 0 is an operation"),
        (bundle2(0x999), "unknown_bundle", "bundle id 0x999 is not in"),
        (bundle2(0) + bundle2(0), "corrupt", "a second bundle at offset 2"),
        (bundle2(0), "corrupt", "bundle 'heartbeat' (0x0): lacks 'beat'"),
        (bundle2(0, HEARTBEAT, HEARTBEAT), "corrupt", "signal 'beat' again at offset 9"),
        (
            bundle2(0, signal2(field(3, 0, b"\x05"), 0x1D)),
            "corrupt",
            "signal 'beat' at offset 2 is sent as int32; the configuration says uint32",
        ),
        (
            bundle2(0, signal2(field(5, 0, b"\x05"), 0x1E)),
            "corrupt",
            "signal id 0x1e at offset 2 is not in it",
        ),
        (
            bundle2(0, signal2(field(5, 0, b"\x80\x80\x80\x80\x10"), 0x1D)),
            "corrupt",
            "its value is 4294967296, out of uint32's range",
        ),
        (
            bundle2(0x106, signal2(field(7, 0, b"\x02"), 0x16)),
            "corrupt",
            "its value is 2, out of bool's range 0..1",
        ),
        (
            bundle2(0, signal2(field(5, 0, b"\x05") + field(6, 0, b"\x05"), 0x1D)),
            "corrupt",
            "carries two values (fields 5 and 6)",
        ),
        (bundle2(0, signal2(b"", 0x1D)), "corrupt", "the signal at offset 2 carries no value"),
        (
            bundle2(0, signal2(field(10, 2, b""), 0x1D)),
            "corrupt",
            "field 10 at offset 4 is Proton 1.0's list_double, reserved in 2.0",
        ),
        (
            bundle2(0, signal2(field(5, 2, b"\x05"), 0x1D)),
            "corrupt",
            "its uint32 has wire type LEN, not VARINT",
        ),
        (bundle2(0, signal2(field(20, 0, b"\x01"), 0x1D)), "corrupt", "not a field of Signal"),
        (bundle2(0, HEARTBEAT)[:-1], "corrupt", "not protobuf"),
        (bundle2(0, HEARTBEAT) + b"\x00", "corrupt", "not protobuf: field number 0"),
        (
            bundle2(0x107, signal2(field(8, 2, b""), 0x17)),
            "corrupt",
            "signal 'text_1' at offset 5: lacks its terminating NUL",
        ),
        (bundle2(0x107, signal2(field(8, 2, b"ab"), 0x18)), "corrupt", "lacks its terminating NUL"),
        (
            bundle2(0x107, signal2(field(8, 2, b"a\0b\0"), 0x18)),
            "corrupt",
            "holds bytes after its terminating NUL at offset 10",
        ),
        (
            bundle2(0x107, signal2(field(8, 2, b"abcdefgh\0"), 0x18)),
            "corrupt",
            "is 9 bytes with its NUL, over its capacity of 8",
        ),
        (
            bundle2(0x107, signal2(field(8, 2, b"\xff\0"), 0x18)),
            "corrupt",
            "is not UTF-8 at offset 9",
        ),
        (
            bundle2(0x108, signal2(field(9, 2, b"ab"), 0x1A)),
            "corrupt",
            "is 2 bytes; its capacity takes at most 1",
        ),
    ],
)
def test_what_proton_would_refuse_or_misread_is_a_decode_error(
    data: bytes, reason: str, problem: str
) -> None:
    with pytest.raises(erc_codec.DecodeError) as caught:
        V2.decode(data)
    assert caught.value.reason == reason
    assert problem in str(caught.value), str(caught.value)


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


@pytest.mark.parametrize(
    ("data", "problem"),
    [
        (field(2, 2, field(5, 0, b"\x05")) * 2, "2 signals; Proton 1.0 tells them by position"),
        (field(2, 2, field(8, 2, b"a")) + field(1, 0, b"\x99\x01"), "bundle id 0x99"),
        (
            field(1, 0, b"\x82\x02")
            + field(2, 2, field(17, 2, field(1, 2, b"a")))
            + field(2, 2, field(1, 1, bytes(8)))
            + field(2, 2, field(18, 2, b"")),
            "its list holds 1 items, not its length 3",
        ),
        (
            field(1, 0, b"\x82\x02")
            + field(2, 2, field(17, 2, field(1, 2, b"a\0") * 3))
            + field(2, 2, field(1, 1, bytes(8)))
            + field(2, 2, field(18, 2, b"")),
            "holds a NUL at offset",
        ),
        (
            field(1, 0, b"\x82\x02")
            + field(2, 2, field(17, 2, field(1, 2, b"a") * 3))
            + field(2, 2, field(1, 1, bytes(8)))
            + field(2, 2, field(18, 2, field(1, 2, b"ab") * 2)),
            "is 2 bytes; its capacity takes exactly 4",
        ),
    ],
)
def test_protocol_1_0_refuses_what_protonc_would_misread(data: bytes, problem: str) -> None:
    with pytest.raises(erc_codec.DecodeError) as caught:
        V1.decode(data)
    assert problem in str(caught.value), str(caught.value)


@pytest.mark.parametrize(
    ("codec", "bundle", "values_", "problem"),
    [
        (V2, "nowhere", {}, "no bundle is called 'nowhere'"),
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
    with pytest.raises(ProtonConfigError, match=r"types_1_0\.yaml:29: signal 'doubles': "):
        BundleCodec(TYPES_1_0)
    with pytest.raises(ValueError, match="version must be"):
        BundleCodec(TYPES_2_0, "3.0")  # type: ignore[arg-type]


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
