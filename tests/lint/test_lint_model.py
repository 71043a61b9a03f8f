"""erc_lint's model of a revision: what nanopb sizes a root from, and its size; what each field and
enum means on the wire, in every syntax, as the protobuf runtime reads it."""

import itertools
from pathlib import Path

import pytest
from git_support import HEADER
from google.protobuf import descriptor_pool, message_factory
from google.protobuf.descriptor import FieldDescriptor
from google.protobuf.descriptor_pb2 import FeatureSet, FieldOptions
from google.protobuf.message import DecodeError
from lint_support import READING, protoc_edition, tree

import erc_lint
from erc_lint._loader import load_tree
from erc_lint._model import Field, build
from erc_schema import Sizes, load_schema, options_class


@pytest.mark.parametrize(
    ("edit", "same"),
    [
        (("reading.options", "16", "32"), False),
        (("reading.proto", "MODE_RUN = 1;", "MODE_RUN = 1; MODE_BACK = -1;"), False),
        (("reading.proto", " [(nanopb).int_size = IS_8]", ""), False),
        (("reading.proto", "uint32 count", "int32 count"), False),
        (("envelope.proto", "Reading reading = 1;", "Reading reading = 1; Mode m = 2;"), False),
        (("reading.proto", "MODE_IDLE = 0;", "MODE_IDLE = 0; // idle\n"), True),
        (("reading.proto", "  Mode mode = 2;\n", "\n\n  Mode   mode = 2;  // moved\n"), True),
    ],
)
def test_equal_size_inputs_mean_equal_sizes(
    tmp_path: Path, edit: tuple[str, str, str], same: bool
) -> None:
    """ENVELOPE_SIZE_GROWN compares what nanopb sizes the root from before it computes sizes
    (bench_lint's 30-file ratio): that shortcut must agree with comparing the sizes."""
    name, before, after = edit
    changed = {**READING, name: READING[name].replace(before, after)}
    revisions = []
    for side, files in (("old", READING), ("new", changed)):
        root = tree(tmp_path / side, files)
        (root / "reading.options").write_text(files["reading.options"])
        revisions.append(build(load_tree(root)))
    old, new = revisions
    assert (dict(old.size_inputs("PBEnvelope")) == dict(new.size_inputs("PBEnvelope"))) == same
    sizes = (old.max_size("PBEnvelope"), new.max_size("PBEnvelope"))
    assert None not in sizes
    if same:
        assert sizes[0] == sizes[1]


# A proto2 file holding a group, imported by the envelope without being reached from it: the
# generator refuses the envelope's file for it.
_GROUPED = (
    'syntax = "proto2";\n'
    "message Legacy {\n  optional group Item = 1 {\n    optional int32 x = 1;\n  }\n}\n"
)
_WITH_GROUPS = {**READING, "envelope.proto": 'import "legacy.proto";\n' + READING["envelope.proto"]}
_SIZE_VARIANTS: dict[str, dict[str, str]] = {
    "plain": READING,
    "options": {**READING, "reading.options": "Reading.label max_size:32\n"},
    "comment": {**READING, "reading.proto": READING["reading.proto"] + "// the end\n"},
    "int_type": {**READING, "reading.proto": READING["reading.proto"].replace("uint32", "int32")},
    "extra_import": {
        **READING,
        "envelope.proto": 'import "other.proto";\n' + READING["envelope.proto"],
        "other.proto": "message Other { string s = 1; }\n",
    },
    "grouped": {**_WITH_GROUPS, "legacy.proto": _GROUPED},
    "grouped_commented": {**_WITH_GROUPS, "legacy.proto": _GROUPED + "// the end\n"},
    "grouped_changed": {**_WITH_GROUPS, "legacy.proto": _GROUPED.replace("int32 x", "int64 x")},
    "grouped_no_more": {
        **_WITH_GROUPS,
        "legacy.proto": _GROUPED.replace("optional group Item = 1 {", "message Item {").replace(
            "  }\n}", "  }\n  optional Item item = 1;\n}"
        ),
    },
}


