"""Any nanopb schema through the public API: plain-message roots, include folders, the options
files and settings nanopb's generator takes, and schemas protobuf's Python runtime cannot build.

Sizes are checked against nanopb's generator (PyPI ``nanopb`` 0.4.9.1) run as a nanopb user runs it,
from the tree's root with the same ``-I``, ``-f`` and ``-s``; tests/interop/test_interop_any.py
holds the encode rules and decodes against nanopb's C library.
"""

import json
import os
import re
import shutil
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any, cast

import pytest
from conftest import TESTS
from hypothesis import given, settings

import erc_codec
from erc_codec import Codec, DecodeError, EncodeError, MessageCodec, SchemaError, strategies
from erc_schema import Sizes, compile_files, load_schema, resolve_options

TREES = TESTS / "any_trees"
INCLUDE = TREES / "include"
SCHEMA_TREES = TESTS / "schema_trees"
_DEFINE = re.compile(r"^#define\s+(\w+)_size\s+(\d+)\s*$", re.MULTILINE)
_RUNTIME = re.compile(r"/\*\s*(\w+)_size depends on runtime parameters\s*\*/")


_PYPI_GENERATOR = (sys.executable, "-m", "nanopb.generator.nanopb_generator")


def generator_sizes(
    tmp: Path, tree: Path, files: list[str], *args: str, generator: Sequence[str] = _PYPI_GENERATOR
) -> dict[str, int | None]:
    """``<Msg>_size`` of every message nanopb's ``generator`` (PyPI's 0.4.9.1 unless told)
    writes for ``files`` (run in ``tree`` with ``args``), ``None`` where it writes "depends on
    runtime parameters"."""
    command = [*generator, "-q", *args]
    subprocess.run(
        [*command, "-D", str(tmp), *files],
        cwd=tree,
        check=True,
    )
    sizes: dict[str, int | None] = {}
    for name in files:
        header = (tmp / name).with_suffix(".pb.h").read_text()
        sizes.update({c.replace("_", "."): int(size) for c, size in _DEFINE.findall(header)})
        sizes.update({c.replace("_", "."): None for c in _RUNTIME.findall(header)})
    return sizes


@pytest.fixture(scope="module")
def generator() -> None:
    pytest.importorskip("nanopb")


# -- include folders, -f and -s ----------------------------------------------------------------


@pytest.mark.parametrize(
    ("options_file", "settings", "expected"),
    [
        ("%s.options", (), {"App": None}),  # App.label has no max_size without -s
        ("%s.options", ("max_size:20", "max_count=3"), {"App": 74}),
        ("%s.nanopb", ("max_count:3",), {"App": 69}),  # app.nanopb and units.nanopb instead
    ],
    ids=["default", "settings", "options-file-pattern"],
)
def test_include_folders_options_and_settings_size_as_nanopb(
    generator: None,
    tmp_path: Path,
    options_file: str,
    settings: tuple[str, ...],
    expected: dict[str, int | None],
) -> None:
    main, inc = INCLUDE / "main", INCLUDE / "inc"
    args = ["-I", ".", "-I", "../inc", "-f", options_file, *(f"-s{s}" for s in settings)]
    theirs = generator_sizes(tmp_path, main, ["app.proto"], *args)
    schema = load_schema(main, "App", include=[inc])
    ours = Sizes(schema, options_file, settings).all()
    assert ours == theirs == expected


def test_a_codec_with_an_include_folder_and_settings() -> None:
    codec = Codec.from_path(
        INCLUDE / "main", "App", include=[INCLUDE / "inc"], settings=["max_size:20", "max_count:3"]
    )
    assert isinstance(codec, MessageCodec)
    assert codec.max_size("Reading") == 33  # units.options, found beside units.proto on -I
    app: Any = codec.message_class("App")(label="x" * 19, counts=[1, 2, 3])
    app.reading.unit = "kPa"
    assert codec.decode(codec.encode(app)).message == app
    with pytest.raises(EncodeError, match=r"App\.label is 20 bytes long, more than the 19"):
        codec.encode(codec.message_class("App")(label="x" * 20))


def test_without_the_include_folder_the_import_is_not_found() -> None:
    with pytest.raises(SchemaError, match=r"shared/units\.proto"):
        Codec.from_path(INCLUDE / "main", "App")


def test_an_include_folder_that_is_not_a_directory(tmp_path: Path) -> None:
    with pytest.raises(SchemaError, match=r"nowhere: include folder is not a directory"):
        load_schema(INCLUDE / "main", "App", include=[tmp_path / "nowhere"])


@pytest.mark.parametrize("setting", ["max_size:x", "no_such_option:1"])
def test_a_bad_generator_setting_is_a_schema_error(setting: str) -> None:
    schema = load_schema(INCLUDE / "main", "App", include=[INCLUDE / "inc"])
    with pytest.raises(SchemaError, match=rf"generator setting {re.escape(repr(setting))}"):
        Sizes(schema, settings=[setting])


def test_a_bad_options_file_pattern_is_a_schema_error() -> None:
    schema = load_schema(INCLUDE / "main", "App", include=[INCLUDE / "inc"])
    with pytest.raises(SchemaError, match=r"options file pattern '%q\.options'"):
        Sizes(schema, options_file="%q.options")


# -- roots named as protoc names them -------------------------------------------------------------


def test_a_root_in_a_package_is_named_in_full(tmp_path: Path) -> None:
    (tmp_path / "p.proto").write_text('syntax = "proto3";\npackage rover.arm;\nmessage Joint {}\n')
    assert Codec.from_path(tmp_path, "rover.arm.Joint").root == "rover.arm.Joint"
    with pytest.raises(SchemaError, match=r"did you mean rover\.arm\.Joint\?"):
        Codec.from_path(tmp_path, "Joint")


def test_the_hint_names_the_package_protoc_reads_not_one_in_a_comment(tmp_path: Path) -> None:
    (tmp_path / "p.proto").write_text(
        'syntax = "proto3";\n/*\npackage old.arm;\n*/\npackage rover.arm;\nmessage Joint {}\n'
    )
    with pytest.raises(SchemaError, match=r"did you mean rover\.arm\.Joint\?"):
        Codec.from_path(tmp_path, "Joint")


def test_a_root_defined_twice_is_chosen_by_its_file() -> None:
    both = r"^message Env is defined in both a\.proto and copies/b\.proto: name the file, e\.g\. "
    with pytest.raises(SchemaError, match=both + r"a\.proto:Env$"):
        Codec.from_path(SCHEMA_TREES / "twice", "Env")
    assert Codec.from_path(SCHEMA_TREES / "twice", "a.proto:Env").kinds() == {1: "a"}
    codec = Codec.from_path(SCHEMA_TREES / "twice", "copies/b.proto:Env")
    assert codec.kinds() == {1: "b"}
    with pytest.raises(SchemaError, match=r"no such \.proto file"):
        Codec.from_path(SCHEMA_TREES / "twice", "c.proto:Env")


def _write(tree: Path, files: dict[str, str]) -> Path:
    for name, text in files.items():
        (tree / name).parent.mkdir(parents=True, exist_ok=True)
        (tree / name).write_text('syntax = "proto3";\n' + text)
    return tree


