"""erc_lint's rules: each is handed one pair and explains itself; what the fixtures of
tests/lint_cases/ (each rule firing, through the command line) do not show."""

import inspect
import re
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import TESTS
from google.protobuf import descriptor_pool, message_factory
from lint_support import READING, rules, tree

import erc_lint
from erc_lint import RULES, Config, Rule
from erc_lint._loader import load_tree
from erc_lint._model import build
from erc_lint._pairing import WIRE_GROUPS, wire_compatible
from erc_lint.rules._registry import PAIRS, Report
from erc_schema import compile_files

SECTIONS = ["## What it does", "## Why is this bad?", "## Example", "## Use instead"]


@pytest.mark.parametrize("rule", RULES.values(), ids=list(RULES))
def test_every_rule_explains_itself(rule: Rule) -> None:
    """ruff's rule docs: what it does, why that breaks the wire, an example, the fix; the
    docstring is what ``erc-lint rules --explain`` will print."""
    doc = inspect.cleandoc(rule.check.__doc__ or "")
    headings = [line for line in doc.splitlines() if line.startswith("## ")]
    assert headings == SECTIONS, rule.id
    example = doc.split("## Example", 1)[1].split("## Use instead", 1)[0]
    assert "```proto" in example, rule.id
    assert example.count("```") % 2 == 0, rule.id
    assert all(len(line) <= 96 for line in doc.splitlines()), rule.id
    assert rule.purpose.endswith("."), rule.id  # one line, as `erc-lint rules` lists it


@pytest.mark.parametrize("rule", RULES.values(), ids=list(RULES))
def test_every_rule_is_handed_one_pair_and_the_change(rule: Rule) -> None:
    assert rule.pairs in PAIRS or rule.pairs in ("tree", "findings")
    assert list(inspect.signature(rule.check).parameters)[1:] == ["change"]
    assert re.fullmatch(r"[A-Z][A-Z0-9]*(_[A-Z0-9]+)*", rule.id)
    assert rule.severity in ("error", "warning")
    assert rule.pairs != "tree" or rule.severity == "error"  # graded by OLD instead


# Examples that need more than one file of each revision: a configuration, a ledger, a second file.
SETUP = {
    "EMBEDDED_ROOT_MISSING",
    "ENVELOPE_OVER_BUDGET",
    "IMPORT_AMBIGUOUS",
    "LEDGER_NUMBER_REUSED",
    "MESSAGE_DELETED",
    "NAME_COLLISION",
    "SUPPRESSION_UNUSED",  # needs the rule it suppresses run too (lint_cases/SUPPRESSION_UNUSED)
}
FENCED = re.compile(r"^(Before|After)\b[^\n]*\n```proto\n(.*?)```", re.DOTALL | re.MULTILINE)


@pytest.mark.parametrize(
    "rule", [r for r in RULES.values() if r.id not in SETUP], ids=lambda r: r.id
)
def test_every_rules_example_shows_the_rule(rule: Rule, tmp_path: Path) -> None:
    """The example a rule explains itself with is true: linted, before against after, it fires
    (alone: the example shows the rule, not what it shares a category with). An example without
    a syntax line is proto3."""
    doc = inspect.cleandoc(rule.check.__doc__ or "")
    blocks = dict(FENCED.findall(doc.split("## Example", 1)[1]))
    assert set(blocks) == {"Before", "After"}, rule.id
    for side, text in blocks.items():
        (tmp_path / side).mkdir()
        header = "" if text.startswith(("syntax", "edition")) else 'syntax = "proto3";\n'
        (tmp_path / side / "example.proto").write_text(header + text)
    found = erc_lint.lint(tmp_path / "Before", tmp_path / "After", Config(use=(rule.id,)))
    assert rule.id in {finding.rule for finding in found}, found


