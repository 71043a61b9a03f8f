"""erc_lint's pairing of OLD and NEW: fields by number and by name, enum values by number,
renamed messages with what they declare, map entries with their map fields."""

import dataclasses
from pathlib import Path

import pytest
from lint_support import SHAPES, rules, tree

import erc_lint


@pytest.mark.parametrize("spelling", ["ERC-Protobufs/components/a/shape.proto", "shape.proto"])
def test_a_moved_field_reads_as_moved_whatever_the_import_spelling(
    tmp_path: Path, spelling: str
) -> None:
    files = dict(SHAPES)
    old = tree(tmp_path / "old", files)
    files["components/b/bare.proto"] = (
        f'import "{spelling}";\nmessage Bare {{ Shape shape = 2; }}\n'
    )
    new = tree(tmp_path / "new", files)
    assert rules(erc_lint.lint(old, new)) == ["FIELD_RENUMBERED"]


def test_a_renamed_oneof_moves_nothing(tmp_path: Path) -> None:
    old = tree(
        tmp_path / "old", {"m.proto": "message M { oneof a { int32 x = 1; float y = 2; } }\n"}
    )
    renamed = tree(
        tmp_path / "new", {"m.proto": "message M { oneof b { int32 x = 1; float y = 2; } }\n"}
    )
    assert erc_lint.lint(old, renamed) == []
    split = tree(
        tmp_path / "split", {"m.proto": "message M { oneof b { int32 x = 1; } float y = 2; }\n"}
    )
    assert rules(erc_lint.lint(old, split)) == ["FIELD_ONEOF_CHANGED"] * 2  # x and y


def test_reordered_enum_aliases_reuse_nothing(tmp_path: Path) -> None:
    enum = "enum E {{ option allow_alias = true; {} = 0; {} = 0; C = 1; }}\n"
    old = tree(tmp_path / "old", {"e.proto": enum.format("A", "B")})
    new = tree(tmp_path / "new", {"e.proto": enum.format("B", "A")})
    assert erc_lint.lint(old, new) == []


def test_map_entries_follow_their_map_field(tmp_path: Path) -> None:
    """protoc writes a message for each map field (``CountsEntry``) with no source of its own:
    renaming the field is the field's rename alone, and a change inside the entry is located at
    the map field, as buf locates it."""
    old = tree(
        tmp_path / "old", {"a.proto": "message Stats {\n  map<string, int32> counts = 1;\n}\n"}
    )
    renamed = tree(
        tmp_path / "renamed", {"a.proto": "message Stats {\n  map<string, int32> totals = 1;\n}\n"}
    )
    assert [(f.rule, f.text) for f in erc_lint.lint(old, renamed)] == [
        ("FIELD_RENAMED", 'Field "1" on message "Stats" changed name from "counts" to "totals".')
    ]
    retyped = tree(
        tmp_path / "retyped", {"a.proto": "message Stats {\n  map<string, sint32> counts = 1;\n}\n"}
    )
    (finding,) = erc_lint.lint(old, retyped)
    assert (finding.rule, finding.line, finding.column) == ("FIELD_TYPE_CHANGED", 3, 3)
    assert finding.text == (
        'Field "2" with name "value" on message "Stats.CountsEntry" changed type from "int32" '
        'to "sint32".'
    )
    # Renamed beside a new map of the same types: the entry follows its field, not its body.
    beside = tree(
        tmp_path / "beside",
        {
            "a.proto": "message Stats {\n  map<string, int32> totals = 1;\n"
            "  map<string, int32> more = 2;\n}\n"
        },
    )
    assert [(f.rule, f.text) for f in erc_lint.lint(old, beside)] == [
        ("FIELD_RENAMED", 'Field "1" on message "Stats" changed name from "counts" to "totals".')
    ]
    # Renamed and retyped at once: both, the type change named in the new entry.
    both = tree(
        tmp_path / "both", {"a.proto": "message Stats {\n  map<string, float> totals = 1;\n}\n"}
    )
    assert [f.rule for f in erc_lint.lint(old, both)] == ["FIELD_RENAMED", "FIELD_TYPE_CHANGED"]