def test_a_duplicate_the_roots_files_are_not_compiled_with_does_not_matter(
    generator: None, tmp_path: Path
) -> None:
    """Part again in a file the root's never import, Other twice in drafts protoc refuses
    (y imports x): neither is compiled with env.proto, for nanopb nor for us."""
    tree = _write(
        tmp_path / "tree",
        {
            "env.proto": 'import "part.proto";\nmessage Env { oneof p { Part part = 1; } }\n',
            "part.proto": "message Part { int32 x = 1; }\n",
            "stray.proto": "message Part { string name = 1; }\n",
            "drafts/x.proto": "message Other { int32 a = 1; }\n",
            "drafts/y.proto": 'import "drafts/x.proto";\nmessage Other { int32 b = 1; }\n',
        },
    )
    out = tmp_path / "out"
    out.mkdir()
    theirs = generator_sizes(out, tree, ["env.proto"])
    assert theirs == {"Env": 13}
    codec = Codec.from_path(tree, "Env")
    assert codec.sizes() == {"Part": 11, **theirs}  # part.proto's own, as nanopb sizes it
    assert codec.max_size("Env") == 13
    part: Any = codec.message_class("part")(x=-1)
    assert codec.decode(codec.encode(part)) == ("part", part)
    done = erc_codec_cli("sizes", "--proto", str(tree), "--root", "Env", "--format", "json")
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["max_size"] == 13


def test_a_duplicate_compiled_with_the_roots_files_is_protocs_error(tmp_path: Path) -> None:
    tree = _write(
        tmp_path,
        {
            "env.proto": 'import "part.proto";\nimport "stray.proto";\n'
            "message Env { oneof p { Part part = 1; } }\n",
            "part.proto": "message Part { int32 x = 1; }\n",
            "stray.proto": "message Part { string name = 1; }\n",
        },
    )
    pattern = r'stray\.proto:2:9: "Part" is already defined in file "part\.proto"'
    with pytest.raises(SchemaError, match=pattern):
        Codec.from_path(tree, "Env")


def test_a_root_defined_again_in_a_file_compiled_with_it_is_ambiguous(
    generator: None, tmp_path: Path
) -> None:
    """a.proto imports b.proto and both define Env: nanopb's generator refuses a.proto, takes
    b.proto alone. Loading Env names both files and how to pick one, not b's Env unasked."""
    tree = _write(
        tmp_path / "tree",
        {
            "a.proto": 'import "b.proto";\nmessage Env { oneof p { Part a = 1; } }\n',
            "b.proto": "message Part { int32 x = 1; }\nmessage Env { oneof p { Part b = 1; } }\n",
        },
    )
    command = [sys.executable, "-m", "nanopb.generator.nanopb_generator", "-q", "-D", str(tmp_path)]
    refused = subprocess.run([*command, "a.proto"], cwd=tree, capture_output=True, text=True)
    assert refused.returncode != 0
    assert '"Env" is already defined in file "b.proto"' in refused.stderr
    pattern = (
        r"^message Env is defined in both a\.proto and b\.proto, which are compiled together "
        r"\(.*a\.proto:3:9: Env is already defined in b\.proto\): name the file, e\.g\. "
        r"b\.proto:Env$"
    )
    with pytest.raises(SchemaError, match=pattern):
        Codec.from_path(tree, "Env")
    assert Codec.from_path(tree, "b.proto:Env").kinds() == {1: "b"}
    with pytest.raises(SchemaError, match=r'a\.proto:3:9: "Env" is already defined'):
        Codec.from_path(tree, "a.proto:Env")
    done = erc_codec_cli("sizes", "--proto", str(tree), "--root", "Env")
    assert done.returncode == 2
    assert done.stderr.startswith("Error: message Env is defined in both a.proto and b.proto")


# -- a plain message as the root ----------------------------------------------------------------


@pytest.fixture(scope="module")
def plain() -> MessageCodec:
    codec = Codec.from_path(TREES / "rules", "Probe")
    assert isinstance(codec, MessageCodec)
    return codec


def test_a_plain_root_in_the_three_forms(plain: MessageCodec) -> None:
    probe = plain.message_class("Probe")(key=b"\1\2\3\0", quad=[0, 0, 0, 0])
    exact = plain.encode(probe, "exact")
    assert exact == probe.SerializeToString()
    assert plain.encode(probe) == exact.rstrip(b"\0")
    assert plain.encode(probe, "pad") == exact + bytes(plain.max_size("Probe") - len(exact))
    for mode in ("strip", "exact", "pad"):
        assert plain.decode(plain.encode(probe, mode)) == ("Probe", probe)
    assert plain.peek(plain.encode(probe)) == ("Probe", exact)
    assert plain.payload_class("Probe") is plain.message_class("Probe")
    assert (plain.kinds(), plain.members(), plain.metadata_fields()) == ({}, (), {})


def test_a_plain_root_refuses_what_it_does_not_send(plain: MessageCodec) -> None:
    with pytest.raises(EncodeError, match=r"Probe\.Inner is not Probe"):
        plain.encode(plain.message_class("Probe.Inner")())
    with pytest.raises(EncodeError, match=r"unknown mode 'loud'"):
        plain.encode(plain.message_class("Probe")(key=b"abcd", quad=[1, 2, 3, 4]), "loud")  # type: ignore[arg-type]
    with pytest.raises(SchemaError, match=r"'Inner' is not Probe"):
        plain.payload_class("Inner")


@pytest.mark.parametrize("value", [5, [10, 4], "0a04"])
def test_a_plain_root_takes_only_bytes_like_datagrams(plain: MessageCodec, value: object) -> None:
    """``bytes(5)`` would be five zeros, which decode to the default message."""
    pattern = f"a datagram is bytes .*not {type(value).__name__}"
    with pytest.raises(TypeError, match=pattern):
        plain.decode(value)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match=pattern):
        plain.peek(value)  # type: ignore[arg-type]


def test_a_plain_root_refuses_a_class_of_another_schema(tmp_path: Path) -> None:
    """Their ``R`` sent as ours would be read as ``a: 1`` (sint32 -1, zigzag) beside an unknown
    field; a class of the same declaration (generated code of the same .proto) is taken."""
    trees = {
        "ours": "uint32 a = 1;",
        "theirs": "sint32 a = 1; uint32 b = 2;",
        "twin": "uint32 a = 1;",
    }
    for folder, fields in trees.items():
        (tmp_path / folder).mkdir()
        (tmp_path / folder / "r.proto").write_text(
            f'syntax = "proto3";\nmessage R {{ {fields} }}\n'
        )
    ours, theirs, twin = (Codec.from_path(tmp_path / folder, "R") for folder in trees)
    with pytest.raises(EncodeError, match=r"^R is a message class of another schema"):
        ours.encode(theirs.message_class("R")(a=-1, b=3))
    sent = ours.encode(twin.message_class("R")(a=5))
    assert ours.decode(sent) == ("R", ours.message_class("R")(a=5))


def test_a_plain_root_encodes_only_messages(plain: MessageCodec) -> None:
    with pytest.raises(TypeError, match=r"encode takes a protobuf message \(a Probe\), not bytes"):
        plain.encode(b"\x0a\x00")  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("data", "pattern", "reason"),
    [
        (bytes(79), r"79 bytes is longer than Probe's maximum of 78", "too_long"),
        (b"\x08\x01\x00\x05", r"zero byte at offset 2 ends the message, but a non-zero", "corrupt"),
        (b"\x0a\x50", r"restoring its stripped zeros makes the datagram 82 bytes", "corrupt"),
        (b"\x0f", r"truncated or corrupt datagram: field 1's wire type 7", "corrupt"),
        (b"\x2a\x02\x0f", r"not a valid Probe \(after restoring its trailing zeros\)", "corrupt"),
    ],
)
def test_a_plain_root_names_what_is_wrong_with_a_datagram(
    plain: MessageCodec, data: bytes, pattern: str, reason: str
) -> None:
    with pytest.raises(DecodeError, match=pattern) as raised:
        plain.decode(data)
    assert raised.value.reason == reason
    # peek, parsing nothing, finds no exact form for all but the last, whose fields it walks
    assert (plain.peek(data) is None) == ("not a valid" not in pattern)


def test_an_empty_datagram_is_the_default_message(plain: MessageCodec) -> None:
    assert plain.decode(b"") == ("Probe", plain.message_class("Probe")())