def test_a_report_at_an_element_is_found_at_its_location(tmp_path: Path) -> None:
    """A tree rule's report may name the element it is about (its location read only where the
    report becomes a finding, bench_lint's proto2+editions ratio): it points where the report at
    the element's location points."""
    revision = build(load_tree(tree(tmp_path, READING)))
    message = revision.messages["Reading"]
    value = revision.enums["Mode"].values[1]
    for element in (message, message.fields[2], value):
        plain = Report(element.location, "m")
        assert Report(element, "m").where == plain.where == plain.location
        assert plain.where.line > 1  # a declaration's line, not the file's first


@pytest.mark.parametrize(
    ("envelope", "missing"),
    [
        ("message PBEnvelope { oneof p { Ph ph = 1 } }\n", False),  # declared, file broken
        ("// message PBEnvelope { oneof p { Ph ph = 1; } }\nmessage Env { Ph ph = 1 }\n", True),
        ('message Env { string s = 1 [json_name = "message PBEnvelope"] }\n', True),
    ],
    ids=["declared", "commented-out", "in-a-string"],
)
def test_a_root_declared_in_a_file_that_does_not_compile_is_not_missing(
    tmp_path: Path, envelope: str, missing: bool
) -> None:
    """What a broken file declares is unknown, not missing (COMPILE says why); a declaration in
    a comment or a string is no declaration."""
    root = tmp_path / "t"
    root.mkdir()
    (root / "ph.proto").write_text('syntax = "proto3";\nmessage Ph { float ph = 1; }\n')
    (root / "env.proto").write_text(f'syntax = "proto3";\nimport "ph.proto";\n{envelope}')
    config = Config(roots=("PBEnvelope",), roots_line=1)
    found = {finding.rule for finding in erc_lint.check(root, config)}
    assert found == ({"COMPILE", "EMBEDDED_ROOT_MISSING"} if missing else {"COMPILE"})


def test_collisions_between_files_never_compiled_together(tmp_path: Path) -> None:
    root = tree(
        tmp_path / "t",
        {
            "gps.proto": "message SensorBoardGPSInfo { double latitude = 1; }\n",
            "leftover/message_types.proto": "enum PBMessageType { SensorBoardGPSInfo = 0; }\n",
        },
    )
    (collision,) = erc_lint.lint(tmp_path / "t", root)
    assert collision.rule == "NAME_COLLISION"
    assert str(root / "gps.proto") in collision.text
    assert str(root / "leftover/message_types.proto") in collision.text


def test_old_damage_in_an_imported_file_stays_old_when_its_importer_is_renamed(
    tmp_path: Path,
) -> None:
    broken = {"b.proto": "message B { float x = 1 }\n"}
    users = 'import "b.proto";\nmessage {name} {{ B b = 1; }}\n'
    old = tree(tmp_path / "old", {**broken, "a.proto": users.format(name="A")})
    new = tree(tmp_path / "new", {**broken, "aa.proto": users.format(name="A")})
    (in_b,) = [f for f in erc_lint.lint(old, new) if f.path == str(new / "b.proto")]
    assert (in_b.rule, in_b.severity) == ("COMPILE", "warning")
    assert in_b.text == 'Expected ";". (imported by aa.proto)'


def test_a_file_old_could_not_compile_is_not_passed_over_in_silence(tmp_path: Path) -> None:
    old = tree(tmp_path / "old", {"a.proto": "message A { int32 x = 1; Missing m = 2; }\n"})
    new = tree(tmp_path / "new", {"a.proto": "message A { int32 x = 2; }\n"})
    findings = erc_lint.lint(old, new)
    assert [(f.rule, f.severity, f.in_old) for f in findings] == [("COMPILE", "warning", True)]
    assert "a.proto does not compile, so its messages could not be compared" in findings[0].text


ALIASED = (
    "enum Mode {\n  option allow_alias = true;\n  MODE_IDLE = 0;\n  MODE_RUN = 1;\n"
    "  MODE_RUNNING = 1;\n}\n"
)


