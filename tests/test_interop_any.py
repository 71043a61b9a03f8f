"""Any nanopb schema against nanopb's real generator and C library: sizes, encode rules, decode.

The session generates C for tests/any_trees/rules (a proto2 and a proto3 file using nanopb's
size-relevant options: required fields and defaults, fixed_length, fixed_count, int_size,
max_length, an ignored field and an ignored callback, oneofs, repeated submessages and bytes) with
Debian's generator matching the installed headers, builds tests/interop/any_filter.c against
nanopb's C library, and asks it to decode and re-encode hypothesis-drawn messages of every root.
Without gcc or nanopb the tests skip, unless ERC_REQUIRE_INTEROP=1 (CI).

What is proven, per message type: ``<Msg>_size`` as the C library compiles it equals ours; nanopb
decodes each of our encodings (exact plainly, padded and restored-stripped NULLTERMINATED) and
re-encodes it to our exact bytes (but where nanopb packs a proto2 array protobuf leaves
unpacked), which we decode back, in every form, to the message we drew; and what our contract
refuses to encode, nanopb's decoder refuses too, as does our strict decode.
"""

import importlib.util
import os
import re
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from google.protobuf.message import Message
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_interop import missing_toolchain

import erc_codec
from erc_codec import strategies

pytestmark = pytest.mark.interop

TREE = Path(__file__).parent / "any_trees" / "rules"
FILTER_SOURCE = Path(__file__).parent / "interop" / "any_filter.c"
ROOTS = ["Rules", "Probe"]
PROTO2_UNPACKED = {"triple"}  # Rules' repeated scalar field: proto2, so not packed by protobuf
CODECS = {root: erc_codec.Codec.from_path(TREE, root=root) for root in ROOTS}


class Peer:
    """The running any_filter.c."""

    def __init__(self, program: Path) -> None:
        self._process = subprocess.Popen(
            [str(program)], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, bufsize=1
        )

    def ask(self, *requests: str) -> list[tuple[bool, str]]:
        assert self._process.stdin is not None
        assert self._process.stdout is not None
        self._process.stdin.write("".join(f"{request}\n" for request in requests))
        self._process.stdin.flush()
        answers = []
        for _ in requests:
            status, _, rest = self._process.stdout.readline().rstrip("\n").partition(" ")
            answers.append((status == "OK", rest))
        return answers

    def recode(self, name: str, data: bytes, nullterminated: bool = False) -> bytes | str:
        """nanopb's re-encoding of ``data`` read as ``name``, or its error text."""
        ((ok, rest),) = self.ask(f"{'N' if nullterminated else 'D'} {name} {data.hex() or '-'}")
        if not ok:
            return rest
        return b"" if rest == "-" else bytes.fromhex(rest)

    def close(self) -> None:
        assert self._process.stdin is not None
        assert self._process.stdout is not None
        self._process.stdin.close()
        assert self._process.wait(timeout=10) == 0
        self._process.stdout.close()


def c_name(full_name: str) -> str:
    return full_name.replace(".", "_")


@pytest.fixture(scope="module")
def nanopb(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Peer]:
    missing, generator, _ = missing_toolchain()
    if missing:
        reason = f"nanopb interop tests need {missing}: apt-get install gcc nanopb libnanopb-dev"
        if os.environ.get("ERC_REQUIRE_INTEROP") == "1":
            pytest.fail(f"ERC_REQUIRE_INTEROP=1 but {reason}")
        pytest.skip(reason)
    assert generator is not None
    build = tmp_path_factory.mktemp("nanopb-any")
    protos = sorted(path.name for path in TREE.glob("*.proto"))
    subprocess.run(
        [str(generator), "-q", "-I", ".", "-D", str(build), *protos], cwd=TREE, check=True
    )
    sized = sorted(
        name for codec in CODECS.values() for name, size in codec.sizes().items() if size
    )
    (build / "messages.h").write_text(
        "".join(f'#include "{Path(proto).with_suffix(".pb.h")}"\n' for proto in protos)
        + "#define MESSAGES "
        + " ".join(f"X({c_name(name)})" for name in sorted(set(sized)))
        + "\n"
    )
    program = build / "any_filter"
    subprocess.run(
        [
            *("gcc", "-std=c11", "-Wall", "-Wextra", "-Werror", "-O1", "-I", str(build)),
            *("-o", str(program), str(FILTER_SOURCE), *map(str, build.glob("*.pb.c"))),
            "-lprotobuf-nanopb",
        ],
        check=True,
    )
    peer = Peer(program)
    yield peer
    peer.close()


