"""erc_lint's loader, configuration and command line (the rules have tests/lint_cases/)."""

import ast
import json
import subprocess
import sys
from pathlib import Path

import pytest

import erc_lint
from erc_lint import Config, Finding


def tree(root: Path, files: dict[str, str]) -> Path:
    for name, text in files.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text('syntax = "proto3";\n' + text)
    return root


def run(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "erc_lint", *args], capture_output=True, text=True, cwd=cwd
    )


def rules(findings: list[Finding]) -> list[str]:
    return [finding.rule for finding in findings]


SHAPES = {
    "components/a/shape.proto": "message Shape { float width = 1; }\n",
    "components/b/prefixed.proto": 'import "ERC-Protobufs/components/a/shape.proto";\n'
    "message Prefixed { Shape shape = 1; }\n",
    "components/b/bare.proto": 'import "shape.proto";\nmessage Bare { Shape shape = 1; }\n',
    "proto/components/c/rooted.proto": 'import "components/a/shape.proto";\n'
    "message Rooted { Shape shape = 1; }\n",
}


def test_imports_resolve_whatever_their_spelling(tmp_path: Path) -> None:
    root = tree(tmp_path / "t", SHAPES)
    assert erc_lint.lint(root, root) == []


def test_imports_are_found_as_protoc_reads_them(tmp_path: Path) -> None:
    """Single quotes, comments between the tokens, none needed before the name; adjacent
    literals joined, over lines too; escapes unescaped. None inside a comment or a string, nor
    in an identifier that starts with ``import``."""
    from erc_codec.schema import imports

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
    assert [(f.line, f.message) for f in erc_lint.lint(lines, lines)] == [
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
    assert findings[0].message == '"Nope" is not defined.'
    assert findings[0].column == 14
    # The broken files' messages are unknown in NEW, not deleted: only COMPILE speaks of them.
    assert all(f.severity == "error" for f in findings)


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
    assert str(root / "gps.proto") in collision.message
    assert str(root / "leftover/message_types.proto") in collision.message


def test_exit_codes(tmp_path: Path) -> None:
    old = tree(tmp_path / "old", {"a.proto": "message A { float x = 1; }\n"})
    renamed = tree(tmp_path / "renamed", {"a.proto": "message A { float y = 1; }\n"})
    retyped = tree(tmp_path / "retyped", {"a.proto": "message A { sint32 x = 1; }\n"})
    assert run(str(old), str(old)).returncode == 0
    warned = run(str(old), str(renamed))
    assert warned.returncode == 0  # a warning only
    assert "FIELD_RENAMED (warning)" in warned.stdout
    assert run(str(old), str(retyped)).returncode == 1
    missing = run(str(old), str(tmp_path / "nowhere"))
    assert missing.returncode == 2
    assert missing.stderr.count("\n") == 1
    assert "Traceback" not in missing.stderr


def test_configuration_in_new_tree(tmp_path: Path) -> None:
    old = tree(tmp_path / "old", {"a.proto": "message A { float x = 1; }\n"})
    new = tree(
        tmp_path / "new",
        {
            "a.proto": "message A { float y = 1; }\n",
            "drafts/broken.proto": "message Broken { Nope x = 1; }\n",
        },
    )
    assert set(rules(erc_lint.lint(old, new))) == {"FIELD_RENAMED", "COMPILE"}
    (new / "pyproject.toml").write_text(
        '[tool.erc-lint]\nignore = ["FIELD_RENAMED"]\nexclude = ["drafts/*"]\n'
    )
    done = run(str(old), str(new))
    assert (done.returncode, done.stdout) == (0, "")
    bad = tmp_path / "bad.toml"
    bad.write_text('[tool.erc-lint]\nignore = ["NO_SUCH_RULE"]\n')
    refused = run(str(old), str(new), "--config", str(bad))
    assert refused.returncode == 2
    assert "NO_SUCH_RULE" in refused.stderr


def test_roots_come_from_configuration(tmp_path: Path) -> None:
    files = {
        "env.proto": "message Item { repeated int32 values = 1; }\n"
        "message Env { oneof payload { Item item = 1; } }\n"
    }
    old = tree(tmp_path / "old", {"env.proto": "message Item { int32 value = 1; }\n"})
    new = tree(tmp_path / "new", files)
    assert "EMBEDDED_REPEATED" not in rules(erc_lint.lint(old, new))
    found = erc_lint.lint(old, new, Config(roots=("Env",)))
    (repeated,) = [f for f in found if f.rule == "EMBEDDED_REPEATED"]
    assert "Env.item.values" in repeated.message


def test_output_formats(tmp_path: Path) -> None:
    old = tree(tmp_path / "old", {"a.proto": "message A { float x = 1; float z = 2; }\n"})
    new = tree(tmp_path / "new", {"a.proto": "message A { float y = 1; }\n"})
    lines = [
        json.loads(line) for line in run(str(old), str(new), "--format", "json").stdout.splitlines()
    ]
    assert [(line["rule"], line["severity"], line["in_old"]) for line in lines] == [
        ("FIELD_RENAMED", "warning", False),
        ("FIELD_DELETED", "error", True),
    ]
    assert set(lines[0]) >= {"rule", "severity", "path", "line", "column", "message"}
    github = run(str(old), str(new), "--format", "github").stdout.splitlines()
    assert github[0].startswith(f"::warning file={new / 'a.proto'},line=2,col=")
    assert github[1].startswith(f"::error file={old / 'a.proto'},line=2,col=")
    assert "::FIELD_DELETED " in github[1]


def test_rules_lists_every_rule() -> None:
    listed = run("rules").stdout.splitlines()
    assert [line.split()[0] for line in listed] == list(erc_lint.RULES)


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


def test_the_pre_commit_hook_compares_against_head(tmp_path: Path) -> None:
    hooks = (Path(__file__).parent.parent / ".pre-commit-hooks.yaml").read_text()
    entry = hooks.split("entry: ", 1)[1].splitlines()[0]
    args = json.loads(hooks.split("\n  args: ", 1)[1].splitlines()[0])
    assert entry == "erc-lint"
    repo = tree(tmp_path, {"proto/a.proto": "message A { float x = 1; }\n"})
    git = ["git", "-c", "user.name=t", "-c", "user.email=t@t.invalid"]
    for command in (["init", "-q"], ["add", "."], ["commit", "-qm", "one"]):
        subprocess.run([*git, *command], cwd=repo, check=True)
    assert run(*args, cwd=repo).returncode == 0
    (repo / "proto" / "a.proto").write_text('syntax = "proto3";\nmessage A { sint32 x = 1; }\n')
    broken = run(*args, cwd=repo)
    assert broken.returncode == 1
    assert broken.stdout.startswith("proto/a.proto:2:13: FIELD_TYPE_CHANGED")


def test_before_the_first_commit_head_is_an_empty_tree(tmp_path: Path) -> None:
    """The hook runs on a repository's first commit too: nothing came before, nothing broke."""
    repo = tree(tmp_path, {"proto/a.proto": "message A { float x = 1; }\n"})
    subprocess.run(["git", "init", "-q"], cwd=repo, check=True)
    first = run(".#ref=HEAD,subdir=proto", "proto", cwd=repo)
    assert (first.returncode, first.stdout, first.stderr) == (0, "", "")
    # Only HEAD: any other name for a missing commit is still a mistake.
    missing = run(".#branch=main,subdir=proto", "proto", cwd=repo)
    assert missing.returncode == 2
    assert "no commit named 'main'" in missing.stderr
    # The same repository, once it has commits, with HEAD detached from any branch: a real HEAD.
    git = ["git", "-c", "user.name=t", "-c", "user.email=t@t.invalid"]
    for command in (["add", "."], ["commit", "-qm", "one"], ["checkout", "-q", "--detach"]):
        subprocess.run([*git, *command], cwd=repo, check=True)
    (repo / "proto" / "a.proto").write_text("message A { sint32 x = 1; }\n")
    assert run(".#ref=HEAD,subdir=proto", "proto", cwd=repo).returncode == 1


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


def test_old_damage_in_an_imported_file_stays_old_when_its_importer_is_renamed(
    tmp_path: Path,
) -> None:
    broken = {"b.proto": "message B { float x = 1 }\n"}
    users = 'import "b.proto";\nmessage {name} {{ B b = 1; }}\n'
    old = tree(tmp_path / "old", {**broken, "a.proto": users.format(name="A")})
    new = tree(tmp_path / "new", {**broken, "aa.proto": users.format(name="A")})
    (in_b,) = [f for f in erc_lint.lint(old, new) if f.path == str(new / "b.proto")]
    assert (in_b.rule, in_b.severity) == ("COMPILE", "warning")
    assert in_b.message == 'Expected ";". (imported by aa.proto)'


def test_github_annotations_escape_what_their_syntax_uses() -> None:
    from erc_lint._report import render

    finding = Finding("odd, name: 100%.proto", 3, 4, "COMPILE", 'Expected ";".\nthen 50%')
    assert render([finding], "github") == (
        "::error file=odd%2C name%3A 100%25.proto,line=3,col=4::"
        'COMPILE Expected ";".%0Athen 50%25\n'
    )


def test_a_file_old_could_not_compile_is_not_passed_over_in_silence(tmp_path: Path) -> None:
    old = tree(tmp_path / "old", {"a.proto": "message A { int32 x = 1; Missing m = 2; }\n"})
    new = tree(tmp_path / "new", {"a.proto": "message A { int32 x = 2; }\n"})
    findings = erc_lint.lint(old, new)
    assert [(f.rule, f.severity, f.in_old) for f in findings] == [("COMPILE", "warning", True)]
    assert "a.proto does not compile, so its messages were not compared" in findings[0].message


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


def test_reordered_enum_aliases_reuse_nothing(tmp_path: Path) -> None:
    enum = "enum E {{ option allow_alias = true; {} = 0; {} = 0; C = 1; }}\n"
    old = tree(tmp_path / "old", {"e.proto": enum.format("A", "B")})
    new = tree(tmp_path / "new", {"e.proto": enum.format("B", "A")})
    assert erc_lint.lint(old, new) == []


@pytest.mark.parametrize(
    ("setup", "complaint"),
    [
        ("empty", "no .proto file in NEW"),
        ("tool = 1\n", ""),
        ("[tool]\nerc-lint = 5\n", "tool.erc-lint must be a table"),
        ("[tool.other]\nx = 1\n", "no [tool.erc-lint] table"),
    ],
)
def test_what_cannot_run_exits_2_in_one_line(tmp_path: Path, setup: str, complaint: str) -> None:
    old = tree(tmp_path / "old", {"a.proto": "message A { float x = 1; }\n"})
    new = tmp_path / "new"
    if setup == "empty":
        new.mkdir()
        done = run(str(old), str(new))
    else:
        tree(new, {"a.proto": "message A { float x = 1; }\n"})
        config = tmp_path / "config.toml"
        config.write_text(setup)
        done = run(str(old), str(new), "--config", str(config))
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1
    assert complaint in done.stderr
    assert "Traceback" not in done.stderr


@pytest.mark.parametrize(
    ("args", "complaint"),
    [
        (["--bogus"], "No such option '--bogus'"),
        (["only-one"], "Missing argument 'NEW'"),
        (["check", ".", "--format", "xml"], "Invalid value for '--format'"),
        (["ledger", "update", ".", "--ledger", "."], "Invalid value for '--ledger'"),
    ],
)
def test_usage_errors_exit_2_in_one_line(args: list[str], complaint: str) -> None:
    done = run(*args)
    assert done.returncode == 2
    assert done.stderr.startswith(f"Error: {complaint}")
    assert done.stderr.count("\n") == 1


def test_linting_folders_leaves_what_it_does_not_use_unloaded(tmp_path: Path) -> None:
    """Start-up is most of a CI run's time: `erc-lint OLD NEW` imports what it uses."""
    old = tree(tmp_path / "old", {"a.proto": "message A { int32 x = 1; }\n"})
    script = (  # what the interpreter's start-up loaded (site's .pth files) does not count
        "import sys\nbefore = set(sys.modules)\nfrom erc_lint.cli import main\n"
        "try:\n    main([sys.argv[1], sys.argv[1]])\nexcept SystemExit:\n    pass\n"
        "print(sorted(m for m in set(sys.modules) - before if m.startswith(('erc_lint.', "
        "'erc_codec.')) or m in ('subprocess', 'json', 'tomllib', 'asyncio')))"
    )
    done = subprocess.run(  # where no pyproject.toml is, as in bench_lint
        [sys.executable, "-c", script, str(old)],
        capture_output=True,
        text=True,
        check=True,
        cwd=tmp_path,
    )
    loaded = set(ast.literal_eval(done.stdout))
    assert "erc_lint._run" in loaded  # it did lint
    unused = {"erc_lint._history", "erc_lint.cli._ledger", "erc_lint._ledger"}
    unused |= {"erc_codec.cli._main", "erc_codec.cli._decode", "erc_codec.strategies"}
    unused |= {"subprocess", "json", "tomllib"}  # git inputs, --format json, a configuration
    unused |= {"asyncio"}  # erc_codec's UDP endpoint runs in a loop; importing it needs none
    assert not loaded & unused


def test_protoc_warnings_read_as_protoc_wrote_them(tmp_path: Path) -> None:
    """protoc warns through absl logging; its log prefixes and notice are not part of a finding."""
    (tmp_path / "old").mkdir()
    (tmp_path / "new").mkdir()
    (tmp_path / "new" / "a.proto").write_text("message A { int32 x = 1; }\n")  # no syntax line
    findings = erc_lint.lint(tmp_path / "old", tmp_path / "new")
    assert [(f.rule, f.line, f.column) for f in findings] == [("COMPILE", 1, 1), ("COMPILE", 1, 13)]
    assert findings[0].message.startswith("No edition or syntax specified for the proto file")
    assert findings[1].message == 'Expected "required", "optional", or "repeated".'


def test_the_command_delivers_all_its_output_before_leaving_the_process(tmp_path: Path) -> None:
    """A report larger than a pipe's buffer (64 KiB) arrives whole, through a pipe and through a
    file, with the status of the run."""
    fields = "".join(f"  int32 f{k} = {k};\n" for k in range(1, 1201))
    old = tree(tmp_path / "old", {"a.proto": f"message A {{\n{fields}}}\n"})
    new = tree(tmp_path / "new", {"a.proto": "message A {}\n"})
    expected = erc_lint.lint(old, new)
    assert len(expected) == 1200
    piped = run(str(old), str(new), "--format", "json")
    assert piped.returncode == 1
    assert len(piped.stdout) > 65536
    assert [json.loads(line)["message"] for line in piped.stdout.splitlines()] == [
        finding.message for finding in expected
    ]
    with (tmp_path / "report.txt").open("w") as sink:
        done = subprocess.run([sys.executable, "-m", "erc_lint", str(old), str(new)], stdout=sink)
    assert done.returncode == 1
    assert (tmp_path / "report.txt").read_text().count("FIELD_DELETED") == 1200


@pytest.mark.parametrize("module", ["erc_lint", "erc_codec"])
def test_output_that_cannot_be_written_is_one_line_and_a_status(module: str) -> None:
    """Started with standard output closed, a command writes nothing and succeeds; with an
    output that refuses the bytes (a full disk), it says so in one line and exits 2."""
    command = [sys.executable, "-m", module, "--help"]
    closed = subprocess.run(
        command, capture_output=False, stderr=subprocess.PIPE, text=True, preexec_fn=_close_stdout
    )
    assert (closed.returncode, closed.stderr) == (0, "")
    if not Path("/dev/full").exists():
        pytest.skip("no /dev/full here")
    with open("/dev/full", "w") as full:
        refused = subprocess.run(command, stdout=full, stderr=subprocess.PIPE, text=True)
    assert refused.returncode == 2
    assert refused.stderr == "Error: [Errno 28] No space left on device\n"


def test_a_run_started_without_standard_error_still_compiles_and_reports(tmp_path: Path) -> None:
    """protoc's diagnostics are caught through descriptor 2: a process started with it closed
    still gets every finding, protoc's own errors included, and the right status."""
    old = tree(tmp_path / "old", {"a.proto": "message A { float x = 1; }\n"})
    new = tree(
        tmp_path / "new",
        {"a.proto": "message A { sint32 x = 1; }\n", "b.proto": "message B { oops }\n"},
    )
    done = subprocess.run(
        [sys.executable, "-m", "erc_lint", str(old), str(new)],
        stdout=subprocess.PIPE,
        text=True,
        preexec_fn=_close_stderr,
    )
    assert done.returncode == 1
    assert [line.split(" ")[1] for line in done.stdout.splitlines()] == [
        "FIELD_TYPE_CHANGED",
        "COMPILE",
    ]


def _close_stderr() -> None:
    import os

    os.close(2)


def _close_stdout() -> None:
    import os

    os.close(1)


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
                    'on enum "Mode" was deleted without reserving its number.',
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
    assert [(f.rule, f.message) for f in findings] == expected


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
    assert [(f.rule, f.message) for f in erc_lint.lint(old, renamed)] == [
        ("FIELD_RENAMED", 'Field "1" on message "Stats" changed name from "counts" to "totals".')
    ]
    retyped = tree(
        tmp_path / "retyped", {"a.proto": "message Stats {\n  map<string, sint32> counts = 1;\n}\n"}
    )
    (finding,) = erc_lint.lint(old, retyped)
    assert (finding.rule, finding.line, finding.column) == ("FIELD_TYPE_CHANGED", 3, 3)
    assert finding.message == (
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
    assert [(f.rule, f.message) for f in erc_lint.lint(old, beside)] == [
        ("FIELD_RENAMED", 'Field "1" on message "Stats" changed name from "counts" to "totals".')
    ]
    # Renamed and retyped at once: both, the type change named in the new entry.
    both = tree(
        tmp_path / "both", {"a.proto": "message Stats {\n  map<string, float> totals = 1;\n}\n"}
    )
    assert [f.rule for f in erc_lint.lint(old, both)] == ["FIELD_RENAMED", "FIELD_TYPE_CHANGED"]


READING = {
    "envelope.proto": 'import "reading.proto";\n'
    "message PBEnvelope { oneof payload { Reading reading = 1; } }\n",
    "reading.proto": 'import "nanopb.proto";\n'
    "enum Mode { MODE_IDLE = 0; MODE_RUN = 1; }\n"
    "message Reading {\n  message Raw { uint32 count = 1 [(nanopb).int_size = IS_8]; }\n"
    "  string label = 1;\n  Mode mode = 2;\n  Raw raw = 3;\n}\n",
    "reading.options": "Reading.label max_size:16\n",
}


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
    messages = [f.message for f in erc_lint.lint(old, new) if f.rule == "ENVELOPE_SIZE_GROWN"]
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
    messages = [f.message for f in erc_lint.lint(old, new) if f.rule == "ENVELOPE_SIZE_GROWN"]
    assert messages == [
        'Maximum size of message "PBEnvelope" grew from 7 to 16 bytes: receivers built with the '
        "old PBEnvelope_size drop the longer datagrams."
    ]


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
    assert [(f.rule, f.message) for f in erc_lint.lint(old, renamed)] == [
        (
            "MESSAGE_RENAMED",
            'Message "ArmBoardStatus" was renamed to "ArmStatus"; its fields are unchanged.',
        )
    ]
    changed = STATUS.replace("ArmBoard", "Arm").replace("float angle", "double angle")
    changed = changed.replace("MODE_RUN = 1;", "MODE_RUN = 2;")
    retyped = tree(tmp_path / "retyped", {"a.proto": changed})
    assert [(f.rule, f.message) for f in erc_lint.lint(old, retyped)][1:] == [
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
    assert sorted((f.rule, f.message.split(" on ")[-1]) for f in erc_lint.lint(old, new)) == [
        ("ENUM_VALUE_DELETED", 'enum "Outer2.E" was deleted without reserving its number.'),
        ("FIELD_TYPE_CHANGED", 'message "Outer2.Inner" changed type from "int32" to "string".'),
        ("MESSAGE_DELETED", 'Previously present message "Foo" was deleted.'),
        ("MESSAGE_RENAMED", 'Message "Outer" was renamed to "Outer2"; its fields are unchanged.'),
    ]


def test_a_packaged_roots_size_is_named_as_nanopb_names_it(tmp_path: Path) -> None:
    text = "package acme.io;\nmessage A { fixed32 x = 1; }\nmessage Env { oneof p { A a = 1; } }\n"
    old = tree(tmp_path / "old", {"env.proto": text})
    new = tree(tmp_path / "new", {"env.proto": text.replace("x = 1;", "x = 1; fixed32 y = 2;")})
    (finding,) = erc_lint.lint(old, new, Config(roots=("acme.io.Env",)))
    assert finding.message == (
        'Maximum size of message "acme.io.Env" grew from 7 to 12 bytes: receivers built with '
        "the old acme_io_Env_size drop the longer datagrams."
    )


def test_the_loader_returns_load_problems_not_findings(tmp_path: Path) -> None:
    """What loading met is a record of its own (kind, key, location, text); the rules of the
    same names make findings of it."""
    from erc_codec.schema import Location
    from erc_lint._loader import LoadProblem, load_tree

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
    from erc_lint._loader import load_tree
    from erc_lint._model import build

    name, before, after = edit
    changed = {**READING, name: READING[name].replace(before, after)}
    revisions = []
    for side, files in (("old", READING), ("new", changed)):
        root = tree(tmp_path / side, files)
        (root / "reading.options").write_text(files["reading.options"])
        revisions.append(build(load_tree(root)))
    old, new = revisions
    assert (old.size_inputs("PBEnvelope") == new.size_inputs("PBEnvelope")) == same
    sizes = (old.max_size("PBEnvelope"), new.max_size("PBEnvelope"))
    assert None not in sizes
    if same:
        assert sizes[0] == sizes[1]


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
    assert [f.message.split(":")[0] for f in erc_lint.lint(old, new)] == [
        'Maximum size of message "PBEnvelope" grew from 2 to 13 bytes'
    ]