STATUS = (
    "message ArmBoardStatus {\n  enum Mode { MODE_IDLE = 0; MODE_RUN = 1; }\n"
    "  message Joint { float angle = 1; }\n  Mode mode = 1;\n  Joint joint = 2;\n"
    "  map<string, int32> counts = 3;\n}\n"
)


def test_a_renamed_message_takes_what_it_declares_along(tmp_path: Path) -> None:
    """Renaming a message renames its nested enum, message and map entry with it: one rename,
    and what changed inside is reported under the new names, old damage staying old."""
    old = tree(tmp_path / "old", {"a.proto": STATUS})
    renamed = tree(tmp_path / "renamed", {"a.proto": STATUS.replace("ArmBoard", "Arm")})
    assert [(f.rule, f.text) for f in erc_lint.lint(old, renamed)] == [
        (
            "MESSAGE_RENAMED",
            'Message "ArmBoardStatus" was renamed to "ArmStatus"; its fields are unchanged.',
        )
    ]
    changed = STATUS.replace("ArmBoard", "Arm").replace("float angle", "double angle")
    changed = changed.replace("MODE_RUN = 1;", "MODE_RUN = 2;")
    retyped = tree(tmp_path / "retyped", {"a.proto": changed})
    assert [(f.rule, f.text) for f in erc_lint.lint(old, retyped)][1:] == [
        (
            "ENUM_VALUE_RENUMBERED",
            'Enum value "MODE_RUN" on enum "ArmStatus.Mode" changed number from "1" to "2".',
        ),
        (
            "FIELD_TYPE_CHANGED",
            'Field "1" with name "angle" on message "ArmStatus.Joint" changed type from "float" '
            'to "double".',
        ),
    ]
    envelope = "message PBEnvelope { oneof payload { ArmBoardStatus status = 1; } }\n"
    old = tree(tmp_path / "old_sent", {"a.proto": STATUS + envelope})
    new = tree(tmp_path / "new_sent", {"a.proto": (STATUS + envelope).replace("ArmBoard", "Arm")})
    assert {(f.rule, f.severity) for f in erc_lint.lint(old, new)} == {
        ("MESSAGE_RENAMED", "warning"),
        ("EMBEDDED_REPEATED", "warning"),
        ("EMBEDDED_UNBOUNDED", "warning"),
    }


def test_a_renamed_messages_nested_types_are_not_claimed_by_lookalikes(tmp_path: Path) -> None:
    """A deleted message or enum whose body matches a renamed message's nested type does not
    become its rename: the nested type goes with its message, and what changed in it shows."""
    old = tree(
        tmp_path / "old",
        {
            "a.proto": "message Foo { string x = 1; }\nenum Color { E0 = 0; E1 = 1; }\n"
            "message Outer {\n  message Inner { int32 x = 1; }\n"
            "  enum E { E0 = 0; E1 = 1; E2 = 2; }\n  Inner i = 1;\n  E e = 2;\n}\n"
        },
    )
    new = tree(
        tmp_path / "new",
        {
            "a.proto": "message Outer2 {\n  message Inner { string x = 1; }\n"
            "  enum E { E0 = 0; E1 = 1; }\n  Inner i = 1;\n  E e = 2;\n}\n"
        },
    )
    assert sorted((f.rule, f.text.split(" on ")[-1]) for f in erc_lint.lint(old, new)) == [
        (
            "ENUM_VALUE_DELETED",
            'enum "Outer2.E" was deleted without reserving its number. Fix: reserve 2 or restore '
            "the value.",
        ),
        ("FIELD_TYPE_CHANGED", 'message "Outer2.Inner" changed type from "int32" to "string".'),
        ("MESSAGE_DELETED", 'Previously present message "Foo" was deleted.'),
        ("MESSAGE_RENAMED", 'Message "Outer" was renamed to "Outer2"; its fields are unchanged.'),
    ]