@pytest.mark.parametrize(
    ("new", "expected"),
    [
        (  # an alias dropped: the number keeps its meaning, one name is gone
            "enum Mode {\n  MODE_IDLE = 0;\n  MODE_RUN = 1;\n}\n",
            [
                (
                    "ENUM_VALUE_RENAMED",
                    'Enum value "1" on enum "Mode" changed name from "MODE_RUN", '
                    '"MODE_RUNNING" to "MODE_RUN".',
                )
            ],
        ),
        (  # an alias moved to a number of its own: renumbered, and 1 is not reused
            "enum Mode {\n  MODE_IDLE = 0;\n  MODE_RUN = 1;\n  MODE_RUNNING = 2;\n}\n",
            [
                (
                    "ENUM_VALUE_RENUMBERED",
                    'Enum value "MODE_RUNNING" on enum "Mode" changed number from "1" to "2".',
                )
            ],
        ),
        (  # the number and both its names gone: one deletion
            "enum Mode {\n  MODE_IDLE = 0;\n}\n",
            [
                (
                    "ENUM_VALUE_DELETED",
                    'Previously present enum value "1" with names "MODE_RUN", "MODE_RUNNING" '
                    'on enum "Mode" was deleted without reserving its number. '
                    "Fix: reserve 1 or restore the value.",
                )
            ],
        ),
        (  # both names renamed at once
            "enum Mode {\n  MODE_IDLE = 0;\n  MODE_ACTIVE = 1;\n}\n",
            [
                (
                    "ENUM_VALUE_RENAMED",
                    'Enum value "1" on enum "Mode" changed name from "MODE_RUN", '
                    '"MODE_RUNNING" to "MODE_ACTIVE".',
                )
            ],
        ),
        (ALIASED.replace("  MODE_RUNNING = 1;\n", "  MODE_RUNNING = 1;\n  MODE_BUSY = 1;\n"), []),
        (
            ALIASED.replace(
                "  MODE_RUN = 1;\n  MODE_RUNNING = 1;\n", "  MODE_RUNNING = 1;\n  MODE_RUN = 1;\n"
            ),
            [],
        ),
        (  # both names moved to 2, and 1 given to another value: one reuse, not one per alias
            "enum Mode {\n  option allow_alias = true;\n  MODE_IDLE = 0;\n  MODE_STOP = 1;\n"
            "  MODE_RUN = 2;\n  MODE_RUNNING = 2;\n}\n",
            [
                (
                    "ENUM_VALUE_REUSED",
                    'Enum value "1" on enum "Mode" changed from "MODE_RUN", "MODE_RUNNING" to '
                    '"MODE_STOP", and "MODE_RUN" is now "2", "MODE_RUNNING" is now "2".',
                ),
                (
                    "ENUM_VALUE_RENUMBERED",
                    'Enum value "MODE_RUN" on enum "Mode" changed number from "1" to "2".',
                ),
                (
                    "ENUM_VALUE_RENUMBERED",
                    'Enum value "MODE_RUNNING" on enum "Mode" changed number from "1" to "2".',
                ),
            ],
        ),
        (  # one name moved, the other gone, 1 given to another value: a reuse, not a rename
            "enum Mode {\n  MODE_IDLE = 0;\n  MODE_STOP = 1;\n  MODE_RUN = 2;\n}\n",
            [
                (
                    "ENUM_VALUE_REUSED",
                    'Enum value "1" on enum "Mode" changed from "MODE_RUN", "MODE_RUNNING" to '
                    '"MODE_STOP", and "MODE_RUN" is now "2".',
                ),
                (
                    "ENUM_VALUE_RENUMBERED",
                    'Enum value "MODE_RUN" on enum "Mode" changed number from "1" to "2".',
                ),
            ],
        ),
    ],
    ids=[
        "alias-dropped",
        "alias-moved",
        "number-deleted",
        "both-renamed",
        "alias-added",
        "reordered",
        "both-moved-number-reused",
        "one-moved-one-gone-number-reused",
    ],
)
def test_enum_aliases_are_judged_per_number(
    tmp_path: Path, new: str, expected: list[tuple[str, str]]
) -> None:
    old_tree = tree(tmp_path / "old", {"a.proto": ALIASED})
    new_tree = tree(tmp_path / "new", {"a.proto": new})
    findings = erc_lint.lint(old_tree, new_tree)
    assert [(f.rule, f.text) for f in findings] == expected


