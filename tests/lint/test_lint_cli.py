"""The erc-lint command: exit statuses, one-line errors, what it loads, all its output
delivered, the pre-commit hook."""

import ast
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import REPO
from lint_support import erc_lint_cli, tree

import erc_lint
from erc_lint.rules import CATEGORIES


def test_exit_codes(tmp_path: Path) -> None:
    old = tree(tmp_path / "old", {"a.proto": "message A { float x = 1; }\n"})
    renamed = tree(tmp_path / "renamed", {"a.proto": "message A { float y = 1; }\n"})
    retyped = tree(tmp_path / "retyped", {"a.proto": "message A { sint32 x = 1; }\n"})
    assert erc_lint_cli(str(old), str(old)).returncode == 0
    warned = erc_lint_cli(str(old), str(renamed))
    assert warned.returncode == 0  # a warning only
    assert "FIELD_RENAMED (warning)" in warned.stdout
    assert erc_lint_cli(str(old), str(retyped)).returncode == 1
    missing = erc_lint_cli(str(old), str(tmp_path / "nowhere"))
    assert missing.returncode == 2
    assert missing.stderr.count("\n") == 1
    assert "Traceback" not in missing.stderr


def test_rules_lists_every_rule_then_every_category() -> None:
    rules, categories = erc_lint_cli("rules").stdout.split("\n\n")
    listed = [line.split() for line in rules.splitlines()]
    assert [line[0] for line in listed] == list(erc_lint.RULES)
    for line, rule in zip(listed, erc_lint.RULES.values(), strict=True):
        assert ",".join(rule.categories) in line
    assert [line.split()[0] for line in categories.splitlines()] == list(CATEGORIES)
    assert "[default]" in categories.splitlines()[0]  # WIRE


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
    done = erc_lint_cli(*args)
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
        "'erc_codec')) or m in ('subprocess', 'json', 'tomllib', 'tomli', 'asyncio', "
        "'tempfile')))"
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
    unused = {
        "erc_lint._history",
        "erc_lint.cli._ledger",
        "erc_lint._ledger",
        "erc_lint.cli._rules",
    }
    unused |= {"subprocess", "json", "tomllib", "tomli"}  # git, --format json, a configuration
    if sys.version_info < (3, 11):  # 3.10's standard library imports it: click → uuid → platform
        unused.remove("subprocess")
    unused |= {"asyncio"}  # erc_codec's UDP endpoint runs in a loop; importing it needs none
    if hasattr(os, "memfd_create"):  # protoc's scratch files in memory: no scratch folder
        unused |= {"tempfile"}
    assert not loaded & unused
    assert [m for m in loaded if m.split(".")[0] == "erc_codec"] == []  # erc_schema is enough


def test_the_command_delivers_all_its_output_before_leaving_the_process(tmp_path: Path) -> None:
    """A report larger than a pipe's buffer (64 KiB) arrives whole, through a pipe and through a
    file, with the status of the run."""
    fields = "".join(f"  int32 f{k} = {k};\n" for k in range(1, 1201))
    old = tree(tmp_path / "old", {"a.proto": f"message A {{\n{fields}}}\n"})
    new = tree(tmp_path / "new", {"a.proto": "message A {}\n"})
    expected = erc_lint.lint(old, new)
    assert len(expected) == 1200
    piped = erc_lint_cli(str(old), str(new), "--format", "json")
    assert piped.returncode == 1
    assert len(piped.stdout) > 65536
    assert [json.loads(line)["message"] for line in piped.stdout.splitlines()] == [
        finding.text for finding in expected
    ]
    with (tmp_path / "report.txt").open("w") as sink:
        done = subprocess.run([sys.executable, "-m", "erc_lint", str(old), str(new)], stdout=sink)
    assert done.returncode == 1
    assert (tmp_path / "report.txt").read_text().count("FIELD_DELETED") == 1200


PLAIN = [sys.executable, "-c", "from erc_lint.cli import main; main()"]  # Python's own exit
QUICK = [sys.executable, "-m", "erc_lint"]  # erc_lint.cli.run, as the erc-lint console script