def test_same_size_inputs_is_the_plain_comparison(tmp_path: Path) -> None:
    """ENVELOPE_SIZE_GROWN's early-exit comparison (bench_lint's proto2+editions ratio) answers
    as comparing every input would, for every pair of these revisions."""
    revisions = []
    for name, files in _SIZE_VARIANTS.items():
        root = tmp_path / name
        root.mkdir()
        for path, text in files.items():
            plain = text.startswith("syntax") or path.endswith(".options")
            (root / path).write_text(text if plain else HEADER + text)
        revision = build(load_tree(root))
        assert not revision.problems, name
        revisions.append(revision)
    same = set()
    for old in revisions:
        for new in revisions:
            plain = dict(old.size_inputs("PBEnvelope")) == dict(new.size_inputs("PBEnvelope"))
            assert old.same_size_inputs(new, "PBEnvelope") == plain, (old.root.name, new.root.name)
            if plain and old is not new:
                same.add(frozenset((old.root.name, new.root.name)))
    # another file imported, holding no type the root reaches and no group, is no input
    alike = [
        ("plain", "comment", "extra_import", "grouped_no_more"),
        ("grouped", "grouped_commented"),
    ]
    assert same == {frozenset(pair) for names in alike for pair in itertools.combinations(names, 2)}


def test_a_roots_size_is_computed_once_per_revision(tmp_path: Path) -> None:
    """NANOPB_LIMIT_WIDENED asks a root's size for every finding: the revision answers from its
    first computation (the same number the plain computation gives), never from files read
    again."""
    root = tree(tmp_path, READING)
    options = root / "reading.options"
    options.write_text(READING["reading.options"])
    revision = build(load_tree(root))
    plain = Sizes(load_schema(root, "PBEnvelope")).max_size("PBEnvelope")
    assert revision.max_size("PBEnvelope") == plain == 26
    options.write_text("Reading.label max_size:200\n")  # would change a fresh computation
    assert revision.max_size("PBEnvelope") == plain
    assert build(load_tree(root)).max_size("PBEnvelope") != plain


def test_a_root_at_the_end_of_a_long_import_chain_is_sized(tmp_path: Path) -> None:
    """The files a root's size is computed from are gathered without recursion: a chain of
    imports longer than Python's recursion limit was an internal error (exit 2)."""
    chain = 1100  # files, each importing the one before
    files = {
        f"c{i}.proto": (f'import "c{i - 1}.proto";\n' if i else "") + f"message C{i} {{}}\n"
        for i in range(chain)
    }
    envelope = (
        f'import "c{chain - 1}.proto";\nmessage PBEnvelope {{ oneof p {{ C{chain - 1} c = 1; }}'
    )
    old = tree(tmp_path / "old", {**files, "env.proto": envelope + " }\n"})
    new = tree(tmp_path / "new", {**files, "env.proto": envelope + " int32 y = 2; }\n"})
    assert [f.text.split(":")[0] for f in erc_lint.lint(old, new)] == [
        'Maximum size of message "PBEnvelope" grew from 2 to 13 bytes'
    ]


