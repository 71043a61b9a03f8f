"""Loading proto trees: the packaged schema, and small trees under tests/schema_trees/ built to
exercise one loader rule each (leftover files, broken imports, missing or doubled roots, roots that
are not envelopes, shared payload types, subfolder imports)."""

import os
import re
import sys
import tempfile
from pathlib import Path
from typing import Any, cast

import pytest
from conftest import PROTO, TESTS
from google.protobuf import descriptor_pb2
from google.protobuf.descriptor import Descriptor

import erc_codec
from erc_codec import Codec, Decoded, DecodeError, EncodeError, MessageCodec, SchemaError
from erc_schema import ProtocError, compile_files, options_class
from erc_schema._options import VOCABULARY, compile_vocabulary

TREES = TESTS / "schema_trees"
ENVELOPE_PROTO = PROTO / "components" / "common" / "envelope.proto"


def descriptor(cls: Any) -> Descriptor:
    return cast(Descriptor, cls.DESCRIPTOR)


def h(text: str) -> bytes:
    return bytes.fromhex(text)


# -- the packaged schema -----------------------------------------------------------------------


def envelope_members_from_source() -> dict[int, tuple[str, str]]:
    """number -> (member name, type name), read from the text of envelope.proto's oneof."""
    text = ENVELOPE_PROTO.read_text(encoding="utf-8")
    body = re.search(r"oneof\s+payload\s*\{(.*?)\}", text, re.DOTALL)
    assert body is not None
    members = re.findall(r"^\s*(\w+)\s+(\w+)\s*=\s*(\d+)\s*;", body.group(1), re.MULTILINE)
    return {int(number): (name, type_name) for type_name, name, number in members}


def test_the_source_lists_members_1_to_21() -> None:
    assert sorted(envelope_members_from_source()) == list(range(1, 22))


def test_default_codec_kinds_match_envelope_proto(codec: Codec) -> None:
    members = envelope_members_from_source()
    assert codec.kinds() == {number: name for number, (name, _) in members.items()}


def test_default_codec_member_types_match_envelope_proto(codec: Codec) -> None:
    envelope = descriptor(codec.message_class("PBEnvelope"))
    for number, (name, type_name) in envelope_members_from_source().items():
        field = envelope.fields_by_number[number]
        assert field.name == name
        assert field.message_type is not None
        assert field.message_type.full_name == type_name


def test_default_codec_is_shared_and_rooted_at_pbenvelope(codec: Codec) -> None:
    assert Codec.default() is codec
    assert codec.root == "PBEnvelope"
    assert codec.max_size("PBEnvelope") == 262


def test_default_codec_loads_the_packaged_tree(codec: Codec) -> None:
    """In a checkout the packaged tree is the repository's proto/ folder."""
    from erc_codec.codec._codec import default_tree

    tree = default_tree()
    assert (tree / "components" / "common" / "envelope.proto").is_file()
    assert tree.resolve() in (PROTO.resolve(), (Path(erc_codec.__file__).parent / "proto"))
    loaded = Codec.from_path(tree)
    assert loaded.kinds() == codec.kinds()
    assert loaded.sizes() == codec.sizes()


# Folder under proto/components/ -> the prefix of every payload type defined there.
PREFIXES = {
    "arm_board": "ArmBoard",
    "basestation": "Basestation",
    "driving_board": "DrivingBoard",
    "sensor_board": "SensorBoard",
}
# Sensor-board payload names documented without the prefix (none today).
DOCUMENTED_SENSOR_NAMES: frozenset[str] = frozenset()


def test_every_member_type_has_its_component_prefix(codec: Codec) -> None:
    envelope = descriptor(codec.message_class("PBEnvelope"))
    for field in envelope.oneofs[0].fields:
        assert field.message_type is not None
        type_name = field.message_type.full_name
        path = Path(field.message_type.file.name)
        assert path.parts[0] == "components", path
        component = path.parts[1]
        assert component in PREFIXES, f"{type_name} is defined in {path}"
        assert type_name.startswith(PREFIXES[component]) or (
            component == "sensor_board" and type_name in DOCUMENTED_SENSOR_NAMES
        ), f"{field.name}: {type_name} in {path}"


