"""erc-lint as a CI gate, run as a user runs it: every output format validated against its
published schema (``tests/formats``, sources named in its README), the summary line, --severity,
baselines, suppression comments, ignore_only, no silent pass, explanations, a closed pipe."""

import json
import os
import re
import subprocess
import sys
import urllib.parse
from pathlib import Path

import jsonschema  # type: ignore[import-untyped]
import junitparser
import pytest
import xmlschema
from conftest import TESTS
from git_support import Repo
from lint_support import erc_lint_cli, tree

FORMATS = TESTS / "formats"
OLD = {
    "arm.proto": "message Arm {\n  float shoulder = 1;\n  float elbow = 2;\n"
    "  uint32 wrist = 3;\n}\n",
    "gone.proto": "message Gone { float x = 1; }\n",
}
NEW = {
    "arm.proto": "message Arm {\n  float shoulder = 1;\n  string elbow = 2;\n}\n",
    "note.proto": "message Note { float y = 1; }\n",
}


@pytest.fixture
def pair(tmp_path: Path) -> Path:
    tree(tmp_path / "old", OLD)
    tree(tmp_path / "new", NEW)
    return tmp_path


def run(pair: Path, *args: str) -> subprocess.CompletedProcess[str]:
    return erc_lint_cli("old", "new", *args, cwd=pair)


def test_sarif_validates_against_the_sarif_2_1_0_schema(pair: Path) -> None:
    done = run(pair, "--format", "sarif")
    assert done.returncode == 1, done.stderr
    document = json.loads(done.stdout)
    schema = json.loads((FORMATS / "sarif-2.1.0-rtm.5.json").read_text())
    jsonschema.Draft4Validator(schema).validate(document)
    (only,) = document["runs"]
    rules = {rule["id"]: rule for rule in only["tool"]["driver"]["rules"]}
    assert "## Why is this bad?" in rules["FIELD_DELETED"]["help"]["text"]
    by_rule = {result["ruleId"]: result for result in only["results"]}
    deleted = by_rule["FIELD_DELETED"]["locations"][0]["physicalLocation"]
    assert deleted["artifactLocation"] == {"uri": "new/arm.proto"}  # the container in NEW
    assert deleted["region"]["startLine"] == 2
    gone = by_rule["MESSAGE_DELETED"]["locations"][0]["physicalLocation"]
    assert gone["artifactLocation"] == {"uri": "old/gone.proto", "uriBaseId": "OLD"}
    assert all(r["partialFingerprints"]["ercLintFinding/v1"] for r in only["results"])


def test_gitlab_code_quality_validates_against_its_documented_schema(pair: Path) -> None:
    done = run(pair, "--format", "gitlab")
    issues = json.loads(done.stdout)
    schema = json.loads((FORMATS / "gitlab-code-quality.json").read_text())
    jsonschema.Draft7Validator(schema).validate(issues)
    assert {issue["check_name"] for issue in issues} >= {"FIELD_DELETED", "FIELD_TYPE_CHANGED"}
    assert len({issue["fingerprint"] for issue in issues}) == len(issues)
    with pytest.raises(jsonschema.ValidationError):  # the schema can fail
        jsonschema.Draft7Validator(schema).validate([{**issues[0], "severity": "fatal"}])


def test_junit_validates_against_the_junit_schema_and_reads_as_junit(pair: Path) -> None:
    done = run(pair, "--format", "junit")
    xmlschema.XMLSchema(FORMATS / "junit-10.xsd").validate(done.stdout)
    report = junitparser.JUnitXml.fromstring(done.stdout)
    cases = [case for suite in report for case in suite]
    failed = [case for case in cases if not case.is_passed]
    assert {case.result[0].type for case in failed} >= {"FIELD_DELETED", "FIELD_TYPE_CHANGED"}
    clean = erc_lint_cli("new", "new", "--format", "junit", cwd=pair)
    xmlschema.XMLSchema(FORMATS / "junit-10.xsd").validate(clean.stdout)
    assert clean.returncode == 0


