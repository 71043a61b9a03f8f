"""nanopb's field model everywhere, against nanopb's real C library: overrides and integers.

Two trees, built once per session with tests/interop/any_filter.c:
- tests/any_trees/integers (every varint type, with and without ``int_size``): against Debian's
  nanopb 0.4.7 (generator and ``libprotobuf-nanopb``) and against nanopb 0.4.9.1 (PyPI's
  generator with the unmodified C runtime Proton vendors, ``../shared/peers/proton``);
- tests/any_trees/overrides (``label_override`` and ``type_override``, which 0.4.7's generator
  does not know): against 0.4.9.1.

What is proven: the sizes are the C library's own; whatever varint a sender writes into any
integer field, our strict decode refuses it exactly when nanopb's decoder does, in nanopb's own
words ("integer too large", "varint overflow"), and where both take it they read the same value
(but an int64 held in fewer than 32 bits, of which nanopb reads the low 32 bits as an int32);
``erc_codec.strategies`` draws only messages with overridden fields that the contract passes,
nanopb decodes, and re-encodes to our bytes; and what the contract refuses for an override,
nanopb refuses or changes. Without gcc, nanopb or ``../shared`` the tests skip, unless
ERC_REQUIRE_INTEROP=1 (CI).
"""

import os
import re
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from conftest import TESTS
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_interop import missing_toolchain
from test_interop_any import NANOPB_0491 as VENDORED
from test_interop_any import Peer, build_filter, c_name

import erc_codec
from erc_codec import strategies
from erc_schema import encode_varint

pytestmark = pytest.mark.interop

TREES = TESTS / "any_trees"
INTEGERS, OVERRIDES = TREES / "integers", TREES / "overrides"
PYPI_GENERATOR = [sys.executable, "-m", "nanopb.generator.nanopb_generator"]
INTEGER_CODEC = erc_codec.Codec.from_path(INTEGERS, root="Integers")
OVERRIDE_ROOTS = ["Overrides2", "Overrides3"]
OVERRIDE_CODECS = {root: erc_codec.Codec.from_path(OVERRIDES, root=root) for root in OVERRIDE_ROOTS}


def _unavailable(what: str) -> None:
    reason = f"nanopb interop tests need {what}"
    if os.environ.get("ERC_REQUIRE_INTEROP") == "1":
        pytest.fail(f"ERC_REQUIRE_INTEROP=1 but {reason}")
    pytest.skip(reason)


def _build(
    build: Path,
    generator: list[str],
    tree: Path,
    codecs: list[erc_codec.Codec],
    runtime: Path | None,
) -> Peer:
    """any_filter.c over every .proto of ``tree``, for each message ``codecs`` size."""
    protos = sorted(path.name for path in tree.glob("*.proto"))
    sized = sorted({name for codec in codecs for name, size in codec.sizes().items() if size})
    return build_filter(build, generator, tree, protos, sized, runtime)


@pytest.fixture(scope="module", params=["0.4.7", "0.4.9.1"])
def integers(
    request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory
) -> Iterator[Peer]:
    """nanopb's C library built for tests/any_trees/integers, in each version."""
    build = tmp_path_factory.mktemp(f"nanopb-integers-{request.param}")
    if request.param == "0.4.7":
        missing, generator, _ = missing_toolchain()
        if missing:
            _unavailable(f"{missing}: apt-get install gcc nanopb libnanopb-dev")
        assert generator is not None
        peer = _build(build, [str(generator)], INTEGERS, [INTEGER_CODEC], None)
    else:
        peer = _vendored(build, INTEGERS, [INTEGER_CODEC])
    yield peer
    peer.close()


@pytest.fixture(scope="module")
def overrides(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Peer]:
    """nanopb 0.4.9.1 built for tests/any_trees/overrides."""
    peer = _vendored(
        tmp_path_factory.mktemp("nanopb-overrides"), OVERRIDES, list(OVERRIDE_CODECS.values())
    )
    yield peer
    peer.close()


def _vendored(build: Path, tree: Path, codecs: list[erc_codec.Codec]) -> Peer:
    if not (VENDORED / "pb_decode.c").is_file():
        _unavailable(f"nanopb 0.4.9.1's C sources beside the repository ({VENDORED})")
    if missing_toolchain()[0] == "gcc":
        _unavailable("gcc")
    said = subprocess.run([*PYPI_GENERATOR, "--version"], capture_output=True, text=True)
    assert said.stdout.strip() == "nanopb-0.4.9.1", said
    assert '"nanopb-0.4.9.1"' in (VENDORED / "pb.h").read_text()
    return _build(build, PYPI_GENERATOR, tree, codecs, VENDORED)