def test_strict_decoding_of_an_envelope(tmp_path: Path) -> None:
    (tmp_path / "e.proto").write_text(
        'syntax = "proto2";\nimport "nanopb.proto";\n'
        "message Part { required uint32 serial = 1;"
        " optional string name = 2 [(nanopb).max_size = 4]; }\n"
        "message Env { oneof payload { Part part = 1; } }\n"
    )
    codec = Codec.from_path(tmp_path, "Env")
    for data, why in [
        (b"\x0a\x00", r"Part\.serial is required but missing"),
        (b"\x0a\x08\x08\x01\x12\x04abcd", r"Part\.name is 4 bytes long, more than the 3"),
    ]:
        assert codec.decode(data).kind == "part"  # protobuf's reading takes it
        with pytest.raises(DecodeError, match=rf"nanopb's decoder refuses the part payload: {why}"):
            codec.decode(data, strict=True)
    assert codec.decode(b"\x0a\x02\x08\x01", strict=True).kind == "part"


# A Reading: level {a: 3, and field 15 = 1, which Level lacks}, b: 7, and field 20 = 1, which
# Reading lacks; sent by itself (a plain root) and as the payload of an envelope.
_UNKNOWN_PAYLOAD = bytes.fromhex("0a04080378011007a00101")


def test_a_plain_root_reports_and_refuses_unknown_fields_as_an_envelope_does(
    tmp_path: Path,
) -> None:
    (tmp_path / "u.proto").write_text(
        'syntax = "proto3";\n'
        "message Level { uint32 a = 1; }\n"
        "message Reading { Level level = 1; uint32 b = 2; }\n"
        "message Env { oneof payload { Reading reading = 1; } }\n"
    )
    plain = Codec.from_path(tmp_path, "Reading")
    envelope = Codec.from_path(tmp_path, "Env")
    assert isinstance(plain, MessageCodec)
    assert not isinstance(envelope, MessageCodec)
    wrapped = bytes([0x0A, len(_UNKNOWN_PAYLOAD)]) + _UNKNOWN_PAYLOAD
    expected = (erc_codec.UnknownField("", 20, 0), erc_codec.UnknownField("level", 15, 0))
    ours, theirs = plain.decode(_UNKNOWN_PAYLOAD), envelope.decode(wrapped)
    assert ours.unknown_fields == theirs.unknown_fields == expected
    assert ours.to_dict()["unknown_fields"] == theirs.to_dict()["unknown_fields"]
    listed = r"Reading does not know: 20 \(wire type 0\), 15 \(wire type 0, in level\)"
    for codec, data, subject in [
        (plain, _UNKNOWN_PAYLOAD, "Reading"),
        (envelope, wrapped, "reading payload"),
    ]:
        for form in (data, data + bytes(2)):  # exact and zero-padded
            pattern = rf"^datagram of {len(form)} bytes: its {subject} holds fields {listed} "
            pattern += r"\(another schema\?\)$"
            with pytest.raises(DecodeError, match=pattern) as raised:
                codec.decode(form, strict=True)
            assert raised.value.reason == "unknown_fields"
    known = plain.message_class("Reading")(b=7)
    assert plain.decode(plain.encode(known), strict=True) == ("Reading", known)


# -- what protobuf's Python runtime cannot build --------------------------------------------------


def test_schemas_the_runtime_refuses_still_get_nanopbs_sizes(
    generator: None, tmp_path: Path
) -> None:
    tree = TREES / "runtime"
    theirs = generator_sizes(tmp_path, tree, ["many.proto"])
    schema = load_schema(tree, "Fine")
    assert Sizes(schema).all() == theirs
    assert theirs == {"ManyRequired": 405, "JsonClash": 22, "HoldsClash": 24, "Fine": 11}
    assert set(schema.refused) == {"ManyRequired", "JsonClash"}


@pytest.mark.parametrize(
    ("root", "pattern"),
    [
        (
            "ManyRequired",
            r"many\.proto:\d+:\d+: ManyRequired: 70 required fields, more than the 63",
        ),
        ("JsonClash", r"JsonClash: fields foo_bar and fooBar share the JSON name 'fooBar'"),
        ("HoldsClash", r"JsonClash \(reached as HoldsClash\.clash\): fields foo_bar and fooBar"),
    ],
)
def test_a_message_the_runtime_refuses_loads_and_refuses_to_encode_or_decode(
    generator: None, tmp_path: Path, root: str, pattern: str
) -> None:
    """The root loads with nanopb's sizes; encoding, decoding and asking its class are each the
    SchemaError saying why (decoding's a DecodeError of reason "unsupported" too, for counters),
    and peek finds nothing."""
    theirs = generator_sizes(tmp_path, TREES / "runtime", ["many.proto"])
    codec = Codec.from_path(TREES / "runtime", root)
    assert codec.max_size(root) == theirs[root]
    assert codec.sizes() == theirs
    message = codec.schema.message_class(root, lenient=True)()
    for attempt in (
        lambda: codec.encode(message),
        lambda: codec.encode(message, "pad"),
        lambda: codec.decode(b""),
        lambda: codec.decode(bytes([0x0D, 1, 0, 0, 0]), strict=True),
        lambda: codec.payload_class(root),
        lambda: codec.message_class(root),
    ):
        with pytest.raises(SchemaError, match=pattern):
            attempt()
    assert codec.peek(b"\x08\x01") is None
    with pytest.raises(DecodeError, match=pattern) as refused:
        codec.decode(b"\x08\x01")
    assert refused.value.reason == "unsupported"


def test_debians_generator_sizes_them_alike(tmp_path: Path) -> None:
    """Debian's nanopb 0.4.7 (its own protoc, no label_override nor editions) on the same tree."""
    program = shutil.which("nanopb_generator.py")
    if program is None:
        if os.environ.get("ERC_REQUIRE_INTEROP") == "1":
            pytest.fail("ERC_REQUIRE_INTEROP=1 but Debian's nanopb generator is not installed")
        pytest.skip("Debian's nanopb generator (apt-get install nanopb) is not installed")
    theirs = generator_sizes(tmp_path, TREES / "runtime", ["many.proto"], generator=[program])
    assert theirs == {"ManyRequired": 405, "JsonClash": 22, "HoldsClash": 24, "Fine": 11}
    for root, size in theirs.items():
        codec = Codec.from_path(TREES / "runtime", root)
        assert (codec.max_size(root), codec.sizes()) == (size, theirs)


def test_the_rest_of_such_a_tree_works() -> None:
    codec = Codec.from_path(TREES / "runtime", "Fine")
    fine = codec.message_class("Fine")(x=-1)
    assert codec.decode(codec.encode(fine)).message == fine
    assert codec.sizes()["ManyRequired"] == 405
    with pytest.raises(SchemaError, match=r"ManyRequired: 70 required fields"):
        codec.message_class("ManyRequired")


# -- envelopes with members erc-codec cannot send: the rest works, sizes are nanopb's ------------

UNSENDABLE = TREES / "unsendable"
_COUNTS = r"env2\.proto:13:\d+: Counts\.n: label_override makes a single number an array"
_CLASH = r"env2\.proto:17:\d+: Clash( \(reached as Env\.clash\))?: fields foo_bar and fooBar"
_SEQ = r"env2\.proto:\d+:\d+: EnvMeta\.seq: label_override makes a single number an array"
_GROUPED = r"editions\.proto:16:\d+: EnvEd\.grouped: protobuf writes it delimited"
_HOLDER = r"editions\.proto:10:\d+: Holder\.inner: protobuf writes it delimited .* EnvEd\.holder"


@pytest.fixture(scope="module")
def unsendable_sizes(tmp_path_factory: pytest.TempPathFactory) -> dict[str, int | None]:
    pytest.importorskip("nanopb")
    out = tmp_path_factory.mktemp("unsendable")
    return generator_sizes(out, UNSENDABLE, ["env2.proto", "editions.proto"])