@pytest.mark.parametrize(
    ("edit", "grown"),
    [
        (("reading.options", "16", "32"), "from 26 to 42"),  # only the .options file changed
        (("reading.proto", "MODE_RUN = 1;", "MODE_RUN = 1; MODE_BACK = -1;"), "from 26 to 35"),
        (("reading.proto", " [(nanopb).int_size = IS_8]", ""), "from 26 to 29"),  # nested type
        (("reading.proto", "MODE_IDLE = 0;", "MODE_IDLE = 0; // idle\n"), None),  # comment only
    ],
)
def test_the_envelope_size_follows_every_input_nanopb_sizes_it_from(
    tmp_path: Path, edit: tuple[str, str, str], grown: str | None
) -> None:
    """Whatever nanopb reads to size the root, in another file, an enum, a nested message or a
    .options file, is compared; comments are not."""
    old = tree(tmp_path / "old", READING)
    (old / "reading.options").write_text(READING["reading.options"])
    name, before, after = edit
    changed = {**READING, name: READING[name].replace(before, after)}
    new = tree(tmp_path / "new", changed)
    (new / "reading.options").write_text(changed["reading.options"])
    messages = [f.text for f in erc_lint.lint(old, new) if f.rule == "ENVELOPE_SIZE_GROWN"]
    assert len(messages) == (grown is not None), messages
    assert all(grown in message for message in messages if grown is not None)


def test_the_envelope_size_follows_the_types_the_root_imports(tmp_path: Path) -> None:
    """A name defined twice in the tree (no package, so a collision) is the definition the root's
    own imports bring: its growth is the root's."""
    files = {
        "a.proto": "message Sub { int32 z = 1; }\n",
        "b.proto": "message Sub { fixed32 x = 1; }\n",
        "env.proto": 'import "b.proto";\nmessage PBEnvelope { oneof payload { Sub sub = 1; } }\n',
    }
    old = tree(tmp_path / "old", files)
    grown = {**files, "b.proto": "message Sub { fixed32 x = 1; fixed64 y = 2; }\n"}
    new = tree(tmp_path / "new", grown)
    messages = [f.text for f in erc_lint.lint(old, new) if f.rule == "ENVELOPE_SIZE_GROWN"]
    assert messages == [
        'Maximum size of message "PBEnvelope" grew from 7 to 16 bytes: receivers built with the '
        "old PBEnvelope_size drop the longer datagrams."
    ]


def test_a_packaged_roots_size_is_named_as_nanopb_names_it(tmp_path: Path) -> None:
    text = "package acme.io;\nmessage A { fixed32 x = 1; }\nmessage Env { oneof p { A a = 1; } }\n"
    old = tree(tmp_path / "old", {"env.proto": text})
    new = tree(tmp_path / "new", {"env.proto": text.replace("x = 1;", "x = 1; fixed32 y = 2;")})
    (finding,) = erc_lint.lint(old, new, Config(roots=("acme.io.Env",)))
    assert finding.text == (
        'Maximum size of message "acme.io.Env" grew from 7 to 12 bytes: receivers built with '
        "the old acme_io_Env_size drop the longer datagrams."
    )


def test_packing_is_no_wire_change_so_no_rule_reports_it(tmp_path: Path) -> None:
    """FIELD_ENCODING_CHANGED leaves packing alone (lint_cases/safe/packing_toggled) because a
    reader accepts a repeated scalar either way: Google protobuf's, here, and nanopb's decoder
    alike (a length-delimited record for a packable repeated field is read as packed)."""
    (tmp_path / "p.proto").write_text(
        'syntax = "proto2";\nmessage Packed { repeated sint32 v = 1 [packed = true]; }\n'
        "message Expanded { repeated sint32 v = 1; }\n"
    )
    pool = descriptor_pool.DescriptorPool()
    for proto in compile_files(tmp_path, ["p.proto"], locations=False).file:
        pool.Add(proto)
    packed, expanded = (
        message_factory.GetMessageClass(pool.FindMessageTypeByName(name))
        for name in ("Packed", "Expanded")
    )
    values = [0, -1, 300, -70000]
    written = packed(v=values).SerializeToString(), expanded(v=values).SerializeToString()
    assert written[0] != written[1]  # the encodings differ
    assert expanded.FromString(written[0]) == expanded(v=values)
    assert packed.FromString(written[1]) == packed(v=values)