def test_msvs_lines_are_visual_studios_canonical_errors(pair: Path) -> None:
    lines = run(pair, "--format", "msvs").stdout.splitlines()
    canonical = re.compile(r"^[^()]+\(\d+,\d+\) : (error|warning) [A-Z0-9_]+ : .+$")
    assert lines
    assert all(canonical.match(line) for line in lines), lines


def test_github_annotations_of_deleted_elements_point_into_new(pair: Path) -> None:
    lines = run(pair, "--format", "github").stdout.splitlines()
    field = next(line for line in lines if "FIELD_DELETED" in line)
    assert field.startswith("::error file=new/arm.proto,line=2,col=1::")
    message = next(line for line in lines if "MESSAGE_DELETED" in line)
    assert message.startswith("::warning title=MESSAGE_DELETED::")  # no file of NEW to point at


def test_summary_and_severity(pair: Path) -> None:
    done = run(pair)
    assert done.stderr == "2 errors, 1 warning in 2 files\n"
    errors_only = run(pair, "--severity", "error")
    assert "(warning)" not in errors_only.stdout
    assert errors_only.stdout.count("\n") == 2
    assert errors_only.returncode == 1


def test_a_baseline_reports_only_new_findings_across_line_moves(pair: Path) -> None:
    written = erc_lint_cli("baseline", "old", "new", cwd=pair)
    assert written.returncode == 0, written.stderr
    assert "3 findings baselined" in written.stderr
    # Lines move (a comment above), and one new break appears.
    (pair / "new" / "arm.proto").write_text(
        'syntax = "proto3";\n// moved\nmessage Arm {\n  uint32 shoulder = 1;\n'
        "  string elbow = 2;\n}\n"
    )
    done = run(pair)
    (line,) = done.stdout.splitlines()
    assert line.startswith("new/arm.proto:4:3: FIELD_TYPE_CHANGED")
    assert '"shoulder"' in line
    assert done.stderr == "1 error, 0 warnings (1 new since baseline, 3 baselined) in 2 files\n"
    assert done.returncode == 1


def test_suppression_comments_end_to_end(pair: Path) -> None:
    (pair / "new" / "arm.proto").write_text(
        'syntax = "proto3";\n'
        "message Arm {  // erc-lint:ignore FIELD_DELETED wrist retired with board v1\n"
        "  float shoulder = 1;\n"
        "  // erc-lint:ignore FIELD_TYPE_CHANGED\n"
        "  string elbow = 2;\n"
        "}\n"
    )
    done = run(pair, "--severity", "error")
    rules = [line.split(": ", 1)[1].split()[0] for line in done.stdout.splitlines()]
    assert rules == ["SUPPRESSION_INVALID", "FIELD_TYPE_CHANGED"]  # no reason: not honoured


@pytest.mark.parametrize(
    ("where", "old", "new"),
    [("", "old", "new"), ("new", "../old", "."), ("new", "../old", "./"), ("", "old", "./new/")],
)
def test_suppressions_hold_however_new_is_spelled(
    pair: Path, where: str, old: str, new: str
) -> None:
    (pair / "new" / "arm.proto").write_text(
        'syntax = "proto3";\n'
        "message Arm {  // erc-lint:ignore FIELD_DELETED wrist retired with board v1\n"
        "  float shoulder = 1;\n"
        "  string elbow = 2;  // erc-lint:ignore FIELD_TYPE_CHANGED boards updated\n"
        "}\n"
    )
    done = erc_lint_cli(old, new, "--severity", "error", cwd=pair / where)
    assert (done.returncode, done.stdout) == (0, ""), done.stdout
    assert done.stderr.startswith("0 errors, 1 warning"), done.stderr  # OLD's gone.proto


def test_ignore_only_per_rule_and_path(pair: Path) -> None:
    (pair / "new" / "pyproject.toml").write_text(
        '[tool.erc-lint]\nignore_only = { FIELD_TYPE_CHANGED = ["arm*"] }\n'
    )
    assert "FIELD_TYPE_CHANGED" not in run(pair).stdout
    (pair / "new" / "pyproject.toml").write_text(
        '[tool.erc-lint]\nignore_only = { FIELD_TYPE_CHANGD = ["arm*"] }\n'
    )
    wrong = run(pair)
    assert wrong.returncode == 2
    assert "did you mean 'FIELD_TYPE_CHANGED'?" in wrong.stderr