def test_every_size_is_the_c_librarys_own(nanopb: Peer) -> None:
    ((ok, listed),) = nanopb.ask("S")
    assert ok
    theirs = {name: int(size) for name, size in re.findall(r"(\w+)=(\d+)", listed)}
    ours = {
        c_name(name): size
        for codec in CODECS.values()
        for name, size in codec.sizes().items()
        if size is not None
    }
    assert ours == theirs
    assert theirs == {"Part": 12, "Rules": 140, "Probe": 78, "Probe_Inner": 5}


@pytest.mark.parametrize("root", ROOTS)
@given(data=st.data())
@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_every_form_round_trips_through_nanopb(
    nanopb: Peer, root: str, data: st.DataObject
) -> None:
    codec = CODECS[root]
    message = data.draw(strategies.messages(codec, root))
    exact, stripped = codec.encode(message, "exact"), codec.encode(message, "strip")
    padded = codec.encode(message, "pad")
    restored = stripped + bytes(codec.max_size(root) - len(stripped))
    # nanopb reads our exact bytes (plainly), padded and restored ones (NULLTERMINATED) alike
    theirs = nanopb.recode(root, exact)
    assert isinstance(theirs, bytes), theirs
    assert nanopb.recode(root, padded, nullterminated=True) == theirs
    assert nanopb.recode(root, restored, nullterminated=True) == theirs
    # its encoding of what it read is ours, byte for byte, but for one rule of its own: nanopb
    # packs every packable array, proto2's unpacked ones too (Rules.triple); values are equal
    if PROTO2_UNPACKED.isdisjoint(field.name for field, _ in message.ListFields()):
        assert theirs == exact
    padded_theirs = theirs + bytes(codec.max_size(root) - len(theirs))
    for form in (theirs, theirs.rstrip(b"\0"), padded_theirs, exact, stripped, padded):
        assert codec.decode(form, strict=True) == (root, message)


def _refused(codec: erc_codec.Codec, message: Message) -> str:
    with pytest.raises(erc_codec.EncodeError) as raised:
        codec.encode(message, "exact")
    return str(raised.value)


@pytest.mark.parametrize(
    ("root", "values", "ours", "theirs"),
    [
        (
            "Rules",
            {"key": b"abcd", "triple": [1, 2, 3]},
            r"Rules\.id is required",
            "missing required",
        ),
        (
            "Rules",
            {"id": 1, "key": b"abc", "triple": [1, 2, 3]},
            r"Rules\.key .*fixed_length",
            "fixed length",
        ),
        (
            "Rules",
            {"id": 1, "key": b"abcd", "triple": [1, 2]},
            r"Rules\.triple .*fixed_count",
            "fixed count",
        ),
        (
            "Rules",
            {"id": 1, "key": b"abcd", "triple": [1, 2, 3], "parts": [{"serial": 1}, {}]},
            r"Rules\.parts\[1\]\.serial is required",
            "missing required",
        ),
        (
            "Rules",
            {"id": 1, "key": b"abcd", "triple": [1, 2, 3], "name": "12345678"},
            r"Rules\.name is 8 bytes",
            "overflow",
        ),
        (
            "Rules",
            {"id": 70000, "key": b"abcd", "triple": [1, 2, 3]},
            r"Rules\.id = 70000 does not fit",
            "integer too large",
        ),
        ("Probe", {"key": b"ab"}, r"Probe\.key .*fixed_length", "fixed length"),
        ("Probe", {"key": b"abcd", "quad": [1, 2, 3]}, r"Probe\.quad .*fixed_count", "fixed count"),
    ],
    ids=[
        "required",
        "fixed-length",
        "fixed-count",
        "nested-required",
        "max-length",
        "int-size",
        "proto3-fixed-length",
        "proto3-fixed-count",
    ],
)
def test_what_we_refuse_to_send_nanopb_refuses_to_read(
    nanopb: Peer, root: str, values: dict[str, object], ours: str, theirs: str
) -> None:
    codec = CODECS[root]
    message = codec.message_class(root)(**values)
    assert re.search(ours, _refused(codec, message))
    data = message.SerializePartialToString()  # sent by something that does not check
    answer = nanopb.recode(root, data)
    assert isinstance(answer, str), answer
    assert theirs in answer
    with pytest.raises(erc_codec.DecodeError, match="nanopb's decoder refuses"):
        codec.decode(data, strict=True)
    codec.decode(data)  # not strict: protobuf's reading


