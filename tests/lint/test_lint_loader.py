"""erc_lint's loader: every file compiled on its own terms, imports resolved whatever their
spelling, what loading met returned as load problems."""

import re
import subprocess
import sys
from pathlib import Path

from lint_support import SHAPES, protoc_edition, rules, tree

import erc_lint
from erc_lint import Config
from erc_lint._loader import LoadProblem, load_tree
from erc_schema import Location, imports


def test_imports_resolve_whatever_their_spelling(tmp_path: Path) -> None:
    root = tree(tmp_path / "t", SHAPES)
    assert erc_lint.lint(root, root) == []


def test_imports_are_found_as_protoc_reads_them(tmp_path: Path) -> None:
    """Single quotes, comments between the tokens, none needed before the name; adjacent
    literals joined, over lines too; escapes unescaped. None inside a comment or a string, nor
    in an identifier that starts with ``import``."""
    user = (
        '// import "commented_out.proto";\n'
        "import /* the shape */ 'shape.proto' ;\n"
        'import // the unit\n  public "unit.proto";\n'
        "message User {\n  Shape shape = 1;\n  Unit unit = 2;\n"
        '  string note = 3 [json_name = "import \\"x.proto\\";"];\n}\n'
    )
    root = tree(
        tmp_path / "t",
        {
            "components/a/shape.proto": "message Shape { float width = 1; }\n",
            "components/b/unit.proto": "message Unit { int32 id = 1; }\n",
            "components/c/user.proto": user,
        },
    )
    assert erc_lint.lint(root, root) == []

    # Each reads as the bare name b.proto (the file is sub/b.proto): protoc takes them all, given
    # sub/ as an include folder, and the linter respells them all to compile without it.
    spellings = [
        'import"b.proto";',
        'import weak"b.proto";',
        "import public'b.proto';",
        'import "b." "proto";',
        'import "b" // joined\n  /* over lines */ ".proto"\n  ;',
        'import "b\\x2eproto";',
        "import '\\142\\56pr\\X6fto';",
        'import "\\u0062.\\U00000070roto";',
    ]
    importers = {
        f"a{i}.proto": f"{s}\nmessage A{i} {{ B b = 1; }}\n" for i, s in enumerate(spellings)
    }
    root = tree(tmp_path / "spellings", {"sub/b.proto": "message B {}\n", **importers})
    protoc = [sys.executable, "-m", "grpc_tools.protoc", f"-I{root}", f"-I{root / 'sub'}"]
    out = f"--descriptor_set_out={tmp_path / 'out.pb'}"
    assert subprocess.run([*protoc, out, *importers], cwd=root).returncode == 0
    for spelling in spellings:
        assert [name for _, _, name in imports(spelling)] == ["b.proto"], spelling
    assert erc_lint.lint(root, root) == []
    assert [name for _, _, name in imports('import "sub/"\n  "b.proto";')] == ["sub/b.proto"]
    never = 'important "a.proto"; importx "b.proto"; my_import "c.proto"; "import \\"d.proto\\";"'
    assert list(imports(never)) == []
    # Respelled over fewer lines, lines would shift: protoc's locations after it stay true.
    lines = tree(
        tmp_path / "lines",
        {
            "sub/b.proto": "message B {}\n",
            "a.proto": spellings[4] + "\nmessage A { Nope b = 1; }\n",
        },
    )
    assert [(f.line, f.text) for f in erc_lint.lint(lines, lines)] == [
        (5, '"Nope" is not defined.')
    ]


def test_an_import_matching_two_files_is_ambiguous(tmp_path: Path) -> None:
    root = tree(
        tmp_path / "t",
        {
            "a/shape.proto": "message ShapeA { float w = 1; }\n",
            "b/shape.proto": "message ShapeB { float w = 1; }\n",
            "user.proto": 'import "shape.proto";\nmessage User { int32 x = 1; }\n',
        },
    )
    findings = erc_lint.lint(root, root)
    (ambiguous,) = [f for f in findings if f.rule == "IMPORT_AMBIGUOUS"]
    assert (
        ambiguous.message
        == 'Import "shape.proto" is ambiguous: it matches a/shape.proto, b/shape.proto.'
    )
    assert (ambiguous.path, ambiguous.line, ambiguous.column) == (str(root / "user.proto"), 2, 8)
    assert ambiguous.severity == "warning"  # OLD has it too