@pytest.mark.parametrize(
    "root", ["Env", "EnvMeta", "EnvEd", "Fine", "Counts", "Clash", "Sub", "Holder"]
)
def test_every_root_of_such_a_tree_loads_with_nanopbs_sizes(
    unsendable_sizes: dict[str, int | None], root: str
) -> None:
    """protoc and nanopb take the tree: every message has the generator's size, from Python and
    from ``erc-codec sizes``, whether or not erc-codec can send it."""
    file = "editions.proto" if root in ("EnvEd", "Sub", "Holder") else "env2.proto"
    theirs = {
        name: size
        for name, size in unsendable_sizes.items()
        if (name in ("EnvEd", "Sub", "Holder")) == (file == "editions.proto")
    }
    codec = Codec.from_path(UNSENDABLE, root)
    assert codec.max_size(root) == theirs[root]
    assert codec.sizes() == theirs
    done = erc_codec_cli("sizes", "--proto", str(UNSENDABLE), "--root", root, "--format", "json")
    assert done.returncode == 0, done.stderr
    listed = json.loads(done.stdout)
    assert listed["max_size"] == theirs[root]
    assert listed["messages"] == theirs
    assert [m["max_size"] for m in listed["members"]] == [
        theirs[m.message] for m in codec.members()
    ]


def test_an_envelope_sends_its_other_members() -> None:
    codec = Codec.from_path(UNSENDABLE, "Env")
    assert codec.kinds() == {1: "fine", 2: "counts", 3: "clash"}
    fine: Any = codec.message_class("fine")(x=-1)
    for mode in ("exact", "strip", "pad"):
        data = codec.encode(fine, mode, timeout=300)
        decoded = codec.decode(data, strict=True)
        assert (decoded, decoded.timeout) == (("fine", fine), 300)
    assert codec.decode(codec.encode(fine)) == ("fine", fine)
    # Counts builds a class (its trouble is nanopb's override); Clash has none
    counts: Any = codec.schema.message_class("Counts")(n=1)
    envelope: Any = codec.message_class("Env")()
    envelope.counts.n = 1
    clash = codec.schema.message_class("Clash", lenient=True)(foo_bar=1)
    for why, attempt in (
        (_COUNTS, lambda: codec.encode(counts)),
        (_COUNTS, lambda: codec.encode(counts, "exact", timeout=1)),
        (_COUNTS, lambda: codec.encode(envelope)),
        (_COUNTS, lambda: codec.decode(b"\x12\x02\x08\x01")),  # what protobuf writes
        (_COUNTS, lambda: codec.decode(b"\x12\x03\x0a\x01\x01", strict=True)),  # nanopb's
        (_COUNTS, lambda: codec.payload_class("counts")),
        (_COUNTS, lambda: codec.message_class("counts")),
        (_CLASH, lambda: codec.encode(clash)),
        (_CLASH, lambda: codec.decode(b"\x1a\x02\x08\x01")),
        (_CLASH, lambda: codec.message_class("Clash")),
    ):
        with pytest.raises(SchemaError, match=why):
            attempt()
    assert codec.peek(b"\x12\x02\x08\x01") is None  # decode says why


def test_the_cli_sends_the_other_members_and_says_why_not_in_one_line() -> None:
    tree = ("--proto", str(UNSENDABLE), "--root", "Env")
    done = erc_codec_cli("encode", *tree, "fine", '{"x": 1}')
    assert (done.returncode, done.stdout) == (0, "0a020801\n"), done.stderr
    refused = erc_codec_cli("encode", *tree, "counts", '{"n": 1}')
    assert refused.returncode == 2
    assert re.fullmatch(rf"Error: \S*{_COUNTS}[^\n]*\n", refused.stderr), refused.stderr
    # A datagram of it is one that cannot be read, reported as every undecodable datagram is.
    unread = erc_codec_cli("decode", *tree, "12020801")
    assert unread.returncode == 1, unread.stderr
    record = json.loads(unread.stdout)
    assert (record["reason"], record["length"]) == ("unsupported", 4)
    assert re.search(_COUNTS, record["error"]), record


def test_a_delimited_member_or_one_holding_such_a_field() -> None:
    codec = Codec.from_path(UNSENDABLE, "EnvEd")
    sub: Any = codec.message_class("plain")(x=5)
    assert codec.decode(codec.encode(sub), strict=True) == ("plain", sub)
    holder: Any = codec.schema.message_class("Holder")()
    holder.inner.x = 1
    grouped: Any = codec.message_class("EnvEd")()
    grouped.grouped.x = 1
    for why, attempt in (
        (_HOLDER, lambda: codec.encode(holder)),
        (_HOLDER, lambda: codec.decode(b"\x1a\x04\x0a\x02\x08\x01")),  # nanopb's bytes
        (_GROUPED, lambda: codec.encode(grouped)),
        (_GROUPED, lambda: codec.decode(b"\x12\x02\x08\x01")),  # nanopb's: unknown to protobuf
        (_GROUPED, lambda: codec.decode(grouped.SerializeToString())),  # protobuf's group
    ):
        with pytest.raises(SchemaError, match=why):
            attempt()


def test_trouble_in_a_metadata_field_stops_the_whole_envelope() -> None:
    codec = Codec.from_path(UNSENDABLE, "EnvMeta")
    fine: Any = codec.schema.message_class("Fine")(x=1)
    for attempt in (
        lambda: codec.encode(fine),
        lambda: codec.encode(fine, "pad"),
        lambda: codec.decode(b"\x0a\x02\x08\x01"),
        lambda: codec.decode(b""),
        lambda: codec.payload_class("fine"),
    ):
        with pytest.raises(SchemaError, match=_SEQ):
            attempt()


# -- fields named as protobuf's Message methods: nanopb's sizes, no encoding or decoding --------

SHADOWING = TREES / "shadowing"
# root -> the field hiding a method, where it is and how it is reached (None: nothing hides)
_HIDDEN = {
    "Lister": r"shadow\.proto:6:\d+: Lister\.ListFields: the field ListFields hides protobuf's "
    r"Message\.ListFields in the Python runtime \(reached from Lister as Lister\.ListFields\)",
    "Described": r"shadow\.proto:10:\d+: Described\.DESCRIPTOR: the field DESCRIPTOR hides "
    r"protobuf's Message\.DESCRIPTOR",
    "Serial": r"shadow\.proto:14:\d+: Serial\.SerializePartialToString: the field "
    r"SerializePartialToString hides protobuf's Message\.SerializePartialToString",
    "Holder": r"Lister\.ListFields: the field ListFields hides .* \(reached from Holder as "
    r"Holder\.inner\.ListFields\)",
}


@pytest.fixture(scope="module")
def shadowing_sizes(tmp_path_factory: pytest.TempPathFactory) -> dict[str, int | None]:
    pytest.importorskip("nanopb")
    return generator_sizes(tmp_path_factory.mktemp("shadowing"), SHADOWING, ["shadow.proto"])


