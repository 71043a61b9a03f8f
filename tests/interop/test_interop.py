"""Byte-for-byte interoperability with nanopb's C library, as the boards run it.

The session builds tests/interop/filter.c against nanopb's real C library (Debian packages
``nanopb`` and ``libnanopb-dev``, the generator picked to match the headers' version) from the
project's proto/, once, starts it once, and feeds it hundreds of hypothesis-drawn messages of every
payload type over a pipe. Without gcc or nanopb the tests skip, unless ERC_REQUIRE_INTEROP=1 (CI).

Besides the round trips, each batch checks the compatibility matrix the README documents: which
transmission form each kind of receiver accepts.
"""

import os
import re
import shutil
import struct
import subprocess
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
from conftest import PROTO, TESTS
from google.protobuf.descriptor import Descriptor, FieldDescriptor
from google.protobuf.message import DecodeError as ProtobufDecodeError
from google.protobuf.message import Message
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import erc_codec
from erc_codec import strategies
from erc_schema import descriptor_of, enum_of, message_of

pytestmark = pytest.mark.interop

CODEC = erc_codec.Codec.default()
ENVELOPE = CODEC.message_class("PBEnvelope")
MAX = CODEC.max_size("PBEnvelope")
KINDS = sorted(CODEC.kinds().values())
FILTER_SOURCE = TESTS / "interop" / "filter.c"
_T = FieldDescriptor


@dataclass(frozen=True)
class Answer:
    ok: bool
    data: bytes  # the C library's (re-)encoding
    fields: list[str]  # what it decoded, as filter.c prints it
    error: str


class Peer:
    """The running filter.c, and the sizes nanopb's generator wrote for proto/."""

    def __init__(self, program: Path, sizes: dict[str, int]) -> None:
        self.sizes = sizes
        self._process = subprocess.Popen(
            [str(program)], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, bufsize=1
        )

    def ask(self, requests: list[str]) -> list[Answer]:
        assert self._process.stdin is not None
        assert self._process.stdout is not None
        self._process.stdin.write("".join(f"{request}\n" for request in requests))
        self._process.stdin.flush()
        return [_answer(self._process.stdout.readline().rstrip("\n")) for _ in requests]

    def close(self) -> None:
        assert self._process.stdin is not None
        assert self._process.stdout is not None
        self._process.stdin.close()
        assert self._process.wait(timeout=10) == 0
        self._process.stdout.close()


def _answer(line: str) -> Answer:
    if line.startswith("ERR "):
        return Answer(False, b"", [], line[4:])
    _, data, *fields = line.split(" ")
    return Answer(True, b"" if data == "-" else bytes.fromhex(data), fields, "")


def missing_toolchain() -> tuple[str, Path | None, Path | None]:
    """(what is missing, the matching generator, pb.h)."""
    if shutil.which("gcc") is None:
        return "gcc", None, None
    probe = subprocess.run(
        ["gcc", "-M", "-x", "c", "-"], input="#include <pb.h>\n", capture_output=True, text=True
    )
    header = re.search(r"(\S*/pb\.h)", probe.stdout)
    if probe.returncode != 0 or header is None:
        return "nanopb's C headers (libnanopb-dev)", None, None
    version = re.search(r'#define NANOPB_VERSION "(.*?)"', Path(header[1]).read_text())
    for folder in os.environ.get("PATH", "").split(os.pathsep):
        for name in ("nanopb_generator.py", "nanopb_generator"):
            candidate = Path(folder) / name
            if not os.access(candidate, os.X_OK):
                continue
            said = subprocess.run([str(candidate), "--version"], capture_output=True, text=True)
            if version and said.stdout.strip() == version[1]:
                return "", candidate, Path(header[1])
    wanted = version[1] if version else "the headers' version"
    return f"nanopb's generator matching {wanted} (Debian package nanopb)", None, None


