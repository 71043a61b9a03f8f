"""Maximum encoded sizes, checked against nanopb's own generator for every message.

nanopb's generator (PyPI ``nanopb`` 0.4.9.1) runs once per proto tree; the ``<CName>_size`` defines
and "depends on runtime parameters" comments of the headers it writes are the ground truth, and
erc_codec must give the same number, or the same "no size", for every message the tree defines.

The trees under ``tests/size_trees/`` are small, one nanopb rule family each (the first line of each
``.proto`` names it). Each tree also carries a hand-computed table, checked against nanopb alone, so
that a mistyped ``.options`` line cannot quietly turn a rule test into a comparison of two "no
size" answers (the generator also runs with ``--error-on-unmatched`` for the same reason).
"""

import re
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest
from conftest import PROTO, TESTS

import erc_codec
from erc_schema import Sizes, load_schema

TREES_DIR = TESTS / "size_trees"

GENERATOR = "nanopb.generator.nanopb_generator"
_DEFINE = re.compile(r"^#define\s+(\w+)_size\s+(\d+)\s*$", re.MULTILINE)
_RUNTIME = re.compile(r"/\*\s*(\w+)_size depends on runtime parameters\s*\*/")
# A size nanopb writes only if another one is defined (a field whose type is a skipped message).
_CONDITIONAL = re.compile(r"^#if defined\((\w+)_size\)\n#define (\w+)_size\b", re.MULTILINE)
_MESSAGE = re.compile(r"\bmessage\s+(\w+)\s*\{")

Sized = dict[str, int | None]


@dataclass(frozen=True)
class Tree:
    """A rule tree: its folder, the message load_schema starts from, and hand-computed sizes."""

    name: str
    root: str
    expected: Sized

    @property
    def path(self) -> Path:
        return TREES_DIR / self.name