# Every construct whose meaning on the wire a feature decides, in each syntax protoc compiles.
FEATURES = {
    "legacy2.proto": 'syntax = "proto2";\n'
    "enum Closed2 { C2_A = 0; C2_B = 1; }\n"
    "message Sub2 { optional int32 x = 1; }\n"
    "message All2 {\n"
    "  required int32 req = 1;\n  optional int32 opt = 2 [default = 4];\n"
    "  repeated int32 plain = 3;\n  repeated int32 packed = 4 [packed = true];\n"
    "  optional group Grp = 5 { optional int32 y = 1; }\n  optional Sub2 sub = 6;\n"
    "  optional Closed2 e = 7;\n  optional string s = 8;\n  map<string, Sub2> m = 9;\n"
    "  oneof o { int32 oa = 10; string ob = 11; }\n"
    "  extensions 100 to 199;\n}\n"
    "message Scope2 { extend All2 { optional Sub2 ext_sub = 100; repeated string ext_s = 101; } }\n"
    "extend All2 { optional group ExtGrp = 102 { optional int32 z = 1; } }\n",
    "legacy3.proto": 'syntax = "proto3";\nimport "legacy2.proto";\n'
    "enum Open3 { O3_A = 0; O3_B = 1; }\n"
    "message All3 {\n"
    "  int32 implicit = 1;\n  optional int32 explicit = 2;\n  repeated int32 packed = 3;\n"
    "  repeated int32 plain = 4 [packed = false];\n  Open3 e = 5;\n  string s = 6;\n"
    "  Sub2 sub = 7;\n  oneof o { string oa = 8; Sub2 ob = 9; }\n  map<int32, string> m = 10;\n}\n",
    "ed2023.proto": 'edition = "2023";\nimport "legacy2.proto";\n'
    "option features.field_presence = IMPLICIT;\n"
    "option features.enum_type = CLOSED;\n"
    "option features.message_encoding = DELIMITED;\n"
    "option features.utf8_validation = NONE;\n"
    "enum Closed23 { C23_A = 0; C23_B = 1; }\n"
    "enum Open23 { option features.enum_type = OPEN; O23_A = 0; O23_B = 1; }\n"
    "message Inner23 { int32 v = 1; }\n"
    "message All23 {\n"
    "  int32 implicit = 1;\n"
    "  int32 req = 2 [features.field_presence = LEGACY_REQUIRED];\n"
    "  int32 explicit = 3 [features.field_presence = EXPLICIT];\n"
    "  Inner23 delimited = 4;\n"
    "  Inner23 prefixed = 5 [features.message_encoding = LENGTH_PREFIXED];\n"
    "  repeated int32 packed = 6;\n"
    "  repeated int32 plain = 7 [features.repeated_field_encoding = EXPANDED];\n"
    "  Closed23 closed = 8 [features.field_presence = EXPLICIT];\n  Open23 open = 9;\n"
    "  string unchecked = 10;\n  string checked = 11 [features.utf8_validation = VERIFY];\n"
    "  map<string, Inner23> m = 12;\n"
    "  oneof o { Inner23 oa = 13; string ob = 14; }\n"
    "  message Nested { Inner23 deep = 1; string s = 2; }\n  Nested nested = 15;\n"
    "  extensions 100 to 199;\n}\n"
    "extend All23 { Inner23 ext_delimited = 100; int32 ext_i = 101; }\n"
    "extend All2 { Inner23 ext_in_2 = 150; }\n",
    "ed2024.proto": 'edition = "2024";\nimport "ed2023.proto";\n'
    "enum Open24 { O24_A = 0; }\n"
    "message All24 {\n  int32 explicit = 1;\n  Inner23 sub = 2;\n  string s = 3;\n"
    "  int32 req = 4 [features.field_presence = LEGACY_REQUIRED];\n  Open24 e = 5;\n"
    "  Closed23 closed = 6;\n}\n",
}


def compiled_features() -> dict[str, str]:
    """FEATURES without its edition 2024 file where the bundled protoc stops at 2023 (the
    protobuf floor's grpcio-tools 1.74)."""
    if protoc_edition() >= 2024:
        return FEATURES
    return {name: text for name, text in FEATURES.items() if name != "ed2024.proto"}


def test_features_resolve_as_a_descriptor_pool_resolves_them(tmp_path: Path) -> None:
    """The model's reading of every field, extension and enum (required, delimited, closed,
    UTF-8 checked) is the protobuf runtime's: its descriptor pool (``is_required``, a delimited
    field's ``TYPE_GROUP``, ``is_closed``) and its parser (a string it validates refuses bytes
    that are not UTF-8)."""
    root = tmp_path / "t"
    for name, text in compiled_features().items():
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_text(text)
    loaded = load_tree(root)
    assert loaded.problems == []
    revision = build(loaded)
    pool = descriptor_pool.DescriptorPool()
    for proto in loaded.imported.values():
        pool.Add(proto)
    fields = [f for m in revision.messages.values() for f in m.fields.values()]
    extensions = [f for m in revision.messages.values() for f in m.extensions.values()]
    assert len(extensions) == 6
    seen = set()
    for field in fields + extensions:
        if field.extension:
            descriptor = pool.FindExtensionByName(field.name)
        else:
            descriptor = pool.FindMessageTypeByName(field.owner).fields_by_number[field.number]
        assert (field.cardinality == "required") == descriptor.is_required, field
        assert field.delimited == (descriptor.type == FieldDescriptor.TYPE_GROUP), field
        seen.add((field.cardinality, field.delimited))
        if field.type == "string" and not field.extension:
            owner = message_factory.GetMessageClass(pool.FindMessageTypeByName(field.owner))
            tag = bytes([field.number << 3 | 2]) if field.number < 16 else b""
            if tag:
                data = tag + b"\x02\xff\xfe"
                try:
                    owner.FromString(data)
                    verified = False
                except DecodeError:
                    verified = True
                assert field.utf8 == verified, field
                seen.add(("utf8", field.utf8))
    for enum in revision.enums.values():
        assert enum.closed == pool.FindEnumTypeByName(enum.name).is_closed, enum.name
        seen.add(("closed", enum.closed))
    # Each reading is met both ways, so the comparison above can fail.
    assert {("required", False), ("optional", True), ("optional", False)} <= seen
    assert {("utf8", True), ("utf8", False), ("closed", True), ("closed", False)} <= seen