def test_a_string_with_a_nul_arrives_cut_at_it(nanopb: Peer) -> None:
    """Why the contract refuses a NUL in a string: nanopb keeps what comes before it."""
    codec = CODECS["Probe"]
    message = codec.message_class("Probe")(key=b"abcd", quad=[1, 2, 3, 4], name="ab\0cd")
    assert re.search(r"Probe\.name holds a NUL at character 2", _refused(codec, message))
    cut = nanopb.recode("Probe", message.SerializeToString())
    assert isinstance(cut, bytes)
    decoded: Any = codec.decode(cut).message
    assert decoded.name == "ab"


@pytest.mark.parametrize(
    ("values", "field"),
    [
        ({"quad": [1, 2, 3, 4]}, "key"),
        ({"key": b"abcd", "quad": [1, 2, 3, 4], "blob": b""}, "blob"),
    ],
    ids=["implicit-presence", "set-but-empty"],
)
def test_empty_fixed_length_bytes_arrive_as_zeros(
    nanopb: Peer, values: dict[str, object], field: str
) -> None:
    """Why the contract refuses b"" for fixed_length bytes: nanopb reads it (or its absence) as
    max_size zeros, and sends those on, so the value would change on the way."""
    codec = CODECS["Probe"]
    message = codec.message_class("Probe")(**values)
    assert re.search(rf"Probe\.{field} is 0 bytes long; fixed_length", _refused(codec, message))
    theirs = nanopb.recode("Probe", message.SerializeToString())
    assert isinstance(theirs, bytes), theirs
    limit = 4 if field == "key" else 2
    assert getattr(codec.decode(theirs, strict=True).message, field) == bytes(limit)
    codec.decode(message.SerializeToString(), strict=True)  # nanopb's decoder takes it, too


# -- against nanopb 0.4.9.1's generator and C library ------------------------------------------
# Debian's 0.4.7 generator runs the system's protoc, which has no editions: these schemas are
# generated by PyPI's nanopb 0.4.9.1 (the test extra) and built with the C library of the same
# version, as Proton 2.0 vendors it beside the repository (see tests/test_proton_interop.py).

NANOPB_0491 = (
    Path(__file__).resolve().parents[1].parent
    / "shared"
    / "peers"
    / "proton"
    / "2.0-d269668"
    / "external"
    / "nanopb"
)
ANY_TREES = Path(__file__).parent / "any_trees"