def test_a_name_erc_codec_asks_a_message_for_hides_it_and_no_other_does(tmp_path: Path) -> None:
    """A field named as a method erc-codec or json_format calls on a message (ListFields,
    DESCRIPTOR, ...) is refused with nanopb's size; a field named as any other public attribute
    of protobuf's Message or upb's classes (Clear, Extensions, SerializeToString, ...), or close
    to one, or private, is sent and read back in every form, strict, and as JSON."""
    from google.protobuf import message as protobuf_message

    hiding = [
        *("ClearField", "CopyFrom", "DESCRIPTOR", "HasField", "ListFields", "MergeFrom"),
        *("SerializePartialToString", "SetInParent", "WhichOneof"),
    ]
    upb = Codec.from_path(SHADOWING, "Fine").message_class("Fine")()
    public = {n for n in dir(protobuf_message.Message) if not n.startswith("_")}
    for upb_names in (dir(upb), dir(type(upb))):
        public |= {n for n in upb_names if not n.startswith("_") and not n.endswith("_NUMBER")}
    public -= {"list_fields", "Listfields", "Descriptor"}  # Fine's own fields
    others = sorted(public - set(hiding))
    assert {"Clear", "Extensions", "SerializeToString", "FromString", "ByteSize"} <= set(others)
    (tmp_path / "all.proto").write_text(
        'syntax = "proto3";\n'
        + "".join(f"message M{i} {{ int32 {name} = 1; }}\n" for i, name in enumerate(hiding))
        + "message Others {"
        + "".join(f" int32 {name} = {i};" for i, name in enumerate(others, 1))
        + " }\n"
        + "message Near { int32 listFields = 1; int32 DESCRIPTOR_ = 2; int32 Clear2 = 3;"
        + " int32 _fields = 4; int32 __init__ = 5; }\n"  # private names: upb looks them up first
    )
    for i, name in enumerate(hiding):
        codec = Codec.from_path(tmp_path, f"M{i}")
        assert codec.max_size(f"M{i}") == 11
        message = codec.schema.message_class(f"M{i}")()
        assert getattr(message, name) == 0  # the field, where the codec wants Message's method
        with pytest.raises(SchemaError, match=rf"M{i}\.{name}: the field {name} hides"):
            codec.encode(message)
    codec = Codec.from_path(tmp_path, "Others")
    sent = codec.message_class("Others")(**{name: i for i, name in enumerate(others, 1)})
    for mode in ("strip", "exact", "pad"):
        assert codec.decode(codec.encode(sent, mode), strict=True).message == sent
    assert codec.to_dict(sent) == {name: i for i, name in enumerate(others, 1)}
    near = Codec.from_path(tmp_path, "Near")
    message = near.message_class("Near")(listFields=1, DESCRIPTOR_=2, Clear2=3, **{"_fields": 4})
    assert near.decode(near.encode(message), strict=True).message == message
    assert near.decode(near.encode(message)).to_dict()["message"]["_fields"] == 4


@pytest.mark.parametrize("root", ["Lister", "Described", "Serial", "Ext", "Fine", "Holder"])
def test_a_field_hiding_a_method_keeps_nanopbs_size_and_is_refused_in_both_directions(
    shadowing_sizes: dict[str, int | None], root: str
) -> None:
    codec = Codec.from_path(SHADOWING, root)
    assert codec.max_size(root) == shadowing_sizes[root]
    assert codec.sizes() == shadowing_sizes
    message: Any = codec.schema.message_class(root)()
    data = b"\x08\x01" if root != "Holder" else b"\x0a\x02\x08\x01"
    if root == "Ext":  # Extensions: a public name, but none erc-codec asks a message for
        message.Extensions = 7
        assert codec.decode(codec.encode(message), strict=True) == ("Ext", message)
        return
    if root == "Fine":  # list_fields, Listfields and Descriptor hide nothing
        message.list_fields, message.Listfields, message.Descriptor = 1, 2, 3
        assert codec.decode(codec.encode(message), strict=True) == ("Fine", message)
        read: Any = codec.decode(b"\x08\x01", strict=True).message
        assert read.list_fields == 1
        decoded = codec.decode(codec.encode(message)).to_dict()["message"]
        assert decoded == {"list_fields": 1, "Listfields": 2, "Descriptor": 3}
        return
    why = _HIDDEN[root]
    for attempt in (
        lambda: codec.encode(message),
        lambda: codec.encode(message, "pad"),
        lambda: codec.payload_class(root),
    ):
        with pytest.raises(SchemaError, match=why):
            attempt()
    for strict in (False, True):
        with pytest.raises(DecodeError, match=why) as raised:
            codec.decode(data, strict=strict)
        assert isinstance(raised.value, SchemaError)
        assert raised.value.reason == "unsupported"
    assert codec.peek(data) is None


def test_an_envelope_sends_the_members_that_reach_no_hiding_field(
    shadowing_sizes: dict[str, int | None],
) -> None:
    codec = Codec.from_path(SHADOWING, "Env")
    assert (codec.max_size("Env"), codec.sizes()) == (shadowing_sizes["Env"], shadowing_sizes)
    fine: Any = codec.message_class("fine")(list_fields=7)
    assert codec.decode(codec.encode(fine, seq=3), strict=True) == ("fine", fine)
    holder: Any = codec.schema.message_class("Holder")()
    why = r"Lister\.ListFields: the field ListFields hides .* \(reached from Env as Env\.holder"
    with pytest.raises(SchemaError, match=why):
        codec.encode(holder)
    with pytest.raises(DecodeError, match=why):
        codec.decode(b"\x12\x04\x0a\x02\x08\x01", strict=True)
    # the envelope's own field hides WhichOneof: no member of it can be sent
    hides = Codec.from_path(SHADOWING, "EnvHides")
    assert hides.max_size("EnvHides") == shadowing_sizes["EnvHides"]
    fine = hides.schema.message_class("Fine")(list_fields=1)
    why = r"shadow\.proto:46:\d+: EnvHides\.WhichOneof: the field WhichOneof hides"
    with pytest.raises(SchemaError, match=why):
        hides.encode(fine)
    with pytest.raises(DecodeError, match=why):
        hides.decode(b"\x0a\x02\x08\x01", strict=True)


def test_debians_generator_sizes_the_hiding_fields_alike(
    shadowing_sizes: dict[str, int | None], tmp_path: Path
) -> None:
    program = shutil.which("nanopb_generator")
    if program is None:
        pytest.skip("Debian's nanopb generator is not installed")
    theirs = generator_sizes(tmp_path, SHADOWING, ["shadow.proto"], generator=[program])
    assert theirs == shadowing_sizes
    assert len(theirs) == 8


def test_the_cli_says_why_in_one_line_for_a_hiding_field() -> None:
    tree = ("--proto", str(SHADOWING), "--root", "Lister")
    refused = erc_codec_cli("encode", *tree, "Lister", '{"ListFields": 1}')
    assert refused.returncode == 2
    assert re.fullmatch(rf"Error: \S*{_HIDDEN['Lister']}[^\n]*\n", refused.stderr), refused.stderr
    for strict in ((), ("--strict",)):
        unread = erc_codec_cli("decode", *tree, *strict, "0801")
        assert unread.returncode == 1, unread.stderr
        assert "Traceback" not in unread.stderr
        record = json.loads(unread.stdout)
        assert (record["reason"], record["length"]) == ("unsupported", 2)
        assert re.search(_HIDDEN["Lister"], record["error"]), record
    sizes = erc_codec_cli("sizes", *tree, "--format", "json")
    assert sizes.returncode == 0, sizes.stderr
    assert json.loads(sizes.stdout)["max_size"] == 11


# -- a tree that ships nanopb.proto (and descriptor.proto) itself ---------------------------------


@pytest.mark.parametrize("where", ["nanopb.proto", "third_party/nanopb.proto"])
def test_a_shipped_nanopb_proto_is_no_part_of_the_listing(
    generator: None, tmp_path: Path, where: str
) -> None:
    """nanopb's generator is run on the tree's own files: NanoPBOptions and descriptor.proto's
    messages have no size it writes for the user, and none is listed, wherever the copy lies."""
    import nanopb
    from grpc_tools import _proto

    tree = tmp_path / "tree"
    vocabulary = Path(nanopb.__file__).parent / "generator" / "proto" / "nanopb.proto"
    (tree / where).parent.mkdir(parents=True)
    (tree / where).write_text(vocabulary.read_text())
    (tree / "google" / "protobuf").mkdir(parents=True)
    descriptor = Path(_proto.__path__[0]) / "google" / "protobuf" / "descriptor.proto"
    (tree / "google" / "protobuf" / "descriptor.proto").write_text(descriptor.read_text())
    (tree / "app.proto").write_text(
        f'syntax = "proto3";\nimport "{where}";\n'
        "message App { string name = 1 [(nanopb).max_size = 9]; uint32 id = 2; }\n"
    )
    out = tmp_path / "out"
    out.mkdir()
    theirs = generator_sizes(out, tree, ["app.proto"], "-I", ".")
    assert theirs == {"App": 16}
    codec = Codec.from_path(tree, "App")
    assert {proto.name for proto in codec.schema.files} >= {where, "app.proto"}
    assert codec.sizes() == theirs
    done = erc_codec_cli("sizes", "--proto", str(tree), "--root", "App", "--format", "json")
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["messages"] == theirs