# Hand-computed from the rules in each tree's comments; the trees' .proto files show the sums.
TREES: list[Tree] = [
    Tree(
        "scalars",
        "AllScalars",
        {
            "AllScalars": 100,
            "Tag15": 2,
            "Tag16": 3,
            "Tag2047": 3,
            "Tag2048": 4,
            "Tag262144": 5,
            "TagMax": 6,
            "Narrow8": 12,
            "Narrow16": 16,
            "Resized": 34,
            "SignExtended": 33,
        },
    ),
    Tree(
        "enums",
        "UsesSmall",
        {
            "UsesSmall": 2,
            "UsesEdge127": 2,
            "UsesEdge128": 3,
            "UsesWide300": 3,
            "UsesHuge": 6,
            "UsesNegative": 11,
            "NestedEnum": 4,
            "RepeatedEnum": 9,
            "NarrowedEnum": 11,
            "EnumMix": 15,
        },
    ),
    Tree(
        "strings_bytes",
        "StrAnnotated",
        {
            "StrFromOptionsFile": 33,
            "StrAnnotated": 33,
            "StrMaxLength": 33,
            "StrMaxLengthWins": 42,
            "StrLength126": 128,
            "StrLength127": 130,
            "Bytes127": 129,
            "Bytes128": 131,
            "BytesFixed": 18,
            "BytesFixedFromOptionsFile": 203,
            "BytesMaxLengthIgnored": None,
            "WideTags": 31,
        },
    ),
    Tree(
        "repeated",
        "RepOne",
        {
            "Item": 7,
            "RepOne": 12,
            "RepThree": 33,
            "RepMixed": 80,
            "RepTag16": 21,
            "RepStrings": 18,
            "RepBytesOne": 7,
            "RepItemOne": 10,
            "RepItemFour": 36,
            "RepFixedCount": 15,
            "RepNone": 0,
        },
    ),
    Tree(
        "maps",
        "WithMaps",
        {
            "Point": 12,
            "WithMaps": 148,
            "WithMaps.CountsEntry": 20,
            "WithMaps.PointsEntry": 20,
            "WithMaps.FlagsEntry": 13,
            "StringMap": 42,
            "StringMap.LabelsEntry": 18,
        },
    ),
    Tree(
        "oneofs",
        "OneofScalars",
        {
            "Payload": 31,
            "OneofScalars": 20,
            "OneofString": 41,
            "OneofSubmsg": 33,
            "OneofWideTag": 35,
            "TwoOneofs": 20,
            "Optionals": 57,
            "NoUnions": 14,
            "IgnoredOneof": 11,
        },
    ),
    Tree(
        "options",
        "MsgOptions",
        {
            "MsgOptions": 81,
            "WildA": 28,
            "WildB": 26,
            "WildC": 19,
            "WildC.Tagged": 17,
            "FileOrder": 10,
            "AnnotationWins": 7,
            "IgnoredField": 5,
            "IgnoredByOptionsFile": 5,
            "CallbackField": None,
            "PointerField": None,
            "HoldsCallback": None,
            "IntSizeAnnotated": 21,
            "DiscardDeprecated": 5,
        },
    ),
    Tree(
        "nested",
        "Outer",
        {
            "Outer": 22,
            "Outer.Inner": 13,
            "Outer.Inner.Leaf": 5,
            "UsesNested": 23,
            "Empty": 0,
            "HoldsEmpty": 2,
            "Size127": 127,
            "Size128": 128,
            "Holds127": 129,
            "Holds128": 131,
            "HoldsHolds128": 134,
            "Size16384": 16384,
            "Holds16384": 16388,
            "Container": 308,
            "Container.Block": 303,
        },
    ),
    Tree(
        "unbounded",
        "Bounded",
        {
            "Bounded": 5,
            "UnboundedString": None,
            "UnboundedBytes": None,
            "UnboundedRepeated": None,
            "UnboundedMap": None,
            "UnboundedMap.MEntry": 22,
            "ContainsUnbounded": None,
            "ContainsTransitively": None,
            "RepeatsUnbounded": None,
            "OneofWithUnbounded": None,
            "Recursive": None,
            "HoldsRecursive": None,
            "MutualA": None,
            "MutualB": None,
        },
    ),
    Tree(
        "imports",
        "MainMsg",
        {"MainMsg": 78, "Dep": 48, "Dep.Reading": 18, "Measure": 8},
    ),
    Tree(
        "nested_options",
        "Parent",
        {
            "Parent": None,
            "Parent.Child": None,
            "UsesChild": None,
            "Control": 15,
            "Control.Child": 13,
        },
    ),
    # Skipped and Retired are not generated at all: no define, no "depends on runtime" comment.
    Tree("skipped", "Kept", {"Kept": 5}),
    Tree("editions", "Holder", {"Sub": 11, "Holder": 45}),
    Tree("overrides", "Override", {"UsesSkipped": None, "Override": 34, "Relabelled": 44}),
]

ENVELOPE = TREES_DIR / "envelope"
# Env's oneof members: field number -> message type (see envelope/env.proto).
ENVELOPE_MEMBERS = {1: "Telemetry", 2: "Label", 3: "Choice", 16: "Track"}

MISSING = "<missing>"  # stands in for a message one side does not list at all


# -- nanopb's generator -------------------------------------------------------------------------