def build_0491(tree: Path, files: list[str], messages: list[str], build: Path) -> Peer:
    """any_filter.c for ``messages`` of ``files`` under ``tree``, generated and built with nanopb
    0.4.9.1."""
    missing = ""
    if not (NANOPB_0491 / "pb_encode.c").is_file():
        missing = f"nanopb 0.4.9.1's C sources ({NANOPB_0491})"
    elif shutil.which("gcc") is None:
        missing = "gcc"
    elif importlib.util.find_spec("nanopb") is None:
        missing = "PyPI nanopb (the test extra)"
    if missing:
        if os.environ.get("ERC_REQUIRE_INTEROP") == "1":
            pytest.fail(f"ERC_REQUIRE_INTEROP=1 but the interop tests need {missing}")
        pytest.skip(f"these interop tests need {missing}")
    subprocess.run(
        [
            *(sys.executable, "-m", "nanopb.generator.nanopb_generator", "-q", "-I", "."),
            *("--error-on-unmatched", "-D", str(build), *files),
        ],
        cwd=tree,
        check=True,
    )
    (build / "messages.h").write_text(
        "".join(f'#include "{Path(file).with_suffix(".pb.h")}"\n' for file in files)
        + f"#define MESSAGES {' '.join(f'X({c_name(name)})' for name in messages)}\n"
    )
    program = build / "any_filter"
    subprocess.run(
        [
            *("gcc", "-std=c11", "-O1", "-I", str(build), "-I", str(NANOPB_0491)),
            *("-o", str(program), str(FILTER_SOURCE), *map(str, build.glob("*.pb.c"))),
            *map(str, sorted(NANOPB_0491.glob("pb_*.c"))),
        ],
        check=True,
    )
    return Peer(program)


@pytest.fixture(scope="module")
def delimited(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Peer]:
    tree = ANY_TREES / "delimited"
    build = tmp_path_factory.mktemp("nanopb-delimited")
    peer = build_0491(tree, ["fields.proto", "whole.proto"], ["Holder", "Track"], build)
    yield peer
    peer.close()


@pytest.mark.parametrize(
    ("root", "field", "line"),
    [("Holder", "delimited", 10), ("Track", "last", 11)],
    ids=["field-feature", "file-feature"],
)
def test_a_delimited_field_is_refused_at_load(
    delimited: Peer, root: str, field: str, line: int
) -> None:
    """nanopb writes an editions DELIMITED field as a length-prefixed message and refuses
    protobuf's group; protobuf keeps nanopb's bytes as an unknown field: no bytes are right for
    both, so the codec refuses the schema, saying where and why, and sizes stay nanopb's."""
    tree = ANY_TREES / "delimited"
    schema = erc_codec.schema.load_schema(tree, root)
    cls = schema.message_class(root)
    message: Any = cls()
    getattr(message, field).x = 1
    ours = message.SerializeToString()
    assert ours[0] & 7 == 3  # protobuf: a group's start tag
    assert delimited.recode(root, ours) == "wrong wire type"
    theirs = delimited.recode(root, bytes([(1 << 3) | 2, 2, 0x08, 0x01]))
    assert theirs == bytes([(1 << 3) | 2, 2, 0x08, 0x01])  # nanopb: a length-prefixed message
    assert not cls.FromString(theirs).HasField(field)  # protobuf: an unknown field
    ((ok, listed),) = delimited.ask("S")
    assert ok
    assert listed == "Holder=26 Track=13"
    assert erc_codec.schema.Sizes(schema).max_size(root) == (26 if root == "Holder" else 13)
    file = "fields.proto" if root == "Holder" else "whole.proto"
    with pytest.raises(
        erc_codec.SchemaError,
        match=rf"{file}:{line}:\d+: {root}\.{field}: protobuf writes it delimited .*\(wire type 2",
    ):
        erc_codec.Codec.from_path(tree, root)


@pytest.fixture(scope="module")
def mapkeys(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Peer]:
    build = tmp_path_factory.mktemp("nanopb-mapkeys")
    messages = ["Labels", "Labels.ByNameEntry"]
    peer = build_0491(ANY_TREES / "mapkeys", ["mapkeys.proto"], messages, build)
    yield peer
    peer.close()


MAPKEYS = erc_codec.Codec.from_path(ANY_TREES / "mapkeys", root="Labels")