# -- proto2 groups: where nanopb's generator refuses the file, no size ----------------------------

GROUPS = TREES / "groups"
_GROUP_FIELD = r"group\.proto:5:\d+: Holder\.item is a proto2 group, which nanopb's generator"
# Each file of the groups tree, the message to load it from, and nanopb 0.4.9.1's sizes for its
# messages, or (a str) where the generator fails on the file, NotImplementedError, and writes no
# header, what our SchemaError says why.
GROUP_FILES: dict[str, tuple[str, dict[str, int] | str]] = {
    "group.proto": ("Holder", _GROUP_FIELD),
    "imports.proto": ("Importer", rf"it imports group\.proto, and .*{_GROUP_FIELD}"),
    "extension.proto": ("Extended", r"extension\.proto: extension added is a proto2 group"),
    "ignored.proto": ("Ignoring", {"Ignoring": 11, "Ignoring.Item": 11}),
    "ignored_extension.proto": ("KeptExtended", {"KeptExtended": 11, "Spared": 11}),
    "skipped.proto": ("Kept", {"Skipped.Item": 11, "Kept": 11}),
    "deprecated.proto": ("Discarding", {"Discarding": 11, "Discarding.Old": 11}),
    "overridden.proto": ("Overriding", {"Overriding": 24, "Overriding.Item": 11}),
}


@pytest.mark.parametrize("file", sorted(GROUP_FILES))
def test_proto2_groups_size_as_nanopbs_generator_does(
    generator: None, tmp_path: Path, file: str
) -> None:
    root, expected = GROUP_FILES[file]
    command = [sys.executable, "-m", "nanopb.generator.nanopb_generator", "-q", "-I", "."]
    run = subprocess.run(
        [*command, "--error-on-unmatched", "-D", str(tmp_path), file],
        cwd=GROUPS,
        capture_output=True,
        text=True,
        check=False,
    )
    sizes = Sizes(load_schema(GROUPS, root))
    ours = sizes.all()  # every file loaded is the one named, or group.proto and it
    if isinstance(expected, str):
        assert run.returncode != 0
        assert "NotImplementedError: 10" in run.stderr  # 10: TYPE_GROUP
        assert ours == {}  # Unrelated too: there is no header
        with pytest.raises(SchemaError, match=rf"nanopb's generator refuses {file} \(.*{expected}"):
            sizes.max_size(root)
        refusal = sizes.refusal(root)  # erc-lint's words: no location in them
        assert refusal is not None
        assert refusal.startswith(f"nanopb's generator refuses {file}: ")
        assert refusal.endswith("is a proto2 group, which nanopb's generator does not implement")
        assert not re.search(r"\.proto:\d", refusal)
        with pytest.raises(SchemaError, match=rf"refuses {file}"):
            Codec.from_path(GROUPS, root)
    else:
        assert run.returncode == 0, run.stderr
        assert sizes.refusal(root) is None
        header = (tmp_path / file).with_suffix(".pb.h").read_text()
        theirs = {c.replace("_", "."): int(size) for c, size in _DEFINE.findall(header)}
        assert ours == theirs == expected
        if file != "overridden.proto":
            assert Codec.from_path(GROUPS, root).max_size(root) == 11
            return
        # nanopb writes the group as a length-prefixed message: no bytes are right for both, so
        # the codec has nanopb's size and refuses to encode or decode
        codec = Codec.from_path(GROUPS, root)
        assert codec.max_size(root) == theirs[root]
        message: Any = codec.schema.message_class(root)()
        message.item.x = 1
        for attempt in (lambda: codec.encode(message), lambda: codec.decode(b"\x0a\x02\x08\x01")):
            with pytest.raises(
                SchemaError, match=r"Overriding\.item: protobuf writes it delimited"
            ):
                attempt()


# -- an enum or message type_override of a field of no such type: the generator fails ------------

OVERRIDES = TREES / "typeoverrides"
_FLAG = (
    r"enum\.proto:8:\d+: Flag\.on is declared BOOL with type_override ENUM: it has no enum type, "
    r"and nanopb's generator cannot generate it"
)
# root -> its file, and what nanopb's generator (0.4.9.1) says refusing it, and what we say
TYPE_OVERRIDES = {
    "Flag": ("enum.proto", "IndexError: string index out of range", _FLAG),
    "Beside": ("enum.proto", "IndexError: string index out of range", _FLAG),
    "AsEnum": (
        "submessage.proto",
        "Expected enum type as Sub, got Message(Sub)",
        r"submessage\.proto:11:\d+: AsEnum\.s is declared MESSAGE with type_override ENUM: it "
        r"has no enum type",
    ),
    "Number": (
        "message.proto",
        "IndexError: string index out of range",
        r"message\.proto:7:\d+: Number\.n is declared INT32 with type_override MESSAGE: it has no "
        r"message type",
    ),
    "Toned": (
        "enum_message.proto",
        "TypeError: Enum.encoded_size()",
        r"enum_message\.proto:12:\d+: Toned\.t is declared ENUM with type_override MESSAGE",
    ),
    "Uses": (
        "importer.proto",
        "IndexError: string index out of range",
        rf"it imports enum\.proto, and .*{_FLAG}",
    ),
}


@pytest.mark.parametrize("root", sorted(TYPE_OVERRIDES))
def test_a_type_override_the_generator_fails_on_is_a_schema_error_naming_the_field(
    generator: None, tmp_path: Path, root: str
) -> None:
    file, theirs, ours = TYPE_OVERRIDES[root]
    run = subprocess.run(
        [*_PYPI_GENERATOR, "-q", "-I", ".", "-D", str(tmp_path), file],
        cwd=OVERRIDES,
        capture_output=True,
        text=True,
        check=False,
    )
    assert run.returncode != 0
    assert theirs in run.stderr, run.stderr
    assert not (tmp_path / file).with_suffix(".pb.h").exists()
    sizes = Sizes(load_schema(OVERRIDES, root))
    assert sizes.all() == {}  # the generator writes no header
    refuses = rf"nanopb's generator refuses {re.escape(file)} \(.*{ours}.*\)"
    why = rf"{refuses}: it writes no code for {root}"
    with pytest.raises(SchemaError, match=why):
        sizes.max_size(root)
    with pytest.raises(SchemaError, match=why):
        Codec.from_path(OVERRIDES, root)
    done = erc_codec_cli("sizes", "--proto", str(OVERRIDES), "--root", root)
    assert done.returncode == 2
    assert re.fullmatch(rf"Error: {why}[^\n]*\n", done.stderr), done.stderr


def test_the_same_overrides_on_what_the_generator_leaves_out_are_sized(
    generator: None, tmp_path: Path
) -> None:
    """FT_IGNORE, a deprecated field under discard_deprecated and skip_message spare the file."""
    theirs = generator_sizes(tmp_path, OVERRIDES, ["spared.proto"])
    assert theirs == {"Spared": 11}
    codec = Codec.from_path(OVERRIDES, "Spared")
    assert (codec.max_size("Spared"), codec.sizes()) == (11, theirs)
    message: Any = codec.message_class("Spared")(k=-1)
    assert codec.decode(codec.encode(message), strict=True).message == message


# -- a root nanopb's generator writes no code for: no size, no codec ------------------------------