def test_implicit_defaults_of_compatible_types_agree(tmp_path: Path) -> None:
    """FIELD_DEFAULT_CHANGED skips scalar fields without an explicit default on either side:
    what the model says they read as while absent is the same for every pair of types that read
    each other's bytes."""
    scalars = sorted({*(t for group in WIRE_GROUPS for t in group), "string", "bytes"})
    body = "".join(f"  optional {t} f_{t} = {k};\n" for k, t in enumerate(scalars, 1))
    (tmp_path / "a.proto").write_text(f'syntax = "proto2";\nmessage A {{\n{body}}}\n')
    revision = build(load_tree(tmp_path))
    fields = {f.type: f for f in revision.messages["A"].fields.values()}
    for old in scalars:
        for new in scalars:
            if wire_compatible(old, new):
                assert revision.default(fields[old])[0] == revision.default(fields[new])[0]


NANOPB_BASE = (
    'import "nanopb.proto";\nenum Gear { GEAR_PARK = 0; GEAR_LOW = 1; }\n'
    "message Chunk {\n"
    "  bytes data = 1 [(nanopb).type = FT_CALLBACK, (nanopb).max_size = 40];\n"
    "  bytes blob = 2 [(nanopb).type = FT_POINTER, (nanopb).max_size = 40];\n"
    "  Gear gear = 3 [(nanopb).int_size = IS_32];\n"
    "  int32 ticks = 4;\n"
    "  bytes key = 5 [(nanopb).max_size = 40];\n"
    "}\n"
)


def _generated(root: Path, out: Path) -> str:
    """What nanopb's generator (PyPI nanopb, as tests/schema/test_sizes.py runs it) writes for
    ``root``/a.proto: the header and the source, without the line naming the generator."""
    out.mkdir()
    subprocess.run(
        [
            sys.executable,
            "-m",
            "nanopb.generator.nanopb_generator",
            "-q",
            "-D",
            str(out),
            "a.proto",
        ],
        cwd=root,
        check=True,
    )
    text = (out / "a.pb.h").read_text() + (out / "a.pb.c").read_text()
    return "\n".join(line for line in text.splitlines() if "Generated by nanopb" not in line)


@pytest.mark.parametrize(
    ("before", "after"),
    [
        ("FT_CALLBACK, (nanopb).max_size = 40", "FT_CALLBACK, (nanopb).max_size = 10"),
        ("FT_POINTER, (nanopb).max_size = 40", "FT_POINTER, (nanopb).max_size = 10"),
        ("int_size = IS_32", "int_size = IS_8"),  # on an enum field: the generator ignores it
        ("GEAR_PARK = 0;", "option (nanopb_enumopt).enum_intsize = IS_8; GEAR_PARK = 0;"),
        ("int32 ticks = 4;", "int32 ticks = 4 [(nanopb).type_override = TYPE_SINT32];"),
        ("key = 5 [(nanopb).max_size = 40]", "key = 5 [(nanopb).max_size = 10]"),
    ],
    ids=[
        "callback-max-size",
        "pointer-max-size",
        "enum-int-size",
        "enum-intsize",
        "override",
        "static",
    ],
)
def test_nanopb_rules_report_what_the_generator_changes(
    tmp_path: Path, before: str, after: str
) -> None:
    """The nanopb rules report a change of options exactly when nanopb's generator writes other
    code for it: a limit on a callback or pointer field, or int_size on an enum field, changes
    nothing; enum_intsize, a type_override and a static field's max_size change the code."""
    pytest.importorskip("nanopb")
    old = tree(tmp_path / "old", {"a.proto": NANOPB_BASE})
    new = tree(tmp_path / "new", {"a.proto": NANOPB_BASE.replace(before, after)})
    changed = _generated(old, tmp_path / "old-out") != _generated(new, tmp_path / "new-out")
    nanopb_rules = {rule for rule, info in RULES.items() if "NANOPB" in info.categories}
    found = [f for f in erc_lint.lint(old, new, Config(roots=())) if f.rule in nanopb_rules]
    assert bool(found) == changed, found