def test_fields_made_with_tuple_new_are_those_field_makes(tmp_path: Path) -> None:
    """The model makes its fields with ``tuple.__new__`` (bench_lint's ratio to buf): each is the
    Field that ``Field(...)`` makes of its members, none missing, fields and extensions alike."""
    root = tmp_path / "t"
    for name, text in compiled_features().items():
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_text(text)
    revision = build(load_tree(root))
    messages = [*revision.messages.values(), *revision.extended.values()]
    made = [f for m in messages for f in (*m.fields.values(), *m.extensions.values())]
    assert any(f.extension for f in made)
    assert any(not f.extension for f in made)
    for field in made:
        assert type(field) is Field
        assert Field(**field._asdict()) == field
        assert len(field) == len(Field._fields)


def test_a_tree_mixing_syntaxes_is_compared_completely(tmp_path: Path) -> None:
    """proto2, proto3 and editions 2023 and 2024 files importing one another load together, and
    a change in each is found."""
    old = tmp_path / "old"
    for name, text in compiled_features().items():
        (old / name).parent.mkdir(parents=True, exist_ok=True)
        (old / name).write_text(text)
    edits = {
        "legacy2.proto": ("optional int32 opt = 2 [default = 4];", "optional int32 opt = 2;"),
        "legacy3.proto": ("  Open3 e = 5;\n", ""),
        "ed2023.proto": (
            "  Inner23 delimited = 4;\n",
            "  Inner23 delimited = 4 [features.message_encoding = LENGTH_PREFIXED];\n",
        ),
        "ed2024.proto": (
            "int32 req = 4 [features.field_presence = LEGACY_REQUIRED]",
            "int32 req = 4",
        ),
    }
    new = tmp_path / "new"
    new.mkdir()
    for name, text in compiled_features().items():
        before, after = edits[name]
        assert before in text
        (new / name).write_text(text.replace(before, after))
    assert erc_lint.lint(old, old) == []
    found = [(Path(f.path).name, f.rule) for f in erc_lint.lint(old, new)]
    expected = [
        ("ed2023.proto", "FIELD_ENCODING_CHANGED"),
        ("ed2024.proto", "REQUIRED_FIELD_REMOVED"),
        ("legacy2.proto", "FIELD_DEFAULT_CHANGED"),
        ("legacy3.proto", "FIELD_DELETED"),
    ]
    assert found == [f for f in expected if f[0] in compiled_features()], found


def test_the_wire_features_are_set_on_files_fields_and_enums_only() -> None:
    """The model merges a file's features with a field's or an enum's own, skipping messages and
    oneofs, because descriptor.proto allows these features nowhere else: a runtime that allows
    more would need the inheritance through them."""
    allowed = {FieldOptions.TARGET_TYPE_FILE, FieldOptions.TARGET_TYPE_FIELD}
    fields = ("field_presence", "repeated_field_encoding", "utf8_validation", "message_encoding")
    for name in fields:
        targets = FeatureSet.DESCRIPTOR.fields_by_name[name].GetOptions().targets
        assert set(targets) == allowed, name
    targets = FeatureSet.DESCRIPTOR.fields_by_name["enum_type"].GetOptions().targets
    assert set(targets) == {FieldOptions.TARGET_TYPE_FILE, FieldOptions.TARGET_TYPE_ENUM}


def test_a_tree_without_nanopb_options_resolves_to_defaults(tmp_path: Path) -> None:
    """The nanopb rules skip resolving options when no revision has a .options file or imports
    nanopb.proto: resolved anyway, every field's and oneof's options are the defaults."""
    files = {**READING}
    files.pop("reading.options")
    files["reading.proto"] = files["reading.proto"].replace('import "nanopb.proto";\n', "")
    files["reading.proto"] = files["reading.proto"].replace(" [(nanopb).int_size = IS_8]", "")
    revision = build(load_tree(tree(tmp_path / "t", files)))
    assert not revision.has_nanopb_options()
    default = options_class()()
    resolved = revision.nanopb()
    everything = [*resolved.fields.values(), *resolved.oneofs.values()]
    assert len(everything) == len(resolved.fields) + 1  # PBEnvelope's oneof too
    assert all(value == default for value in everything)
    with_options = tree(tmp_path / "o", READING)
    assert build(load_tree(with_options)).has_nanopb_options()  # it imports nanopb.proto