UNGENERATED = TREES / "ungenerated"
_NO_CODE = {
    "D": r"deprecated\.proto:9:1: nanopb generates no code for D \(it is deprecated, under "
    r"discard_deprecated\), so no size",
    "D.DmEntry": r"deprecated\.proto:9:1: nanopb generates no code for D\.DmEntry \(the entry "
    r"type of a map in D, which it generates no code for\), so no size",
    "S": r"deprecated\.proto:15:1: nanopb generates no code for S \(it has skip_message\), so no "
    r"size",
    "Skipped": r"spared\.proto:14:1: nanopb generates no code for Skipped \(it has skip_message\)",
}


@pytest.mark.parametrize("root", sorted(_NO_CODE))
def test_a_root_nanopb_generates_no_code_for_is_a_schema_error(
    generator: None, tmp_path: Path, root: str
) -> None:
    tree = OVERRIDES if root == "Skipped" else UNGENERATED
    file = "spared.proto" if root == "Skipped" else "deprecated.proto"
    theirs = generator_sizes(tmp_path, tree, [file])
    assert root not in theirs
    assert theirs == ({"Spared": 11} if root == "Skipped" else {"Kept": 11})
    sizes = Sizes(load_schema(tree, root))
    assert sizes.all() == theirs
    with pytest.raises(SchemaError, match=_NO_CODE[root]):
        sizes.max_size(root)
    with pytest.raises(SchemaError, match=_NO_CODE[root]):
        Codec.from_path(tree, root)
    done = erc_codec_cli("sizes", "--proto", str(tree), "--root", root)
    assert done.returncode == 2
    assert re.fullmatch(rf"Error: \S*{_NO_CODE[root]}[^\n]*\n", done.stderr), done.stderr
    encoded = erc_codec_cli("encode", "--proto", str(tree), "--root", root, root, "{}")
    assert encoded.returncode == 2
    assert re.fullmatch(rf"Error: \S*{_NO_CODE[root]}[^\n]*\n", encoded.stderr), encoded.stderr


def test_the_generated_message_beside_them_is_a_codec(generator: None, tmp_path: Path) -> None:
    theirs = generator_sizes(tmp_path, UNGENERATED, ["deprecated.proto"])
    codec = Codec.from_path(UNGENERATED, "Kept")
    assert (codec.max_size("Kept"), codec.sizes()) == (11, theirs)


def _chain(tree: Path, fields: int) -> None:
    """M0 holding M1 ... holding M{fields}, the last an int32: ``fields`` message fields deep."""
    lines = [f"message M{i} {{ M{i + 1} next = 1; }}" for i in range(fields)]
    (tree / "deep.proto").write_text(
        'syntax = "proto3";\n' + "\n".join(lines) + f"\nmessage M{fields} {{ int32 x = 1; }}\n"
    )


def test_nesting_as_deep_as_protobuf_decodes_round_trips(tmp_path: Path) -> None:
    _chain(tmp_path, 100)
    codec = Codec.from_path(tmp_path, "M0")
    message: Any = codec.message_class("M0")()
    inner = message
    for _ in range(100):
        inner = inner.next
    inner.x = -1
    assert codec.decode(codec.encode(message)).message == message


def test_nesting_deeper_than_protobuf_decodes_is_refused_at_load(tmp_path: Path) -> None:
    """101 message fields deep: nanopb sizes (and decodes) it, protobuf's runtime cannot decode
    it ("Exceeded upb_DecodeOptions_MaxDepth"), so the codec would send what it cannot read."""
    _chain(tmp_path, 101)
    assert Sizes(load_schema(tmp_path, "M0")).max_size("M101") == 11
    pattern = (
        r"deep\.proto:102:\d+: M0 nests messages too deeply for protobuf's Python runtime to "
        r"decode: M0\.next\.next\.next\.\(\.\.\. 96 more \.\.\.\)\.next\.next is 101 messages "
        r"deep, it decodes at most 100"
    )
    with pytest.raises(SchemaError, match=pattern):
        Codec.from_path(tmp_path, "M0")
    assert Codec.from_path(tmp_path, "M1").max_size("M101") == 11  # 100 deep from M1


def test_nesting_deeper_than_python_recurses(tmp_path: Path) -> None:
    """700 messages, each holding the next: sized without recursion; the runtime cannot build
    the class (nanopb's own generator, recursive too, gives up on it)."""
    depth = 700
    lines = [f"message M{i} {{ M{i + 1} next = 1; }}" for i in range(depth - 1)]
    (tmp_path / "deep.proto").write_text(
        'syntax = "proto3";\n' + "\n".join(lines) + f"\nmessage M{depth - 1} {{ int32 x = 1; }}\n"
    )
    sizes = Sizes(load_schema(tmp_path, "M0"))
    assert sizes.max_size(f"M{depth - 1}") == 11
    expected = 11
    for _ in range(depth - 1):
        expected += 1 + (expected.bit_length() + 6) // 7
    assert sizes.max_size("M0") == expected
    sizes.require_fixed(load_schema(tmp_path, "M0").root)
    with pytest.raises(SchemaError, match=r"M0 nests messages too deeply"):
        Codec.from_path(tmp_path, "M0")


def test_default_codec_is_unchanged() -> None:
    assert type(erc_codec.Codec.default()) is erc_codec.EnvelopeCodec


def test_each_codec_is_one_root_handler_and_the_codecs_schema_half() -> None:
    """No diamond: a ``MessageCodec`` is no ``Envelope``, and ``Codec(schema)`` is the envelope
    codec, as before."""
    from erc_codec.codec._envelope import Envelope
    from erc_codec.codec._plain import Plain

    envelope = erc_codec.Codec.default()
    plain = Codec.from_path(TREES / "rules", "Probe")
    assert [isinstance(envelope, base) for base in (Codec, Envelope, Plain)] == [True, True, False]
    assert [isinstance(plain, base) for base in (Codec, Envelope, Plain)] == [True, False, True]
    assert type(Codec(envelope.schema)) is erc_codec.EnvelopeCodec
    with pytest.raises(TypeError, match="Mine: a codec is an EnvelopeCodec or a MessageCodec"):

        class Mine(Codec):  # no root handler: it could encode nothing
            pass

    class Yours(erc_codec.EnvelopeCodec):
        pass

    assert Yours(envelope.schema).encode(envelope.message_class("drive_motor")()) == b"\x4a"


# -- the command line ----------------------------------------------------------------------------


def erc_codec_cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "erc_codec", *args], capture_output=True, text=True, check=False
    )


def test_the_cli_encodes_and_decodes_a_plain_root() -> None:
    tree = ("--proto", str(TREES / "rules"), "--root", "Probe")
    done = erc_codec_cli("encode", *tree, "Probe", '{"key": "YWJjZA==", "quad": [1, 2, 3, 4]}')
    assert done.returncode == 0, done.stderr
    datagram = done.stdout.strip()
    assert datagram == "0a0461626364121001000000020000000300000004"  # stripped: 3 zeros fewer
    decoded = erc_codec_cli("decode", *tree, datagram)
    assert decoded.returncode == 0, decoded.stderr
    assert '"kind": "Probe"' in decoded.stdout
    assert '"quad": [1, 2, 3, 4]' in decoded.stdout
    refused = erc_codec_cli("encode", *tree, "Probe", '{"quad": [1, 2, 3, 4]}')
    assert refused.returncode == 1
    assert refused.stderr == "Error: Probe.key is 0 bytes long; fixed_length needs exactly 4\n"
    wrong = erc_codec_cli("encode", *tree, "probe", "{}")
    assert wrong.returncode == 2
    assert "Probe has no members: it is a plain message, KIND Probe" in wrong.stderr
    sizes = erc_codec_cli("sizes", *tree)
    assert re.search(r"^\s+Probe\.Inner\s+5$", sizes.stdout, re.MULTILINE), sizes.stdout