def test_an_enums_default_from_an_include_folder_is_read_from_its_file(tmp_path: Path) -> None:
    """FIELD_DEFAULT_CHANGED on an enum another folder (-I) declares: its first value is the
    implicit default, as for an enum of the tree."""
    include = tmp_path / "inc"
    (include / "lib").mkdir(parents=True)
    enum = 'syntax = "proto2";\nenum Mode { MODE_A = 0; MODE_B = 1; }\n'
    (include / "lib" / "mode.proto").write_text(enum)
    head = 'syntax = "proto2";\nimport "lib/mode.proto";\n'
    old, new = tmp_path / "old", tmp_path / "new"
    for side, body in (
        ("old", "m = 1 [default = MODE_A]; optional Mode n = 2"),
        ("new", "m = 1; optional Mode n = 2 [default = MODE_A]"),
    ):
        (tmp_path / side).mkdir()
        (tmp_path / side / "a.proto").write_text(f"{head}message M {{ optional Mode {body}; }}\n")
    assert erc_lint.lint(old, new, includes=[include]) == []
    (include / "lib" / "mode.proto").write_text(
        enum.replace("MODE_A = 0; MODE_B = 1;", "MODE_B = 1; MODE_A = 0;")
    )
    assert [f.text for f in erc_lint.lint(old, new, includes=[include])] == [
        'Field "1" with name "m" on message "M" changed default value from Mode.MODE_A to '
        "Mode.MODE_B.",
        'Field "2" with name "n" on message "M" changed default value from Mode.MODE_B to '
        "Mode.MODE_A.",
    ]


def test_an_extension_turned_into_a_field_of_the_same_type_is_not_deleted(tmp_path: Path) -> None:
    """Same number, cardinality and type: the bytes read as before. Only the range that lost the
    number is reported."""
    head = 'syntax = "proto2";\n'
    old, new = tmp_path / "old", tmp_path / "new"
    for root, text in (
        (old, "message Host { extensions 100 to 199; }\nextend Host { optional int32 e = 100; }\n"),
        (new, "message Host { optional int32 e = 100; extensions 101 to 199; }\n"),
    ):
        root.mkdir()
        (root / "a.proto").write_text(head + text)
    assert rules(erc_lint.lint(old, new)) == ["EXTENSION_RANGE_REMOVED"]
    (new / "a.proto").write_text(
        head + "message Host { optional sint32 e = 100; extensions 101 to 199; }\n"
    )
    assert sorted(rules(erc_lint.lint(old, new))) == [
        "EXTENSION_DELETED",
        "EXTENSION_RANGE_REMOVED",
    ]


CASES = TESTS / "lint_cases"


def test_nanopb_shortcut_agrees_with_the_plain_rules() -> None:
    """The limit rules and the layout rule skip a field of the same type, cardinality and nanopb
    options in both revisions; over every lint case (each nanopb case among them), they find
    with the shortcut exactly what they find without it."""
    from erc_lint._pairing import Change
    from erc_lint.rules.nanopb import layout_changes, limit_changes_of

    compared = 0
    for new in sorted(CASES.glob("**/new")):
        old = new.parent / "old"
        if not old.is_dir():
            continue
        change = Change(build(load_tree(old)), build(load_tree(new)), Config())
        compared += change.compares_nanopb
        for pair in change.fields():
            assert limit_changes_of(pair, change) == limit_changes_of(pair, change, alike=False)
        for paired in change.messages:
            quick = list(layout_changes(paired, change))
            assert quick == list(layout_changes(paired, change, alike=False)), new
    assert compared >= 10  # the nanopb rules' cases, and others with options