@pytest.mark.parametrize(
    ("args", "said"),
    [
        (["old", "nwe"], "no such folder (did you mean 'new'?) in NEW"),
        (["check", "nwe"], "no such folder (did you mean 'new'?) in TREE"),
        (["chek", "new"], "no command 'chek' (did you mean 'check'?)"),
        (["ledger", "update", "nwe", "--check"], "no such folder (did you mean 'new'?) in TREE"),
        (["explain", "FIELD_DELETD"], "no rule 'FIELD_DELETD' (did you mean 'FIELD_DELETED'?)"),
    ],
)
def test_typos_exit_2_with_a_suggestion(pair: Path, args: list[str], said: str) -> None:
    done = erc_lint_cli(*args, cwd=pair)
    assert done.returncode == 2, done
    assert said in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1


def test_an_empty_old_only_on_purpose(pair: Path) -> None:
    (pair / "empty").mkdir()
    refused = erc_lint_cli("empty", "new", cwd=pair)
    assert refused.returncode == 2
    assert "no .proto file in OLD" in refused.stderr
    assert erc_lint_cli("empty", "new", "--allow-empty-old", cwd=pair).returncode == 0


def test_explain_prints_the_rules_docstring(pair: Path) -> None:
    for args in (["explain", "FIELD_DELETED"], ["rules", "--explain", "FIELD_DELETED"]):
        done = erc_lint_cli(*args, cwd=pair)
        assert done.returncode == 0
        assert "## Use instead" in done.stdout
        assert "reserved" in done.stdout


def test_a_closed_pipe_exits_0_quietly(pair: Path) -> None:
    for name in ("a", "b", "c", "d"):
        (pair / "old" / f"{name}.proto").write_text(
            f'syntax = "proto3";\nmessage {name.upper()} {{\n'
            + "".join(f"  float f{k} = {k};\n" for k in range(1, 2000))
            + "}\n"
        )
    shell = f"{sys.executable} -m erc_lint old new | head -1"
    done = subprocess.run(
        ["bash", "-o", "pipefail", "-c", shell], cwd=pair, capture_output=True, text=True
    )
    assert done.stdout.count("\n") == 1
    assert "Traceback" not in done.stderr
    assert "BrokenPipe" not in done.stderr
    assert done.returncode == 1  # the findings' status (errors), never a pipe failure's 2 or 120


def test_a_baseline_holds_however_the_tree_is_read(tmp_path: Path) -> None:
    # NAME_COLLISION names both files in its message: a git input's scratch folder, or the
    # folder as spelled, must not reach the key.
    repo = Repo(tmp_path / "r")
    repo.commit("two", a="message GPS { double lat = 1; }\n", b="message GPS { double x = 1; }\n")
    written = erc_lint_cli("baseline", repo.spec("HEAD"), "-o", "bl", cwd=tmp_path)
    assert written.returncode == 0, written.stderr
    assert "message at a.proto and message at b.proto." in (tmp_path / "bl").read_text()
    for cwd, given in [
        (tmp_path, repo.spec("HEAD")),
        (tmp_path, "r/proto"),
        (tmp_path, "./r/proto/"),
        (tmp_path / "r" / "proto", "."),
    ]:
        done = erc_lint_cli("check", given, "--baseline", str(tmp_path / "bl"), cwd=cwd)
        assert (done.returncode, done.stdout) == (0, ""), (given, done.stdout)