def _varint_size(value: int) -> int:
    """Bytes of a varint; written out here so the expectations do not lean on erc_codec."""
    return max(1, (value.bit_length() + 6) // 7)


def _proto_files(tree: Path) -> list[str]:
    return sorted(path.relative_to(tree).as_posix() for path in tree.rglob("*.proto"))


def _full_name(c_name: str) -> str:
    """nanopb's C name back to the message's full name (no packages; see the underscore guard)."""
    return c_name.replace("_", ".")


def nanopb_sizes(tree: Path, outdir: Path) -> Sized:
    """Run nanopb's generator over every .proto of ``tree``; ``{full name: size or None}``."""
    files = _proto_files(tree)
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            GENERATOR,
            "-q",
            "--error-on-unmatched",
            "-I",
            str(tree),
            "-D",
            str(outdir),
            *files,
        ],
        cwd=tree,
        capture_output=True,
        text=True,
        check=False,
    )
    if result.returncode != 0:
        pytest.fail(f"nanopb's generator failed on {tree}:\n{result.stderr}")
    sizes: Sized = {}
    conditional: list[tuple[str, str]] = []
    for name in files:
        header = (outdir / name).with_suffix(".pb.h").read_text(encoding="utf-8")
        for c_name, value in _DEFINE.findall(header):
            sizes[_full_name(c_name)] = int(value)
        for c_name in _RUNTIME.findall(header):
            sizes[_full_name(c_name)] = None
        conditional += _CONDITIONAL.findall(header)
    for needed, c_name in conditional:
        assert sizes.get(_full_name(needed)) is None, f"{c_name}_size is an expression: read it"
        sizes[_full_name(c_name)] = None  # what it needs is never defined
    return sizes


class NanopbRuns:
    """nanopb's sizes per tree, generated at most once per tree for the whole module."""

    def __init__(self, factory: pytest.TempPathFactory) -> None:
        self._factory = factory
        self._cache: dict[Path, Sized] = {}

    def sizes(self, tree: Path) -> Sized:
        if tree not in self._cache:
            self._cache[tree] = nanopb_sizes(tree, self._factory.mktemp(f"nanopb-{tree.name}"))
        return self._cache[tree]


@pytest.fixture(scope="module")
def nanopb(tmp_path_factory: pytest.TempPathFactory) -> NanopbRuns:
    pytest.importorskip("nanopb")
    return NanopbRuns(tmp_path_factory)


def _side_by_side(ours: Sized, theirs: Sized) -> dict[str, tuple[object, object]]:
    """Every message on which the two disagree: ``{name: (erc_codec, nanopb)}``."""
    return {
        name: (ours.get(name, MISSING), theirs.get(name, MISSING))
        for name in sorted(ours.keys() | theirs.keys())
        if ours.get(name, MISSING) != theirs.get(name, MISSING)
    }


# -- guards on the trees themselves -------------------------------------------------------------


def _all_trees() -> Iterator[Path]:
    yield PROTO
    yield from sorted(path for path in TREES_DIR.iterdir() if path.is_dir())


@pytest.mark.parametrize("tree", list(_all_trees()), ids=lambda tree: tree.name)
def test_message_names_map_back_from_c_names(tree: Path) -> None:
    """No message name holds an underscore, so ``Outer_Inner`` can only be ``Outer.Inner``."""
    names = [
        name
        for path in sorted(tree.rglob("*.proto"))
        for name in _MESSAGE.findall(path.read_text(encoding="utf-8"))
    ]
    assert names
    assert [name for name in names if "_" in name] == []


def test_every_rule_tree_is_compared() -> None:
    folders = {path.name for path in TREES_DIR.iterdir() if path.is_dir()}
    compared = {tree.name for tree in TREES} | {ENVELOPE.name, "bad_string", "bad_repeated"}
    assert folders == compared


@pytest.mark.parametrize("tree", TREES, ids=lambda tree: tree.name)
def test_rule_tree_exercises_its_rules(nanopb: NanopbRuns, tree: Tree) -> None:
    """nanopb gives the hand-computed sizes: each tree really exercises the rule it names."""
    assert nanopb.sizes(tree.path) == tree.expected


# -- the packaged rover tree --------------------------------------------------------------------


def test_packaged_tree_sizes_equal_nanopb(codec: erc_codec.Codec, nanopb: NanopbRuns) -> None:
    assert _side_by_side(codec.sizes(), nanopb.sizes(PROTO)) == {}


def test_packaged_envelope_size_is_nanopb_pbenvelope_size(
    codec: erc_codec.Codec, nanopb: NanopbRuns
) -> None:
    assert codec.max_size("PBEnvelope") == 262
    assert nanopb.sizes(PROTO)["PBEnvelope"] == 262