def test_an_extension_of_a_file_that_no_longer_compiles_is_not_deleted(tmp_path: Path) -> None:
    """As for a message of such a file: what it declares is unknown in NEW, not gone. COMPILE
    says so; an extension still declared in a file that compiles and gone from it is deleted."""
    head = 'syntax = "proto2";\n'
    host = head + "message Host { extensions 100 to 199; }\n"
    ext = head + 'import "host.proto";\nextend Host { optional int32 e = 100; }\n'
    broken = ext.replace('import "host.proto";', 'import "host.proto";\nimport "missing.proto";')
    old, new = tmp_path / "old", tmp_path / "new"
    for root, text in ((old, ext), (new, broken)):
        root.mkdir()
        (root / "host.proto").write_text(host)
        (root / "e.proto").write_text(text)
    assert set(rules(erc_lint.lint(old, new))) == {"COMPILE"}
    (new / "e.proto").write_text(head + 'import "host.proto";\n')
    assert rules(erc_lint.lint(old, new)) == ["EXTENSION_DELETED"]


def test_limit_changes_once_per_pair(tmp_path: Path) -> None:
    """The two limit rules share one computation per field pair: the memo gives what the plain
    computation gives, for every pair."""
    from erc_lint._pairing import Change
    from erc_lint.rules.nanopb import limit_changes, limit_changes_of

    old = tree(tmp_path / "old", {"a.proto": NANOPB_BASE})
    narrowed = NANOPB_BASE.replace("max_size = 40];\n}", "max_size = 10];\n}")
    new = tree(tmp_path / "new", {"a.proto": narrowed.replace("int32 ticks", "int64 ticks")})
    change = Change(build(load_tree(old)), build(load_tree(new)), Config())
    pairs = list(change.fields())
    plain = [limit_changes_of(pair, change) for pair in pairs]
    assert [limit_changes(pair, change) for pair in pairs] == plain
    assert [limit_changes(pair, change) for pair in pairs] == plain  # from the memo
    assert sum(map(len, plain)) == 2  # key's max_size, ticks' width


def test_sizes_from_the_revisions_resolved_options_are_sizes_own() -> None:
    """The revision model hands Sizes the options it resolved for the whole tree (a speed trick
    for bench_lint's proto2+editions ratio): over every lint case tree with an envelope, the
    sizes are those Sizes resolves for the root's files itself; a tree declaring a name twice
    is resolved again."""
    from erc_codec import SchemaError
    from erc_schema import Sizes, load_schema, resolve_options

    compared = 0
    for folder in sorted(CASES.glob("**/new")) + sorted(CASES.glob("**/old")):
        try:
            schema = load_schema(folder, "PBEnvelope")
            plain = Sizes(schema).all()
        except SchemaError:
            continue
        revision = build(load_tree(folder))
        assert revision.nanopb().unique, folder
        assert Sizes(schema, resolved=revision.nanopb()).all() == plain, folder
        compared += 1
    assert compared >= 25
    twice = resolve_options(CASES, [])
    twice.unique = False  # as resolve_options marks a tree declaring a name twice (below)
    assert Sizes(schema, resolved=twice).all() == plain


def test_resolved_options_say_when_two_files_declare_one_name(tmp_path: Path) -> None:
    for name in ("a.proto", "b.proto"):
        (tmp_path / name).write_text('syntax = "proto3";\nmessage M { int32 x = 1; }\n')
    (tmp_path / "c.proto").write_text('syntax = "proto3";\nmessage N { int32 x = 1; }\n')
    files = {  # two protoc runs: one would refuse the second M
        f.name: f
        for run in (["a.proto", "c.proto"], ["b.proto"])
        for f in compile_files(tmp_path, run).file
    }
    from erc_schema import resolve_options

    assert resolve_options(tmp_path, [files["a.proto"], files["c.proto"]]).unique
    assert not resolve_options(tmp_path, list(files.values())).unique