def test_a_baseline_key_leaves_out_the_fix_and_its_next_free_number(tmp_path: Path) -> None:
    root = tree(tmp_path / "p", {"a.proto": "message GPS { double lat = 1; double lon = 2; }\n"})
    assert erc_lint_cli("ledger", "update", "p", cwd=tmp_path).returncode == 0
    tree(root, {"a.proto": "message GPS { double lat = 1; string name = 2; }\n"})
    assert erc_lint_cli("baseline", "p", cwd=tmp_path).returncode == 0
    assert "Fix:" not in (tmp_path / "erc-lint.baseline").read_text()
    tree(root, {"a.proto": "message GPS { double lat = 1; string name = 2; double alt = 3; }\n"})
    done = erc_lint_cli("check", "p", cwd=tmp_path)
    assert (done.returncode, done.stdout) == (0, ""), done.stdout


def test_a_git_new_points_ci_formats_at_the_repository_not_a_scratch_folder(
    tmp_path: Path,
) -> None:
    repo = Repo(tmp_path / "r")
    repo.commit("one", a="message A { float x = 1; float y = 2; }\n")
    repo.commit("two", a="message A { float x = 1; }\n")
    done = erc_lint_cli(repo.spec("HEAD~1"), repo.spec("HEAD"), "--format", "json")
    (line,) = done.stdout.splitlines()
    found = json.loads(line)
    assert found["path"] == found["in_new"]["path"] == f"{repo.root}/proto/a.proto"


@pytest.mark.parametrize("output", ["sarif", "junit", "json", "gitlab"])
def test_a_file_name_that_is_not_utf8_keeps_every_document_valid(
    tmp_path: Path, output: str
) -> None:
    name = b"b\xff\x01.proto"
    for side, kind in (("old", "float"), ("new", "string")):
        (tmp_path / side).mkdir()
        text = f'syntax = "proto3";\nmessage A {{ {kind} x = 1; }}\n'
        (tmp_path / side / os.fsdecode(name)).write_text(text)
    done = subprocess.run(
        [sys.executable, "-m", "erc_lint", "old", "new", "--format", output],
        capture_output=True,
        cwd=tmp_path,
    )
    assert done.returncode == 0, done.stderr  # one COMPILE warning: protoc cannot read it
    text = done.stdout.decode("utf-8")  # valid UTF-8, not the name's raw bytes
    assert "\\udcff" not in text
    assert "\udcff" not in text
    if output == "sarif":
        (result,) = json.loads(text)["runs"][0]["results"]
        uri = result["locations"][0]["physicalLocation"]["artifactLocation"]["uri"]
        assert uri == "new/b%FF%01.proto"  # the file's own bytes, percent-escaped
    elif output == "junit":
        xmlschema.XMLSchema(FORMATS / "junit-10.xsd").validate(text)
        (suite,) = junitparser.JUnitXml.fromstring(text)
        assert suite.name == "new/b\\xff\\x01.proto"
    else:
        (found,) = (
            [json.loads(line) for line in text.splitlines()]
            if output == "json"
            else (json.loads(text))
        )
        path = found["path"] if output == "json" else found["location"]["path"]
        assert path == "new/b\\xff\x01.proto"


def test_sarif_names_a_file_by_the_uri_of_its_exact_name(tmp_path: Path) -> None:
    """A backslash, a space, ``%`` and a non-ASCII letter in a file name are percent-encoded in
    SARIF's URIs (RFC 3986), a backslash never read as a folder separator: decoded, each URI is
    the file's path, relative to the folder erc-lint ran in (``OLD``'s for what NEW lacks)."""
    changed, gone = "back\\slash 100% \u00fc.proto", "gone\\file.proto"
    tree(
        tmp_path / "old",
        {changed: "message A { float x = 1; }\n", gone: "message G { float x = 1; }\n"},
    )
    tree(tmp_path / "new", {changed: "message A { string x = 1; }\n"})
    done = erc_lint_cli("old", "new", "--format", "sarif", cwd=tmp_path)
    assert done.returncode == 1, done.stderr
    document = json.loads(done.stdout)
    schema = json.loads((FORMATS / "sarif-2.1.0-rtm.5.json").read_text())
    jsonschema.Draft4Validator(schema).validate(document)
    results = {result["ruleId"]: result for result in document["runs"][0]["results"]}
    changed_at = results["FIELD_TYPE_CHANGED"]["locations"][0]["physicalLocation"]
    assert changed_at["artifactLocation"] == {"uri": "new/back%5Cslash%20100%25%20%C3%BC.proto"}
    gone_at = results["MESSAGE_DELETED"]["locations"][0]["physicalLocation"]
    assert gone_at["artifactLocation"] == {"uri": "old/gone%5Cfile.proto", "uriBaseId": "OLD"}
    related = results["MESSAGE_DELETED"]["relatedLocations"][0]["physicalLocation"]
    assert related["artifactLocation"] == gone_at["artifactLocation"]
    # What RFC 3986 allows in a relative reference's path, and the files' names decoded.
    allowed = re.compile(r"(?:[A-Za-z0-9._~!$&'()*+,;=:@/-]|%[0-9A-F]{2})+")
    for where, name in ((changed_at, f"new/{changed}"), (gone_at, f"old/{gone}")):
        uri = where["artifactLocation"]["uri"]
        assert allowed.fullmatch(uri)
        assert urllib.parse.unquote(uri) == name
        assert (tmp_path / name).is_file()