def _c_sizes(peer: Peer) -> dict[str, int]:
    ((ok, listed),) = peer.ask("S")
    assert ok
    return {name: int(size) for name, size in re.findall(r"(\w+)=(\d+)", listed)}


def test_integer_sizes_are_the_c_librarys_own(integers: Peer) -> None:
    ours = {c_name(name): size for name, size in INTEGER_CODEC.sizes().items() if size}
    assert ours == _c_sizes(integers) == {"Integers": 160, "Integers_Inner": 12}


def test_override_sizes_are_the_c_librarys_own(overrides: Peer) -> None:
    ours = {
        c_name(name): size
        for codec in OVERRIDE_CODECS.values()
        for name, size in codec.sizes().items()
        if size
    }
    # Overrides3.label: a string held as bytes of max_length + 1 = 32: 1 + 32 + 1
    assert ours == _c_sizes(overrides) == {"Overrides2": 39, "Overrides3": 98, "Reading": 6}


# -- integers: any varint, into any integer field ------------------------------------------------

_DESCRIPTOR: Any = INTEGER_CODEC.message_class("Integers").DESCRIPTOR
VARINT_FIELDS = [field.name for field in _DESCRIPTOR.fields if field.name != "inner"]
PACKED = {"u32s", "s32s_8"}


def _varints() -> st.SearchStrategy[bytes]:
    """Varint bytes: canonical encodings of values around every boundary nanopb checks, and
    padded or overlong ones (trailing 0x80 bytes, ten bytes with a big last one, eleven)."""
    edges = [0, 1, 127, 128, 200, 255, 256, 2**15, 2**16, 2**31, 2**32, 2**63, 2**64]
    values = st.one_of(
        st.sampled_from(edges).flatmap(lambda edge: st.integers(edge - 2, edge + 1)),
        st.integers(-(2**63), 2**64 - 1),
    )
    canonical = values.map(lambda value: encode_varint(value if value < 2**64 else value - 2**64))
    continued = st.lists(st.integers(0x80, 0xFF), min_size=1, max_size=11)
    raw = st.builds(lambda head, last: bytes(head) + bytes([last]), continued, st.integers(0, 0x7F))
    padded = st.builds(
        lambda value, pad: (
            bytes(b | 0x80 for b in encode_varint(value)) + b"\x80" * pad + b"\x00"
        )[: 10 + (pad > 9)],
        st.integers(0, 2**32),
        st.integers(0, 9),
    )
    return st.one_of(canonical, raw, padded.filter(lambda data: data[-1] < 0x80))


def _placed(name: str, varint: bytes, where: str) -> bytes:
    """The Integers bytes carrying ``varint`` in field ``name`` (or Inner's, or packed)."""
    if where == "inner":
        number = {"u32": 1, "s32": 2}[name]
        inner = encode_varint(number << 3) + varint
        return encode_varint(19 << 3 | 2) + encode_varint(len(inner)) + inner
    number = _DESCRIPTOR.fields_by_name[name].number
    if where == "packed":
        return encode_varint(number << 3 | 2) + encode_varint(len(varint)) + varint
    return encode_varint(number << 3) + varint


def _read(data: bytes, strict: bool) -> Any:
    """Our decode of ``data``, or the text of its DecodeError."""
    try:
        return INTEGER_CODEC.decode(data, strict=strict)
    except erc_codec.DecodeError as error:
        return str(error)


def _agree(peer: Peer, data: bytes) -> None:
    """Our strict decode refuses ``data`` exactly when nanopb does, in its words; where both
    take it, both read the same values."""
    theirs = peer.recode("Integers", data)
    ours = _read(data, strict=True)
    if isinstance(ours, str):
        assert isinstance(theirs, str), f"nanopb takes {data.hex()}, we refuse: {ours}"
        # corrupt to protobuf too (eleven bytes and more): refused either way, in its words
        assert f"({theirs})" in ours or isinstance(_read(data, strict=False), str), ours
        return
    assert isinstance(theirs, bytes), f"nanopb refuses {data.hex()} ({theirs}), we take it"
    expected = ours.message
    if expected.i64_16:  # an int64 in fewer than 32 bits: nanopb reads the low 32 as an int32
        low = expected.i64_16 & 0xFFFFFFFF
        expected.i64_16 = low - 2**32 if low >= 2**31 else low
    assert INTEGER_CODEC.decode(theirs, strict=True).message == expected, data.hex()