def test_include_folders_resolve_imports_from_outside(tmp_path: Path) -> None:
    shared = tree(tmp_path / "shared", {"units/units.proto": "message Metres { float m = 1; }\n"})
    root = tree(
        tmp_path / "t",
        {"walk.proto": 'import "units/units.proto";\nmessage Walk { Metres length = 1; }\n'},
    )
    assert "COMPILE" in rules(erc_lint.lint(root, root))
    assert erc_lint.lint(root, root, includes=[shared]) == []


def test_broken_files_are_reported_and_hide_nothing(tmp_path: Path) -> None:
    files = {f"m{i}.proto": f"message M{i} {{ float v = 1; }}\n" for i in range(9)}
    old = tree(tmp_path / "old", files)
    files["m3.proto"] = "message M3 { Nope v = 1; }\n"
    files["m7.proto"] = "message M7 { float v = 1 }\n"
    files["m5.proto"] = "message M5 { sint32 v = 1; }\n"
    new = tree(tmp_path / "new", files)
    findings = erc_lint.lint(old, new)
    assert [(Path(f.path).name, f.line, f.rule) for f in findings] == [
        ("m3.proto", 2, "COMPILE"),
        ("m5.proto", 2, "FIELD_TYPE_CHANGED"),
        ("m7.proto", 2, "COMPILE"),
    ]
    assert findings[0].text == '"Nope" is not defined.'
    assert findings[0].column == 14
    # The broken files' messages are unknown in NEW, not deleted: only COMPILE speaks of them.
    assert all(f.severity == "error" for f in findings)


def test_proto2_groups_load(tmp_path: Path) -> None:
    group = tmp_path / "t" / "g.proto"
    group.parent.mkdir()
    group.write_text(
        'syntax = "proto2";\nmessage G { optional group Item = 1 { optional int32 x = 2; } }\n'
    )
    assert erc_lint.lint(group.parent, group.parent) == []


def test_excluded_files_stay_importable(tmp_path: Path) -> None:
    root = tree(
        tmp_path / "t",
        {
            "legacy/l.proto": "message L { int32 x = 1; }\n",
            "sub/l2.proto": "message L2 { int32 x = 1; }\n",
            "a.proto": 'import "legacy/l.proto";\nimport "l2.proto";\n'
            "message A { L l = 1; L2 l2 = 2; }\n",
        },
    )
    assert erc_lint.lint(root, root, Config(exclude=("legacy/*",))) == []


def test_protoc_warnings_read_as_protoc_wrote_them(tmp_path: Path) -> None:
    """protoc warns through absl logging; its log prefixes and notice are not part of a finding."""
    (tmp_path / "new").mkdir()
    (tmp_path / "new" / "a.proto").write_text("message A { int32 x = 1; }\n")  # no syntax line
    findings = erc_lint.check(tmp_path / "new")  # against nothing (lint refuses an empty OLD)
    assert [(f.rule, f.line, f.column) for f in findings] == [("COMPILE", 1, 1), ("COMPILE", 1, 13)]
    assert findings[0].text.startswith("No edition or syntax specified for the proto file")
    assert findings[1].message == 'Expected "required", "optional", or "repeated".'


def test_the_loader_returns_load_problems_not_findings(tmp_path: Path) -> None:
    """What loading met is a record of its own (kind, key, location, text); the rules of the
    same names make findings of it."""
    root = tree(
        tmp_path / "t",
        {
            "a/shape.proto": "message ShapeA { float w = 1; }\n",
            "b/shape.proto": "message ShapeB { float w = 1; }\n",
            "user.proto": 'import "shape.proto";\nmessage User { int32 x = 1; }\n',
            "broken.proto": "message Broken { Nope x = 1; }\n",
        },
    )
    loaded = load_tree(root)
    assert [(p.kind, p.key) for p in sorted(loaded.problems)] == [
        ("COMPILE", 'broken.proto:"Nope" is not defined.'),
        ("COMPILE", 'user.proto:Import "shape.proto" was not found or had errors.'),
        ("COMPILE", "user.proto:shape.proto: File not found."),
        ("IMPORT_AMBIGUOUS", "user.proto:shape.proto"),
    ]
    assert sorted(loaded.problems)[-1] == LoadProblem(
        "IMPORT_AMBIGUOUS",
        "user.proto:shape.proto",
        Location(str(root / "user.proto"), 2, 8),
        'Import "shape.proto" is ambiguous: it matches a/shape.proto, b/shape.proto.',
    )
    assert loaded.failed == {"broken.proto", "user.proto"}