# -- rule trees, through the size model --------------------------------------------------------


@pytest.mark.parametrize("tree", TREES, ids=lambda tree: tree.name)
def test_rule_tree_sizes_equal_nanopb(nanopb: NanopbRuns, tree: Tree) -> None:
    """Every message nanopb generates has erc_codec's number (or, like nanopb, no size)."""
    ours = Sizes(load_schema(tree.path, root=tree.root)).all()
    theirs = nanopb.sizes(tree.path)
    assert {name: ours.get(name, MISSING) for name in theirs} == theirs


@pytest.mark.parametrize("tree", TREES, ids=lambda tree: tree.name)
def test_rule_tree_lists_the_messages_nanopb_generates(nanopb: NanopbRuns, tree: Tree) -> None:
    """erc_codec lists exactly the messages nanopb gives a size or "no size" to, no others."""
    ours = Sizes(load_schema(tree.path, root=tree.root)).all()
    theirs = nanopb.sizes(tree.path)
    extra = sorted(ours.keys() - theirs.keys())
    missing = sorted(theirs.keys() - ours.keys())
    assert not extra, f"erc_codec lists messages nanopb does not generate: {extra}"
    assert not missing, f"erc_codec leaves out messages nanopb generates: {missing}"


# -- an envelope tree, through the public Codec -------------------------------------------------


@pytest.fixture(scope="module")
def envelope_codec() -> erc_codec.Codec:
    return erc_codec.Codec.from_path(ENVELOPE, root="Env")


def test_envelope_tree_sizes_equal_nanopb(
    envelope_codec: erc_codec.Codec, nanopb: NanopbRuns
) -> None:
    assert _side_by_side(envelope_codec.sizes(), nanopb.sizes(ENVELOPE)) == {}


def test_envelope_size_is_its_widest_member(
    envelope_codec: erc_codec.Codec, nanopb: NanopbRuns
) -> None:
    theirs = nanopb.sizes(ENVELOPE)
    framed: dict[int, int] = {}
    for number, member in ENVELOPE_MEMBERS.items():
        size = theirs[member]
        assert size is not None, member
        framed[number] = _varint_size(number << 3) + _varint_size(size) + size
    # The widest member (Track, 146 bytes) has a two-byte tag and a two-byte length prefix.
    assert max(framed, key=framed.__getitem__) == 16
    assert framed[16] == 2 + 2 + 146
    assert envelope_codec.max_size("Env") == max(framed.values()) == theirs["Env"]


# -- envelopes reaching a field nanopb cannot size ----------------------------------------------


def _line_of(path: Path, declaration: str) -> int:
    lines = path.read_text(encoding="utf-8").splitlines()
    matches = [number for number, line in enumerate(lines, 1) if declaration in line]
    assert len(matches) == 1, (path, declaration)
    return matches[0]


@pytest.mark.parametrize(
    ("folder", "file", "declaration", "field", "reached_as"),
    [
        ("bad_string", "env.proto", "string name = 2;", "Holder.name", "Env.holder.name"),
        (
            "bad_repeated",
            "parts/inner.proto",
            "repeated sint32 values = 2;",
            "Inner.values",
            "Env.wrapper.inner.values",
        ),
    ],
    ids=["unbounded-string", "repeated-without-max-count"],
)
def test_envelope_reaching_an_unsized_field_is_a_schema_error(
    folder: str, file: str, declaration: str, field: str, reached_as: str
) -> None:
    tree = TREES_DIR / folder
    line = _line_of(tree / file, declaration)
    with pytest.raises(erc_codec.SchemaError) as raised:
        erc_codec.Codec.from_path(tree, root="Env")
    message = str(raised.value)
    assert re.search(rf"(^|[\s/]){re.escape(file)}:{line}\b", message), message
    assert re.search(rf"\b{re.escape(field)}\b", message), message
    assert re.search(rf"\b{re.escape(reached_as)}\b", message), message