@pytest.fixture(scope="session")
def nanopb(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Peer]:
    missing, generator, _ = missing_toolchain()
    if missing:
        reason = f"nanopb interop tests need {missing}: apt-get install gcc nanopb libnanopb-dev"
        if os.environ.get("ERC_REQUIRE_INTEROP") == "1":
            pytest.fail(f"ERC_REQUIRE_INTEROP=1 but {reason}")
        pytest.skip(reason)
    assert generator is not None
    build = tmp_path_factory.mktemp("nanopb")
    protos = sorted(path.relative_to(PROTO).as_posix() for path in PROTO.rglob("*.proto"))
    subprocess.run(
        [str(generator), "-q", "-I", ".", "-D", str(build), *protos], cwd=PROTO, check=True
    )
    sources = sorted(str(path) for path in build.rglob("*.pb.c"))
    program = build / "filter"
    subprocess.run(
        [
            *("gcc", "-std=c11", "-Wall", "-Wextra", "-Werror", "-O1", "-I", str(build)),
            *("-o", str(program), str(FILTER_SOURCE), *sources, "-lprotobuf-nanopb"),
        ],
        check=True,
    )
    sizes = {}
    for header in build.rglob("*.pb.h"):
        for name, size in re.findall(r"#define (\w+)_size\s+(\d+)$", header.read_text(), re.M):
            sizes[name] = int(size)
    peer = Peer(program, sizes)
    yield peer
    peer.close()


def describe(message: Message, prefix: str = "") -> list[str]:
    """A message's set fields in filter.c's notation (floats and fixed fields as raw bits)."""
    items = []
    for field, value in message.ListFields():
        path = f"{prefix}{field.number}"
        if field.type == _T.TYPE_MESSAGE:
            items += [path, *describe(value, f"{path}.")]
        else:
            items.append(f"{path}={_raw(field, value)}")
    return items


def _raw(field: FieldDescriptor, value: Any) -> int:
    if field.type == _T.TYPE_FLOAT:
        return int(struct.unpack("<I", struct.pack("<f", value))[0])
    if field.type == _T.TYPE_DOUBLE:
        return int(struct.unpack("<Q", struct.pack("<d", value))[0])
    if field.type == _T.TYPE_SFIXED32:
        return int(value) & 0xFFFFFFFF
    if field.type == _T.TYPE_SFIXED64:
        return int(value) & 0xFFFFFFFFFFFFFFFF
    return int(value)


def wrapped(kind: str, payload: Message) -> Message:
    envelope = ENVELOPE()
    getattr(envelope, kind).CopyFrom(payload)
    return envelope


def google_accepts(data: bytes) -> bool:
    try:
        ENVELOPE.FromString(data)
    except ProtobufDecodeError:
        return False
    return True


def payload_type(kind: str) -> str:
    return message_of(descriptor_of(ENVELOPE).fields_by_name[kind]).full_name


@pytest.mark.parametrize("kind", KINDS)
@given(data=st.data())
@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_every_form_against_nanopb(nanopb: Peer, kind: str, data: st.DataObject) -> None:
    message = data.draw(strategies.messages(CODEC, payload_type(kind)))
    fields = describe(wrapped(kind, message))
    exact = CODEC.encode(message, "exact")
    stripped, padded = CODEC.encode(message, "strip"), CODEC.encode(message, "pad")
    restored = stripped + bytes(MAX - len(stripped))  # what the fleet's receivers do first
    built, plain, nullterminated, null_restored, plain_pad, plain_strip, null_strip = nanopb.ask(
        [
            "E " + " ".join(fields),
            f"D {exact.hex()}",
            f"N {padded.hex()}",
            f"N {restored.hex()}",
            f"D {padded.hex()}",
            f"D {stripped.hex() or '-'}",
            f"N {stripped.hex() or '-'}",
        ]
    )
    # 1. Python's exact encoding is nanopb's, byte for byte.
    assert built.ok, built.error
    assert built.data == exact
    # 2. nanopb decodes exact bytes (plain) and padded bytes (NULLTERMINATED) to our values.
    for answer in (plain, nullterminated, null_restored):
        assert answer.ok, answer.error
        assert answer.fields == fields
        assert answer.data == exact
    # 3. Our decoder reads nanopb's bytes in every form.
    for form in (built.data, built.data.rstrip(b"\0"), built.data + bytes(MAX - len(exact))):
        decoded = CODEC.decode(form)
        assert decoded.kind == kind
        assert decoded.message.SerializeToString() == message.SerializeToString()
    # The matrix: plain pb_decode and Google protobuf take exact bytes only; NULLTERMINATED stops
    # at a zero tag, but a stripped datagram must be padded back before it too can read it.
    assert plain_pad.ok == (len(exact) == MAX) == google_accepts(padded)
    assert plain_strip.ok == (stripped == exact) == google_accepts(stripped)
    assert null_strip.ok == (stripped == exact)