@pytest.mark.parametrize("name", ["Nope", "pbenvelope", "PBEnvelope.payload", "SensorState", ""])
def test_message_class_of_an_unknown_name_raises_schema_error(codec: Codec, name: str) -> None:
    with pytest.raises(SchemaError, match=re.escape(repr(name))):
        codec.message_class(name)


def test_max_size_of_an_unknown_name_raises_schema_error(codec: Codec) -> None:
    with pytest.raises(SchemaError, match="NoSuchMessage"):
        codec.max_size("NoSuchMessage")


def test_from_path_accepts_str_and_pathlike(codec: Codec) -> None:
    for tree in (str(PROTO), PROTO, os.fspath(PROTO)):
        assert Codec.from_path(tree).kinds() == codec.kinds()


@pytest.mark.parametrize(
    "root", ["SensorBoardGPSInfo", "MotorInformation", "DrivingBoardDiagnostics"]
)
def test_a_payload_of_the_real_tree_is_a_plain_message_root(root: str) -> None:
    codec = Codec.from_path(PROTO, root=root)
    assert isinstance(codec, MessageCodec)
    assert (codec.root, codec.kinds(), codec.members()) == (root, {}, ())
    with pytest.raises(SchemaError, match=rf"\b{root}\b.*must have exactly one oneof"):
        Codec(codec.schema)  # the envelope codec itself still wants an envelope


# -- (a) a tree with leftovers next to the envelope ----------------------------------------------


def test_leftover_files_really_break_a_whole_tree_compile() -> None:
    """The leftovers are hostile: compiled together with the envelope they fail."""
    tree = TREES / "leftover"
    collision = r"message_types\.proto:7:3: \"SensorBoardPing\" is already defined"
    with pytest.raises(SchemaError, match=collision):
        compile_files(tree, ["env.proto", "message_types.proto"])
    with pytest.raises(SchemaError, match=r"draft\.proto:\d+:\d+:"):
        compile_files(tree, ["draft.proto"])


def test_leftover_files_do_not_stop_loading() -> None:
    codec = Codec.from_path(TREES / "leftover", root="Env")
    assert codec.root == "Env"
    assert codec.kinds() == {1: "ping", 2: "pong"}
    assert codec.max_size("SensorBoardPong") == 11  # uint32 6 + float 5
    assert codec.max_size("Env") == 13
    pong: Any = codec.message_class("SensorBoardPong")(seq=300, latency_ms=1e-40)
    assert codec.encode(pong, "exact") == h("12 08 08 ac 02 15 c2 16 01 00")
    assert codec.encode(pong) == h("12 08 08 ac 02 15 c2 16 01")
    assert codec.encode(pong, "pad") == h("12 08 08 ac 02 15 c2 16 01 00") + bytes(3)
    for mode in ("strip", "exact", "pad"):
        assert codec.decode(codec.encode(pong, mode)) == ("pong", pong)
    ping: Any = codec.message_class("SensorBoardPing")()
    assert codec.encode(ping, "exact") == h("0a 00")
    assert codec.decode(h("0a")) == ("ping", ping)


def test_leftover_enum_is_not_part_of_the_loaded_schema() -> None:
    codec = Codec.from_path(TREES / "leftover", root="Env")
    with pytest.raises(SchemaError, match="Draft"):
        codec.message_class("Draft")
    assert set(codec.sizes()) == {"Env", "SensorBoardPing", "SensorBoardPong"}


# -- (b) a broken import of the envelope ---------------------------------------------------------


def test_a_broken_import_is_a_schema_error_with_protocs_location() -> None:
    with pytest.raises(SchemaError) as caught:
        Codec.from_path(TREES / "broken", root="Env")
    text = str(caught.value)
    assert 'parts/broken_part.proto:6:3: "Missing" is not defined.' in text
    assert re.search(r"env\.proto:3:1: Import \"parts/broken_part\.proto\"", text), text