def test_editions_compile_up_to_what_the_bundled_protoc_supports(tmp_path: Path) -> None:
    """grpcio-tools' protoc compiles edition 2023, and 2024 from grpcio-tools 1.81 (libprotoc
    34) on; a later edition is protoc's own COMPILE finding, as the README says."""
    latest = protoc_edition()
    assert latest in (2023, 2024)
    files = {
        f"e{edition}.proto": f'edition = "{edition}";\nmessage E{edition} {{ int32 x = 1; }}\n'
        for edition in ("2023", "2024")
    }
    files["unstable.proto"] = 'edition = "UNSTABLE";\nmessage Later { int32 x = 1; }\n'
    root = tmp_path / "t"
    root.mkdir()
    for name, text in files.items():
        (root / name).write_text(text)
    loaded = load_tree(root)
    compiled = {"e2023.proto", "e2024.proto"} if latest == 2024 else {"e2023.proto"}
    assert set(loaded.files) == compiled
    later = ["UNSTABLE"] if latest == 2024 else ["2024", "UNSTABLE"]
    assert [(p.location.path, p.location.line) for p in loaded.problems] == [
        (str(root / ("unstable.proto" if edition == "UNSTABLE" else f"e{edition}.proto")), 1)
        for edition in later
    ]
    texts = [p.text for p in loaded.problems]
    if latest == 2023:  # grpcio-tools before 1.81: its protoc knows no edition past 2023
        assert texts[0] == (
            "e2024.proto: is a file using edition 2024, which is later than the protoc maximum "
            "supported edition 2023."
        )
    # UNSTABLE: "later than ... 2024" from 1.81 on; 'Unknown edition "UNSTABLE".' before (the
    # floor's 1.74), located in unstable.proto as asserted above.
    assert "UNSTABLE" in texts[-1], texts


def test_the_import_scan_matches_the_plain_keyword_pattern() -> None:
    """erc_schema's import scan spells its keyword ``i(?<!\\wi)mport\\b`` so that re can
    skip ahead to the characters a match starts with (bench_lint's ratio to buf): it finds what
    the plain pattern, with ``\\bimport\\b``, finds, at the start of a text, after word and other
    characters, in comments, strings and identifiers, whatever follows; and it stops at the last
    ``import`` of a text, where the plain scan goes on to its end."""
    string = r'"(?:\\.|[^"\\\n])*"|\'(?:\\.|[^\'\\\n])*\''
    comment = r"//[^\n]*|/\*.*?\*/"
    gap = rf"(?:[ \t\n\r\v\f]|{comment})"
    plain = re.compile(
        rf"{comment}|{string}|\bimport\b(?:{gap}*(?:public|weak)\b)?"
        rf"{gap}*({string})((?:{gap}*(?:{string}))*){gap}*;",
        re.DOTALL,
    )
    pieces = [
        "import", "import ", "ximport", "_import", "import_", "importx", "é", "import\t",
        "9import", ".import", '"a.proto"', "'b.proto'", '"un', "'un", "//", "/*", "*/", "\n",
        " ", ";", "public", "weak", "\\", "\\x41", "\\u00e9", "package", "message A {}", "i",
        "mport", ".proto",
    ]  # fmt: skip
    texts = [a + b + c for a in pieces for b in pieces for c in pieces]
    texts += [" ".join(pieces), "".join(pieces), "\n".join(reversed(pieces))]
    for text in texts:
        found = [(start, end) for start, end, _ in imports(text)]
        spans = [(m.start(1), m.end(2)) for m in plain.finditer(text) if m[1] is not None]
        assert found == spans, text