def test_a_type_moved_to_another_scope_pairs_when_its_numbers_and_names_agree(
    tmp_path: Path,
) -> None:
    """An enum moved into a message keeps its meaning (a value added on the way is no change);
    one whose shared names moved to other numbers is another enum; a short name that more than
    one type left or took pairs nothing."""
    users = "message User { Mode m = 1; }\n"
    old = tree(tmp_path / "old", {"a.proto": "enum Mode { A = 0; B = 1; }\n" + users})
    moved = "message User {\n  enum Mode { A = 0; B = 1; C = 2; }\n  Mode m = 1;\n}\n"
    assert erc_lint.lint(old, tree(tmp_path / "moved", {"a.proto": moved})) == []
    changed = moved.replace("B = 1; C = 2;", "C = 1; B = 2;")
    assert rules(erc_lint.lint(old, tree(tmp_path / "changed", {"a.proto": changed}))) == [
        "FIELD_TYPE_CHANGED"
    ]
    # P.Mode and R.Mode both left; a top-level Mode is no more the move of one than the other.
    nested = "message {0} {{\n  enum Mode {{ A = 0; B = 1; }}\n  Mode m = 1;\n}}\n"
    old_two = tree(tmp_path / "old_two", {"a.proto": nested.format("P") + nested.format("R")})
    top = (
        "enum Mode { A = 0; B = 1; C = 2; }\nmessage P { Mode m = 1; }\nmessage R { Mode m = 1; }\n"
    )
    new_two = tree(tmp_path / "new_two", {"a.proto": top})
    assert rules(erc_lint.lint(old_two, new_two)) == ["FIELD_TYPE_CHANGED"] * 2


def test_a_moved_message_brings_what_it_declares(tmp_path: Path) -> None:
    old = tree(
        tmp_path / "old",
        {
            "a.proto": "message Joint {\n  enum Kind { K0 = 0; K1 = 1; }\n  Kind kind = 1;\n"
            "  float angle = 2;\n}\nmessage Arm { Joint shoulder = 1; }\n"
        },
    )
    new = tree(
        tmp_path / "new",
        {
            "a.proto": "message Arm {\n  message Joint {\n    enum Kind { K0 = 0; K1 = 1; }\n"
            "    Kind kind = 1;\n    double angle = 2;\n  }\n  Joint shoulder = 1;\n}\n"
        },
    )
    assert [(f.rule, f.text) for f in erc_lint.lint(old, new)] == [
        ("MESSAGE_RENAMED", 'Message "Joint" was moved to "Arm.Joint".'),
        (
            "FIELD_TYPE_CHANGED",
            'Field "2" with name "angle" on message "Arm.Joint" changed type from "float" to '
            '"double".',
        ),
    ]


def test_paired_behaves_as_the_frozen_dataclass_it_replaces(tmp_path: Path) -> None:
    """Paired is a plain class for start-up time: it unpacks, equals, hashes, prints and refuses
    assignment as ``@dataclass(frozen=True, slots=True)`` with the same two fields does."""
    from erc_lint._loader import load_tree
    from erc_lint._model import Message, build
    from erc_lint._pairing import Paired

    @dataclasses.dataclass(frozen=True, slots=True)
    class Plain:
        old: Message
        new: Message

    messages = build(load_tree(tree(tmp_path, {"a.proto": "message A {}\nmessage B {}\n"})))
    a, b = messages.messages["A"], messages.messages["B"]
    fast, plain = Paired(a, b), Plain(a, b)
    assert tuple(fast) == (a, b) == (plain.old, plain.new)
    assert (fast == Paired(a, b), fast == Paired(b, a), fast == (a, b)) == (True, False, False)
    assert (plain == Plain(a, b), plain == Plain(b, a)) == (True, False)
    assert hash(fast) == hash(Paired(a, b))
    assert hash(plain) == hash(Plain(a, b))
    assert repr(fast) == repr(plain).replace(Plain.__qualname__, "Paired")
    with pytest.raises(AttributeError):
        fast.old = b
    with pytest.raises(AttributeError):
        plain.old = b  # type: ignore[misc]
    with pytest.raises((AttributeError, TypeError)):
        fast.other = b
    with pytest.raises((AttributeError, TypeError)):
        plain.other = b  # type: ignore[attr-defined]