def test_a_broken_import_reports_the_file_as_a_user_can_open_it() -> None:
    tree = TREES / "broken"
    with pytest.raises(SchemaError) as caught:
        Codec.from_path(tree, root="Env")
    match = re.search(r"(\S*broken_part\.proto):6:3:", str(caught.value))
    assert match is not None
    assert Path(match.group(1)).resolve() == (tree / "parts" / "broken_part.proto").resolve()


# -- (c) a root that is defined nowhere ----------------------------------------------------------


@pytest.mark.parametrize("root", ["Nowhere", "PBEnvelope", "Ghost", "PBMessageType"])
def test_a_root_defined_nowhere_is_named(root: str) -> None:
    # Ghost appears only in a comment of draft.proto; PBMessageType is an enum, not a message.
    with pytest.raises(SchemaError, match=rf"\b{root}\b"):
        Codec.from_path(TREES / "leftover", root=root)


def test_a_tree_without_proto_files(tmp_path: Path) -> None:
    with pytest.raises(SchemaError, match=r"\bEnv\b"):
        Codec.from_path(tmp_path, root="Env")


# -- (d) a root defined twice --------------------------------------------------------------------


def test_a_root_defined_in_two_files_names_both() -> None:
    with pytest.raises(SchemaError) as caught:
        Codec.from_path(TREES / "twice", root="Env")
    text = str(caught.value)
    assert "Env" in text
    assert "a.proto" in text
    assert "copies/b.proto" in text


def test_each_copy_compiles_alone() -> None:
    """Neither file is broken: the two definitions only meet in a loader that takes both."""
    for name in ("a.proto", "copies/b.proto"):
        compiled = compile_files(TREES / "twice", [name])
        assert [message.name for message in compiled.file[-1].message_type][-1] == "Env"


# -- (e) roots that are not envelopes ----------------------------------------------------------


@pytest.mark.parametrize(
    ("root", "pattern"),
    [
        ("Unsized", r"roots\.proto:\d+:\d+: Named\.name: string field without nanopb max_size"),
    ],
)
def test_an_unsized_root_is_refused(root: str, pattern: str) -> None:
    with pytest.raises(SchemaError, match=pattern):
        Codec.from_path(TREES / "notenvelope", root=root)


@pytest.mark.parametrize("root", ["Loose", "TwoOneofs", "NoOneof", "Part", "Scalar"])
def test_a_root_that_is_not_an_envelope_is_a_plain_message(root: str) -> None:
    codec = Codec.from_path(TREES / "notenvelope", root=root)
    assert isinstance(codec, MessageCodec)
    message = codec.message_class(root)()
    for mode in ("strip", "exact", "pad"):
        assert codec.decode(codec.encode(message, mode)) == (root, message)


# -- (f) one payload type, two members -----------------------------------------------------------


@pytest.fixture(scope="module")
def shared() -> Codec:
    return Codec.from_path(TREES / "shared", root="Env")


def test_shared_type_decodes_for_both_members(shared: Codec) -> None:
    reading = shared.message_class("Reading")
    one: Any = reading(value=1.0)
    assert shared.kinds() == {1: "left", 2: "right", 3: "other"}
    cases = [
        (h("0a 00"), "left", reading()),
        (h("0a"), "left", reading()),
        (h("12 00"), "right", reading()),
        (h("12"), "right", reading()),
        (h("12 05 0d 00 00 80 3f"), "right", one),
        (h("0a 05 0d 00 00 80 3f") + bytes(6), "left", one),
        (h("0a 05 0d 00 00 80 3f 00 00"), "left", one),
    ]
    for data, kind, message in cases:
        decoded = shared.decode(data)
        assert isinstance(decoded, Decoded)
        assert type(decoded.message) is reading
        assert decoded == (kind, message), data.hex()


def test_shared_type_bare_payload_is_ambiguous(shared: Codec) -> None:
    reading = shared.message_class("Reading")(value=1.0)
    with pytest.raises(EncodeError) as caught:
        shared.encode(reading)
    text = str(caught.value)
    assert "Reading" in text
    assert re.search(r"ambiguous|twice|both|two members", text), text
    other = Codec.from_path(TREES / "shared", root="Env").message_class("Reading")(value=1.0)
    with pytest.raises(EncodeError, match="Reading"):
        shared.encode(other)  # a class from another load takes the by-name path: same answer