def test_every_size_equals_the_generated_header(nanopb: Peer) -> None:
    ours = {name.replace(".", "_"): size for name, size in CODEC.sizes().items()}
    assert ours == nanopb.sizes
    assert nanopb.sizes["PBEnvelope"] == MAX == 262  # the widest payload, 255, + timeout: 7


def widest(descriptor: Descriptor) -> Message:
    """A message with every field at the value that encodes widest."""
    message = CODEC.message_class(descriptor.full_name)()
    for field in descriptor.fields:
        if field.type == _T.TYPE_MESSAGE:
            getattr(message, field.name).CopyFrom(widest(message_of(field)))
        elif field.type == _T.TYPE_ENUM:
            numbers = [value.number for value in enum_of(field).values]
            setattr(message, field.name, min(numbers) if min(numbers) < 0 else max(numbers))
        else:
            setattr(message, field.name, _WIDEST[field.type])
    return message


_WIDEST: dict[int, object] = {
    _T.TYPE_BOOL: True,
    _T.TYPE_INT32: -1,  # sign-extended to ten bytes
    _T.TYPE_INT64: -1,
    _T.TYPE_UINT32: 2**32 - 1,
    _T.TYPE_UINT64: 2**64 - 1,
    _T.TYPE_SINT32: -(2**31),
    _T.TYPE_SINT64: -(2**63),
    _T.TYPE_FIXED32: 1,
    _T.TYPE_SFIXED32: -1,
    _T.TYPE_FIXED64: 1,
    _T.TYPE_SFIXED64: -1,
    _T.TYPE_FLOAT: 1.5,
    _T.TYPE_DOUBLE: 1.5,
}


@pytest.mark.parametrize("kind", KINDS)
def test_the_widest_message_fills_its_size_in_both(nanopb: Peer, kind: str) -> None:
    payload = widest(descriptor_of(CODEC.message_class(payload_type(kind))))
    exact = CODEC.encode(payload, "exact")
    header = len(exact) - payload.ByteSize()
    assert payload.ByteSize() == CODEC.max_size(payload_type(kind))
    assert payload.ByteSize() == nanopb.sizes[payload_type(kind)]
    (built,) = nanopb.ask(["E " + " ".join(describe(wrapped(kind, payload)))])
    assert built.ok, built.error
    assert built.data == exact
    if len(exact) == MAX:  # the widest payload of all fills the envelope exactly
        assert header + nanopb.sizes[payload_type(kind)] == nanopb.sizes["PBEnvelope"]


def test_a_missing_toolchain_is_named(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv("PATH", str(tmp_path))  # no gcc, no generator
    assert missing_toolchain() == ("gcc", None, None)


@pytest.mark.parametrize("timeout", [1, 300, 2**32 - 1])
def test_the_timeout_metadata_matches_nanopb(nanopb: Peer, timeout: int) -> None:
    """An envelope whose last field is ``timeout``, not the payload: nanopb builds the same bytes,
    and plain ``pb_decode`` reads every form the codec sends it, since nothing is stripped."""
    stop = CODEC.message_class("drive_motor")()  # all zero: exact payload "4a 00"
    exact = CODEC.encode(stop, "exact", timeout=timeout)
    built, plain, from_stripped = nanopb.ask(
        [
            f"E 9 30={timeout}",
            f"D {exact.hex()}",
            f"D {CODEC.encode(stop, 'strip', timeout=timeout).hex()}",
        ]
    )
    assert built.ok
    assert built.data == exact
    assert plain.ok
    assert plain.fields == ["9", f"30={timeout}"]
    assert from_stripped == plain
    padded = CODEC.encode(stop, "pad", timeout=timeout)
    assert len(padded) == MAX
    for data in (exact, padded):
        decoded = CODEC.decode(data)
        assert (decoded.kind, decoded.timeout) == ("drive_motor", timeout)