def test_a_closed_standard_output_is_one_line_and_exit_2(pair: Path) -> None:
    done = subprocess.run(
        f"{sys.executable} -m erc_lint old new >&-",
        shell=True,
        capture_output=True,
        text=True,
        cwd=pair,
    )
    assert done.returncode == 2, done.stderr
    assert done.stderr == "Error: standard output is closed: nowhere to write the findings\n"


def test_only_what_is_gone_from_new_is_called_gone(tmp_path: Path) -> None:
    tree(
        tmp_path / "old",
        {"a.proto": "message A { float x = 1 }\n", "c.proto": "message C { float y = 1; }\n"},
    )
    tree(tmp_path / "new", {"a.proto": "message A { float x = 1; }\n", "c.proto": "message C {}\n"})
    done = erc_lint_cli("old", "new", "--format", "github", cwd=tmp_path)
    compiled, deleted = done.stdout.splitlines()
    assert "COMPILE OLD's a.proto does not compile" in compiled
    assert compiled.endswith("(OLD had it at old/a.proto:1)")
    assert "FIELD_DELETED" in deleted
    assert "(gone from NEW; OLD had it at old/c.proto:2)" in deleted


def test_the_api_refuses_a_tree_that_is_not_there_as_the_cli_does(pair: Path) -> None:
    import erc_lint

    with pytest.raises(erc_lint.LintError, match="no such folder in OLD"):
        erc_lint.lint(pair / "nonexistent", pair / "new")
    with pytest.raises(erc_lint.LintError, match=r"no such folder .* in NEW"):
        erc_lint.lint(pair / "old", pair / "nwe")
    (pair / "empty").mkdir()
    with pytest.raises(erc_lint.LintError, match=r"no \.proto file in TREE"):
        erc_lint.check(pair / "empty")
    repo = Repo(pair / "r")
    repo.commit("one", a="message A { float x = 1; }\n")
    with pytest.raises(erc_lint.LintError, match=r"no \.proto file in NEW: none in subdir"):
        erc_lint.lint(repo.spec("HEAD"), f"{repo.root}#ref=HEAD,subdir=protos")
    assert erc_lint.lint(pair / "old", pair / "new")  # the same call on real trees finds


def test_ignore_only_silences_suppression_unused_and_one_finding_is_singular(
    pair: Path,
) -> None:
    (pair / "new" / "note.proto").write_text(
        'syntax = "proto3";\nmessage Note { float y = 1; }  // erc-lint:ignore FIELD_DELETED old\n'
    )
    assert "SUPPRESSION_UNUSED" in run(pair).stdout
    (pair / "new" / "pyproject.toml").write_text(
        '[tool.erc-lint]\nignore_only = { SUPPRESSION_UNUSED = ["note.proto"] }\n'
    )
    assert "SUPPRESSION_UNUSED" not in run(pair).stdout
    tree(pair / "single", {"a.proto": "message A {}\n", "b.proto": "message A {}\n"})
    written = erc_lint_cli("baseline", "single", cwd=pair)
    assert written.stderr == "erc-lint.baseline: 1 finding baselined\n", written.stderr