def test_shared_type_in_an_envelope_encodes_for_either_member(shared: Codec) -> None:
    envelope = shared.message_class("Env")
    reading = shared.message_class("Reading")
    for kind, tag in (("left", "0a"), ("right", "12")):
        message: Any = envelope()
        getattr(message, kind).CopyFrom(reading(value=1.0))
        assert shared.encode(message, "exact") == h(f"{tag} 05 0d 00 00 80 3f")
        empty: Any = envelope()
        getattr(empty, kind).SetInParent()
        assert shared.encode(empty, "exact") == h(f"{tag} 00")
        assert shared.encode(empty) == h(tag)
        assert shared.encode(empty, "pad") == h(f"{tag} 00") + bytes(11)
        assert shared.decode(shared.encode(empty)) == (kind, reading())


def test_shared_tree_other_member_still_encodes_bare(shared: Codec) -> None:
    other: Any = shared.message_class("Other")(id=1)
    assert shared.encode(other, "exact") == h("1a 02 08 01")
    assert shared.decode(h("1a 02 08 01")) == ("other", other)


# -- (g) subfolder imports -------------------------------------------------------------------------


def test_subfolder_imports_load() -> None:
    codec = Codec.from_path(TREES / "subdir", root="Env")
    assert codec.kinds() == {1: "x", 2: "y"}
    assert codec.max_size("SubY") == 9
    assert codec.max_size("SubX") == 17  # 6 + (1 + 1 + 9)
    assert codec.max_size("Env") == 19
    x: Any = codec.message_class("SubX")(id=5)
    x.inner.value = 5e-324
    assert codec.encode(x, "exact") == h("0a 0d 08 05 12 09 09 01 00 00 00 00 00 00 00")
    assert codec.encode(x) == h("0a 0d 08 05 12 09 09 01")
    assert codec.decode(h("0a 0d 08 05 12 09 09 01")) == ("x", x)


# -- (h) a directory that does not exist -------------------------------------------------------


def test_a_nonexistent_directory(tmp_path: Path) -> None:
    missing = tmp_path / "no" / "such" / "tree"
    with pytest.raises(SchemaError, match=re.escape(str(missing))):
        Codec.from_path(missing)


def test_a_file_instead_of_a_directory() -> None:
    with pytest.raises(SchemaError, match=r"envelope\.proto"):
        Codec.from_path(ENVELOPE_PROTO)


def test_schema_error_is_a_codec_error() -> None:
    with pytest.raises(erc_codec.CodecError):
        Codec.from_path(TREES / "twice", root="Env")


# -- loading writes nothing --------------------------------------------------------------------


def snapshot(tree: Path) -> dict[str, tuple[bool, int, int]]:
    """Every entry under ``tree``: relative path -> (is a directory, size, mtime in ns)."""
    found: dict[str, tuple[bool, int, int]] = {}
    for path in sorted(tree.rglob("*")):
        stat = path.stat()
        found[path.relative_to(tree).as_posix()] = (path.is_dir(), stat.st_size, stat.st_mtime_ns)
    return found


def test_loading_never_writes_into_the_tree() -> None:
    before = {tree: snapshot(tree) for tree in (TREES, PROTO)}
    attempts: list[tuple[Path, str]] = [
        (PROTO, "PBEnvelope"),
        (PROTO, "SensorBoardGPSInfo"),
        (TREES / "leftover", "Env"),
        (TREES / "leftover", "Nowhere"),
        (TREES / "broken", "Env"),
        (TREES / "twice", "Env"),
        (TREES / "notenvelope", "Scalar"),
        (TREES / "notenvelope", "Unsized"),
        (TREES / "shared", "Env"),
        (TREES / "subdir", "Env"),
    ]
    loaded = 0
    for tree, root in attempts:
        try:
            codec = Codec.from_path(tree, root=root)
        except SchemaError:
            continue
        codec.sizes()
        envelope: Any = codec.message_class(root)()
        if codec.kinds():
            getattr(envelope, codec.kinds()[min(codec.kinds())]).SetInParent()
        codec.decode(codec.encode(envelope))
        loaded += 1
    assert loaded == 6  # SensorBoardGPSInfo and Scalar as plain messages
    after = {tree: snapshot(tree) for tree in (TREES, PROTO)}
    assert after == before