@pytest.mark.parametrize(
    ("values", "ours", "theirs"),
    [
        (
            {"by_name": {"abcde": 1}},
            r"^Labels\.by_name key 'abcde' is 5 bytes long, more than the 4 allowed$",
            "string overflow",  # max_length:4
        ),
        (
            {"flags": {"abc": True}},
            r"^Labels\.flags key 'abc' is 3 bytes long, more than the 2 allowed$",
            "string overflow",  # max_size:3, its NUL included
        ),
        (
            {"by_name": {"a\0b": 1}},
            r"^Labels\.by_name key 'a\\x00b' holds a NUL at character 1: nanopb stores",
            "0a050a01611001",  # the key arrives cut at the NUL: "a"
        ),
    ],
    ids=["max-length", "max-size", "nul"],
)
def test_a_map_key_nanopb_refuses_or_cuts_is_not_sent(
    mapkeys: Peer, values: dict[str, object], ours: str, theirs: str
) -> None:
    message = MAPKEYS.message_class("Labels")(**values)
    assert re.search(ours, _refused(MAPKEYS, message))
    data = message.SerializeToString()
    answer = mapkeys.recode("Labels", data)
    assert (answer if isinstance(answer, str) else answer.hex()) == theirs
    assert MAPKEYS.decode(data).message == message  # protobuf's reading takes it
    if answer == "string overflow":  # what nanopb's decoder refuses, a strict decode refuses
        with pytest.raises(erc_codec.DecodeError, match=r"nanopb's decoder refuses the Labels"):
            MAPKEYS.decode(data, strict=True)


@given(data=st.data())
@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_map_keys_at_their_limits_round_trip_through_nanopb(
    mapkeys: Peer, data: st.DataObject
) -> None:
    """What the contract lets through nanopb reads back the same. (Not byte for byte: protobuf
    writes a map entry's key and value even at their defaults, nanopb leaves them out.)"""
    message = data.draw(strategies.messages(MAPKEYS, "Labels"))
    theirs = mapkeys.recode("Labels", MAPKEYS.encode(message, "exact"))
    assert isinstance(theirs, bytes), theirs
    assert MAPKEYS.decode(theirs, strict=True) == ("Labels", message)
    longest: Any = MAPKEYS.message_class("Labels")(by_name={"abcd": 2**32 - 1, "wxyz": 2**32 - 1})
    longest.flags["ab"] = True
    exact = MAPKEYS.encode(longest, "exact")
    assert mapkeys.recode("Labels", exact) == exact
    # the longest keys and values: nanopb's 37 less the byte it adds for max_count:1 (flags)
    assert (len(exact), MAPKEYS.max_size("Labels")) == (36, 37)


def test_a_map_entry_is_a_root_as_nanopb_generates_it(mapkeys: Peer) -> None:
    """nanopb generates a map's entry type (Labels_ByNameEntry, its _msg and _size) like any
    nested message: it loads as a plain root, with its key's and value's limits."""
    codec = erc_codec.Codec.from_path(ANY_TREES / "mapkeys", root="Labels.ByNameEntry")
    assert isinstance(codec, erc_codec.MessageCodec)
    ((ok, listed),) = mapkeys.ask("S")
    assert ok
    assert listed == f"Labels=37 Labels_ByNameEntry={codec.max_size(codec.root)}"
    entry = codec.message_class("Labels.ByNameEntry")(key="abcd", value=2**32 - 1)
    exact = codec.encode(entry, "exact")
    assert len(exact) == codec.max_size(codec.root) == 12
    assert mapkeys.recode("Labels_ByNameEntry", exact) == exact
    assert codec.decode(codec.encode(entry)) == ("Labels.ByNameEntry", entry)
    too_long = codec.message_class("Labels.ByNameEntry")(key="abcde")
    assert re.search(r"^Labels\.ByNameEntry\.key is 5 bytes long", _refused(codec, too_long))
    assert mapkeys.recode("Labels_ByNameEntry", too_long.SerializeToString()) == "string overflow"