@given(
    name=st.sampled_from(VARINT_FIELDS),
    varint=_varints(),
    where=st.sampled_from(["field", "packed", "inner"]),
)
@settings(max_examples=600, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_strict_decode_refuses_the_integers_nanopb_refuses(
    integers: Peer, name: str, varint: bytes, where: str
) -> None:
    if where == "packed" and name not in PACKED:
        where = "field"
    if where == "inner":
        name = "s32" if name.startswith("s") else "u32"
    _agree(integers, _placed(name, varint, where))


@pytest.mark.parametrize(
    ("name", "varint", "words"),
    [
        ("u32", encode_varint(2**32), "Integers.u32 = 4294967296 does not fit nanopb's uint32_t"),
        ("u32", encode_varint(-1), "Integers.u32 = 18446744073709551615 does not fit"),
        ("s32", encode_varint(2**32), "Integers.s32 = 2147483648 does not fit nanopb's int32_t"),
        ("colour", encode_varint(-1), "Integers.colour = 18446744073709551615 does not fit"),
        ("tiny", encode_varint(256), "Integers.tiny = 256 does not fit nanopb's uint8_t"),
        ("u32_16", encode_varint(2**32 + 5), "Integers.u32_16 = 4294967301 does not fit"),
        ("i32_8", encode_varint(128), "Integers.i32_8 = 128 does not fit nanopb's int8_t"),
        ("flag", encode_varint(2**32), "Integers.flag = 4294967296 (varint overflow)"),
        ("i64", bytes([0xFF] * 9 + [0x02]), "Integers.i64 = a varint of 10 bytes"),
    ],
    ids=[
        "uint32",
        "negative-uint32",
        "sint32",
        "enum",
        "packed-enum",
        "int-size",
        "int8",
        "bool",
        "ten",
    ],
)
def test_the_refusal_names_the_field_and_nanopbs_words(
    integers: Peer, name: str, varint: bytes, words: str
) -> None:
    """Each of these protobuf's runtime parses (keeping 32 bits of it, or a bool): it was not
    refused before strict decode read the bytes."""
    data = _placed(name, varint, "field")
    INTEGER_CODEC.decode(data)  # protobuf's reading takes it
    answer = integers.recode("Integers", data)
    assert isinstance(answer, str)
    with pytest.raises(erc_codec.DecodeError) as raised:
        INTEGER_CODEC.decode(data, strict=True)
    assert words in str(raised.value)
    assert f"({answer})" in str(raised.value)


def test_a_packed_item_and_a_nested_field_are_named_by_their_path(integers: Peer) -> None:
    data = _placed("u32s", encode_varint(1) + encode_varint(2**32), "packed")
    with pytest.raises(erc_codec.DecodeError, match=r"Integers\.u32s\[1\] = 4294967296"):
        INTEGER_CODEC.decode(data, strict=True)
    assert integers.recode("Integers", data) == "integer too large"
    data = _placed("u32", encode_varint(2**32), "inner")
    with pytest.raises(erc_codec.DecodeError, match=r"Integers\.inner\.u32 = 4294967296"):
        INTEGER_CODEC.decode(data, strict=True)
    assert integers.recode("Integers", data) == "integer too large"


# -- overrides -------------------------------------------------------------------------------------


@pytest.mark.parametrize("root", OVERRIDE_ROOTS)
@given(data=st.data())
@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_drawn_overridden_messages_pass_the_contract_and_nanopb(
    overrides: Peer, root: str, data: st.DataObject
) -> None:
    codec = OVERRIDE_CODECS[root]
    message = data.draw(strategies.messages(codec, root))
    exact = codec.encode(message, "exact")  # the contract passes it
    theirs = overrides.recode(root, exact)
    assert isinstance(theirs, bytes), f"nanopb refuses {exact.hex()}: {theirs}"
    # nanopb writes what it holds single once, its arrays packed: the same values
    assert codec.decode(theirs, strict=True) == (root, message)
    assert codec.decode(exact, strict=True) == (root, message)
    assert codec.decode(codec.encode(message, "strip"), strict=True) == (root, message)


def _three(**values: Any) -> Any:
    base: dict[str, Any] = {"only": [{"value": 1}], "count": 1}
    return OVERRIDE_CODECS["Overrides3"].message_class("Overrides3")(**{**base, **values})


def _two(**values: Any) -> Any:
    base: dict[str, Any] = {"must": 1, "words": ["w"]}
    return OVERRIDE_CODECS["Overrides2"].message_class("Overrides2")(**{**base, **values})


@pytest.mark.parametrize(
    ("message", "ours", "theirs"),
    [
        (
            _three(count=0),
            r"Overrides3\.count is required .* holds its default",
            "missing required",
        ),
        (
            _three(only=[]),
            r"Overrides3\.only holds 0 items; label_override REQUIRED",
            "missing required",
        ),
        (
            _three(label="x" * 33),
            r"Overrides3\.label is 33 bytes long, more than the 32",
            "overflow",
        ),
        (
            _three(name=b"12345678"),
            r"Overrides3\.name is 8 bytes long, more than the 7",
            "overflow",
        ),
        (
            _three(wide=2**32),
            r"Overrides3\.wide = 4294967296 does not fit nanopb's type_override",
            "integer too large",
        ),
        (
            _two(must=None),
            r"Overrides2\.must is required \(nanopb label_override\)",
            "missing required",
        ),
        (
            _two(words=[]),
            r"Overrides2\.words holds 0 items; label_override REQUIRED",
            "missing required",
        ),
        (_two(words=["a", "b"]), None, None),
        (_two(last=[1, 2]), None, None),
    ],
    ids=[
        "proto3-required",
        "repeated-required",
        "string-as-bytes",
        "bytes-as-string",
        "narrowed",
        "proto2-required",
        "words-required",
        "words-twice",
        "last-twice",
    ],
)
def test_what_the_contract_refuses_nanopb_refuses_or_changes(
    overrides: Peer, message: Any, ours: str | None, theirs: str | None
) -> None:
    root = message.DESCRIPTOR.full_name
    codec = OVERRIDE_CODECS[root]
    with pytest.raises(erc_codec.EncodeError) as raised:
        codec.encode(message, "exact")
    data = message.SerializePartialToString()  # sent by something that does not check
    answer = overrides.recode(root, data)
    if theirs is None:  # two items where nanopb holds one: it keeps the last, the first is lost
        assert re.search(r"holds 2 items, more than the one nanopb holds", str(raised.value))
        assert isinstance(answer, bytes)
        assert codec.decode(answer).message != message
        return
    assert ours is not None
    assert re.search(ours, str(raised.value)), str(raised.value)
    assert isinstance(answer, str), answer
    assert theirs in answer
    with pytest.raises(erc_codec.DecodeError, match="nanopb's decoder refuses"):
        codec.decode(data, strict=True)


def test_what_the_raw_descriptor_refused_nanopb_takes(overrides: Peer) -> None:
    """A string held as bytes may hold 32 bytes and NULs (max_length 31 counted a NUL the bytes
    do not need); a proto2 required field made optional may be left out."""
    codec = OVERRIDE_CODECS["Overrides3"]
    message = _three(label="abc\0" * 8)
    data = codec.encode(message, "exact")
    assert overrides.recode("Overrides3", data) == data
    assert codec.decode(data, strict=True).message == message
    loose = _two()
    data = OVERRIDE_CODECS["Overrides2"].encode(loose, "exact")
    assert isinstance(overrides.recode("Overrides2", data), bytes)
    assert OVERRIDE_CODECS["Overrides2"].decode(data, strict=True).message == loose


def test_strict_decode_counts_what_protobuf_merges(overrides: Peer) -> None:
    """Overrides3.history is single for protobuf, an array of 2 for nanopb: three arrive."""
    codec = OVERRIDE_CODECS["Overrides3"]
    base = _three().SerializeToString()
    data = base + b"\x1a\x02\x08\x05" * 3
    codec.decode(data)  # protobuf merges them
    assert overrides.recode("Overrides3", data) == "array overflow"
    with pytest.raises(erc_codec.DecodeError, match=r"Overrides3\.history arrived 3 times"):
        codec.decode(data, strict=True)
    two = base + b"\x1a\x02\x08\x05" * 2
    assert isinstance(overrides.recode("Overrides3", two), bytes)
    codec.decode(two, strict=True)


def test_strict_decode_sees_a_required_zero_a_sender_wrote(overrides: Peer) -> None:
    """A proto3 field nanopb requires, written as an explicit 0 (nanopb's own encoder does):
    protobuf's parse cannot tell it from absent, the bytes can."""
    codec = OVERRIDE_CODECS["Overrides3"]
    written = _three().SerializeToString().replace(b"\x20\x01", b"\x20\x00")
    assert isinstance(overrides.recode("Overrides3", written), bytes)
    codec.decode(written, strict=True)
    absent = written.replace(b"\x20\x00", b"")
    assert "missing required" in str(overrides.recode("Overrides3", absent))
    with pytest.raises(erc_codec.DecodeError, match=r"Overrides3\.count is required but missing"):
        codec.decode(absent, strict=True)