@pytest.mark.parametrize("where", ["memory", "disk"])
def test_protoc_scratch_files_leave_nothing_behind(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, where: str
) -> None:
    """protoc's scratch files (its output, its diagnostics, descriptors it is given), in memory
    or in a temporary folder, are gone when the compilation ends, failed or not, and no
    descriptor stays open."""
    if where == "disk":
        monkeypatch.delattr(os, "memfd_create", raising=False)
    monkeypatch.setenv("TMPDIR", str(tmp_path))
    monkeypatch.setattr("tempfile.tempdir", None)  # read TMPDIR again
    assert tempfile.gettempdir() == str(tmp_path)
    opened = set(os.listdir("/proc/self/fd")) if os.path.isdir("/proc/self/fd") else set()
    compiled = compile_files(PROTO, ["components/common/envelope.proto"])
    known = compile_files(TREES / "subdir", ["env.proto"], known=compiled)
    with pytest.raises(SchemaError, match=r"env\.proto:\d+:\d+: "):
        compile_files(TREES / "broken", ["env.proto"])
    assert "PBEnvelope" in {m.name for f in compiled.file for m in f.message_type}
    assert [f.name for f in known.file][-1] == "env.proto"
    if opened:
        assert set(os.listdir("/proc/self/fd")) <= opened
    assert list(tmp_path.iterdir()) == []


def compiled_both_ways() -> list[bytes | list[str]]:
    """The packaged tree, a tree given known files, and protoc's diagnostics for a broken tree."""
    compiled = compile_files(PROTO, ["components/common/envelope.proto"])
    known = compile_files(TREES / "subdir", ["env.proto"], known=compiled, retain_options=True)
    with pytest.raises(ProtocError) as failed:
        compile_files(TREES / "broken", ["env.proto"])
    assert failed.value.lines
    return [compiled.SerializeToString(), known.SerializeToString(), failed.value.lines]


def test_scratch_files_in_memory_give_what_a_scratch_folder_gives(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """bench_lint's speed trick (protoc's scratch files in memory on Linux) against the plain
    version (a temporary folder): the same bytes, the same diagnostics. With no temporary folder
    to be had, the memory files still work, and the folder is really what the plain version
    uses."""
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path / "absent"))
    if sys.platform == "linux":  # where memfd_create is
        in_memory = compiled_both_ways()
    monkeypatch.delattr(os, "memfd_create", raising=False)
    with pytest.raises(FileNotFoundError):
        compile_files(PROTO, ["components/common/envelope.proto"])
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path))
    on_disk = compiled_both_ways()
    if sys.platform == "linux":
        assert in_memory == on_disk
    assert list(tmp_path.iterdir()) == []


def test_decode_errors_of_a_small_tree(shared: Codec) -> None:
    with pytest.raises(DecodeError, match=r"\b4\b"):
        shared.decode(h("22 00"))
    with pytest.raises(DecodeError, match=r"14 bytes.*13"):
        shared.decode(bytes(14))


def test_shipped_vocabulary_is_protocs() -> None:
    """nanopb.pb, which options_class reads instead of running protoc on every run, is what
    protoc makes of the shipped nanopb.proto now, and what NanoPBOptions is built from. (After
    an edit of nanopb.proto: ``VOCABULARY.write_bytes(compile_vocabulary().SerializeToString(
    deterministic=True))``.)"""
    compiled = compile_vocabulary()
    shipped = descriptor_pb2.FileDescriptorSet.FromString(VOCABULARY.read_bytes())
    assert [file.name for file in compiled.file] == ["nanopb.proto"]
    assert shipped == compiled
    assert VOCABULARY.read_bytes() == compiled.SerializeToString(deterministic=True)
    built = descriptor_pb2.FileDescriptorProto()
    options_class().DESCRIPTOR.file.CopyToProto(built)
    assert built == compiled.file[0]