def test_the_quick_exit_gives_what_the_plain_exit_gives(tmp_path: Path) -> None:
    """erc-lint leaves its process with os._exit once its output is flushed (``cli.run``, for
    bench_lint's ratio to buf): every command gives that way the output, status and files the
    plain group (``cli.main``, ended by Python's shutdown) gives. Findings past a pipe's buffer,
    to a pipe and to a file; none; a usage error; a failure to run; SARIF; a baseline written;
    a ledger written."""
    fields = "".join(f"  int32 f{k} = {k};\n" for k in range(1, 1201))
    old = tree(tmp_path / "old", {"a.proto": f"message A {{\n{fields}}}\n"})
    new = tree(tmp_path / "new", {"a.proto": "message A {}\n"})
    cases = [
        [str(old), str(new), "--format", "json"],
        [str(old), str(old)],
        [str(old), str(tmp_path / "nowhere")],
        ["chek", str(old)],
        ["--format", "sarif", str(old), str(new)],
        ["baseline", str(old), str(new), "-o", "{out}/erc-lint.baseline"],
        ["ledger", "update", str(new), "--ledger", "{out}/erc-lint.lock"],
        ["rules"],
    ]
    for args in cases:
        given = []
        for way, command in (("plain", PLAIN), ("quick", QUICK)):
            out = tmp_path / way / str(cases.index(args))
            out.mkdir(parents=True)
            with (out.parent / f"{out.name}.stdout").open("wb") as sink:
                to_file = subprocess.run(
                    [*command, *(arg.format(out=out) for arg in args)], stdout=sink, cwd=out
                )
            piped = subprocess.run(
                [*command, *(arg.format(out=out) for arg in args)], capture_output=True, cwd=out
            )
            written = {path.name: path.read_bytes() for path in sorted(out.iterdir())}
            report = (out.parent / f"{out.name}.stdout").read_bytes()
            seen = (piped.returncode, to_file.returncode, piped.stdout, report, piped.stderr)
            given.append(repr((seen, written)).replace(str(out), "OUT"))
        assert given[0] == given[1], args
    pyproject = (REPO / "pyproject.toml").read_text()
    assert '\nerc-lint = "erc_lint.cli:run"\n' in pyproject


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
    os.close(2)


def _close_stdout() -> None:
    os.close(1)


def test_the_pre_commit_hook_compares_against_head(tmp_path: Path) -> None:
    hooks = (REPO / ".pre-commit-hooks.yaml").read_text()
    entry = hooks.split("entry: ", 1)[1].splitlines()[0]
    args = json.loads(hooks.split("\n  args: ", 1)[1].splitlines()[0])
    assert entry == "erc-lint"
    repo = tree(tmp_path, {"proto/a.proto": "message A { float x = 1; }\n"})
    git = ["git", "-c", "user.name=t", "-c", "user.email=t@t.invalid"]
    for command in (["init", "-q"], ["add", "."], ["commit", "-qm", "one"]):
        subprocess.run([*git, *command], cwd=repo, check=True)
    assert erc_lint_cli(*args, cwd=repo).returncode == 0
    (repo / "proto" / "a.proto").write_text('syntax = "proto3";\nmessage A { sint32 x = 1; }\n')
    broken = erc_lint_cli(*args, cwd=repo)
    assert broken.returncode == 1
    assert broken.stdout.startswith("proto/a.proto:2:13: FIELD_TYPE_CHANGED")


@pytest.mark.parametrize("output", ["text", "github"])
def test_a_file_name_that_is_not_utf8_is_reported_as_its_bytes(tmp_path: Path, output: str) -> None:
    """Whatever the locale's encoding (here UTF-8, strict), the finding's path is the name's
    own bytes, as ``ls`` prints them, and the status is the findings'."""
    root = tree(tmp_path / "tree", {"a.proto": "message A { oops }\n"})
    os.rename(root / "a.proto", os.fsencode(root) + b"/x\xff.proto")
    done = subprocess.run(
        [sys.executable, "-m", "erc_lint", "check", str(root), "--format", output],
        capture_output=True,
        env={**os.environ, "PYTHONIOENCODING": "utf-8:strict"},
    )
    assert (done.returncode, done.stderr) == (1, b"1 error, 0 warnings in 1 file\n")
    assert b"x\xff.proto" in done.stdout
    assert b"File name is not UTF-8" in done.stdout