def test_a_plain_root_tells_a_cut_datagram_from_a_stripped_one(plain: MessageCodec) -> None:
    probe: Any = plain.message_class("Probe")(key=b"abcd", quad=[1, 2, 3, 4])
    probe.inner.a = 0x80  # its varint ends in 80 01: cut after the 80, it reads as cut
    exact = plain.encode(probe, "exact")
    with pytest.raises(DecodeError, match=r"cut short: .* in Probe\.inner\.a continues a varint"):
        plain.decode(exact[:-1])
    assert plain.peek(exact[:-1]) is None  # no exact form: its restored zeros were never sent
    assert plain.decode(cast(bytes, memoryview(exact))) == ("Probe", probe)  # any bytes-like
    with pytest.raises(TypeError, match="not str"):
        plain.decode(exact.hex())  # type: ignore[arg-type]


MAPS_NANOPB_DROPS = """syntax = "proto3";
message A { map<int32, int32> m = 1; int32 x = 2; }
message B { map<int32, int32> n = 2; }
message C { map<int32, int32> k = 3; }
"""


@pytest.mark.parametrize("discard", [True, False])
def test_map_entries_are_listed_where_nanopb_generates_them(
    generator: None, tmp_path: Path, discard: bool
) -> None:
    """discard_unused_automatic_types (on by default): no entry type for an ignored map field,
    nor for one in a skipped message; with it off, every entry, as nanopb writes them."""
    tree = tmp_path / "tree"
    tree.mkdir()
    (tree / "maps.proto").write_text(MAPS_NANOPB_DROPS)
    options = "A.m type:FT_IGNORE\nB skip_message:true\nC.k max_count:2\n"
    if not discard:
        options += "* discard_unused_automatic_types:false\n"
    (tree / "maps.options").write_text(options)
    out = tmp_path / "out"
    out.mkdir()
    theirs = generator_sizes(out, tree, ["maps.proto"])
    ours = erc_codec.Codec.from_path(tree, root="A").sizes()
    assert ours == theirs
    assert ("A.MEntry" in ours) is not discard


def test_a_dispatcher_counts_a_member_nobody_can_read_and_handles_the_others() -> None:
    """Its datagrams end in the "unsupported" counter (not an exception out of feed), and a
    handler for it is refused, saying why."""
    codec = Codec.from_path(UNSENDABLE, "Env")
    drops: list[erc_codec.runtime.Drop] = []
    dispatcher = erc_codec.runtime.Dispatcher(codec, on_drop=drops.append)
    handled: list[Any] = []
    dispatcher.register("fine", handled.append)
    with pytest.raises(SchemaError, match=_COUNTS):
        dispatcher.register("counts", handled.append)
    assert not dispatcher.feed(bytes.fromhex("12020801"))
    assert dispatcher.feed(bytes.fromhex("0a020801"))
    stats = dispatcher.stats()
    assert (stats.undecodable, stats.handled) == ({"unsupported": 1}, {"fine": 1})
    assert handled[0].x == 1
    # the drop names the member its error knows, as a decoded datagram's drop would
    ((drop,),) = [drops]
    assert (drop.reason, drop.kind, drop.data.hex()) == ("unsupported", "counts", "12020801")
    assert isinstance(drop.error, SchemaError)
    assert isinstance(drop.error, erc_codec.DecodeError)


_EXTENSION_TYPE = re.compile(r"pb_extension_type_t (\w+); /\* field type: char \w+\[(\d+)\]; \*/")


def test_extension_options_resolve_as_nanopbs_generator_resolves_them(
    generator: None, tmp_path: Path
) -> None:
    """An extension starts from its file's options and is matched as its full name (``pk.ex``,
    ``pk.R.inner``; not its own name): the storage the generator writes for each agrees."""
    tree = tmp_path / "tree"
    tree.mkdir()
    (tree / "e.proto").write_text(
        'syntax = "proto2";\nimport "nanopb.proto";\npackage pk;\n'
        "option (nanopb_fileopt).max_size = 3;\n"
        "message R {\n  extensions 100 to 110;\n"
        "  extend R { optional string inner = 101; optional string plain = 102; }\n}\n"
        "extend R {\n  optional string ex = 100 [(nanopb).max_size = 10];\n"
        "  optional string other = 103;\n}\n"
    )
    (tree / "e.options").write_text(
        "ex max_size:7\npk.ex max_size:8\npk.R.inner max_size:9\nR.plain max_size:4\n"
        "pk.other max_size:6\n"
    )
    out = tmp_path / "out"
    out.mkdir()
    command = [sys.executable, "-m", "nanopb.generator.nanopb_generator", "-q", "-D", str(out)]
    subprocess.run([*command, "e.proto"], cwd=tree, check=True)
    header = (out / "e.pb.h").read_text()
    theirs = {c: int(size) for c, size in _EXTENSION_TYPE.findall(header)}
    files = compile_files(tree, ["e.proto"]).file
    resolved = resolve_options(tree, files)
    ours = {
        name.replace(".", "_"): int(options.max_size)
        for name, options in resolved.extensions.items()
        if name.startswith("pk.")  # not nanopb.proto's own
    }
    assert ours == theirs == {"pk_ex": 10, "pk_R_inner": 9, "pk_R_plain": 3, "pk_other": 6}


# -- a max_size that leaves no room for any value ------------------------------------------------


@pytest.mark.parametrize("syntax", ["proto3", "proto2"])
@pytest.mark.parametrize(
    ("kind", "written", "size"),
    [
        ("string", "[(nanopb).max_size = 0]", 12),  # 1 + (1 + 0 - 1), + 11 for b
        ("string", "[(nanopb).max_size = -1]", 20),  # varint(-1) is ten bytes: 1 + (10 - 1 - 1)
        ("string", "[(nanopb).max_length = -1]", 12),  # max_size 0
        ("string", "-s max_size=0", 12),
        ("bytes", "[(nanopb).max_size = -1]", 21),
    ],
)
def test_a_max_size_with_no_room_for_any_value_is_sized_as_the_generator_does_and_never_sent(
    generator: None, tmp_path: Path, syntax: str, kind: str, written: str, size: int
) -> None:
    """nanopb's generator takes the option as given (no error, no callback): ``char a[0]``, whose
    encoder answers "zero-length string" and decoder "string overflow" to any value, or an
    array of negative size no compiler takes. The field has nanopb's size and is never sent;
    a message without it is sent and received as any other."""
    label = "optional " if syntax == "proto2" else ""
    option, dash_s = ("", [written[3:]]) if written.startswith("-s") else (written, [])
    (tmp_path / "s.proto").write_text(
        f'syntax = "{syntax}";\nimport "nanopb.proto";\n'
        f"message S {{ {label}{kind} a = 1 {option}; {label}int32 b = 2; }}\n"
    )
    out = tmp_path / "out"
    out.mkdir()
    theirs = generator_sizes(out, tmp_path, ["s.proto"], *(f"-s{s}" for s in dash_s))
    codec = Codec.from_path(tmp_path, "S", settings=dash_s)
    assert codec.sizes() == theirs == {"S": size}
    s: Any = codec.message_class("S")
    assert codec.decode(codec.encode(s(b=1)), strict=True) == ("S", s(b=1))
    values: list[str | bytes] = ["x", ""] if kind == "string" else [b"x", b""]
    if syntax == "proto3":
        values.pop()  # protobuf sends no empty proto3 value
    for sent in (s(a=value) for value in values):
        with pytest.raises(
            EncodeError, match=r"^S\.a cannot be sent: nanopb's max_size -?\d+ leaves no"
        ):
            codec.encode(sent)
        with pytest.raises(DecodeError, match=r"S\.a arrived, but its max_size leaves"):
            codec.decode(sent.SerializeToString(), strict=True)

    @given(message=strategies.messages(codec, "S"))
    @settings(max_examples=30, database=None)
    def never_drawn(message: Any) -> None:
        assert not message.HasField("a") if syntax == "proto2" else not message.a
        assert codec.decode(codec.encode(message), strict=True) == ("S", message)

    never_drawn()
