"""erc-lint over fixture trees, run as a user would (a subprocess in the case's folder).

Every case is a folder of ``tests/lint_cases`` holding ``old/``, ``new/`` and ``expected.txt``:
exactly what ``erc-lint old new`` prints there. ``lint_cases/<RULE>/`` shows rule ``<RULE>``
firing (and nothing that change does not unavoidably trigger too), either as a case itself or as
a folder of scenarios, ``lint_cases/<RULE>/<scenario>/``, each a case; ``lint_cases/safe/<name>/``
is a change that breaks nothing, so its ``expected.txt`` is empty.

``ERC_UPDATE_EXPECTED=1 pytest tests/lint/test_lint_cases.py`` writes each case's ``expected.txt``
from what erc-lint prints instead of comparing them, for review in the diff.
"""

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import PROTO, TESTS

from erc_lint import RULES

CASES = TESTS / "lint_cases"
SAFE = CASES / "safe"


def cases(folder: Path) -> list[Path]:
    """``folder`` if it is a case, else each of its scenarios."""
    if (folder / "expected.txt").exists():
        return [folder]
    return sorted(path for path in folder.iterdir() if path.is_dir())


RULE_CASES = [
    case
    for path in sorted(CASES.iterdir())
    if path.is_dir() and path != SAFE
    for case in cases(path)
]
SAFE_CASES = cases(SAFE)
UPDATE = os.environ.get("ERC_UPDATE_EXPECTED") == "1"
# One finding in text format: ``path:line:col: RULE[ (warning)] message``.
FINDING = re.compile(
    r"^(?P<path>[^:\s]+):\d+:\d+: (?P<rule>[A-Z][A-Z0-9_]*)(?P<warning> \(warning\))? \S"
)


def erc_lint(cwd: Path, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "erc_lint", *args],
        cwd=cwd,
        capture_output=True,
        text=True,
        check=False,
    )


def findings(text: str) -> list[re.Match[str]]:
    """Every line of ``text`` parsed as a finding; a line that is not one fails the test."""
    parsed = []
    for line in text.splitlines():
        match = FINDING.match(line)
        assert match is not None, f"not a finding: {line!r}"
        parsed.append(match)
    return parsed


def case_id(case: Path) -> str:
    return case.relative_to(CASES).as_posix()


def rule_of(case: Path) -> str:
    """The rule a case shows: its folder's name under ``lint_cases``."""
    return case.relative_to(CASES).parts[0]


@pytest.mark.parametrize("case", RULE_CASES + SAFE_CASES, ids=case_id)
def test_case_prints_exactly_its_expected_findings(case: Path) -> None:
    assert (case / "old").is_dir(), case
    assert (case / "new").is_dir(), case
    if UPDATE:
        done = erc_lint(case, "old", "new")
        assert done.returncode in (0, 1), done.stderr  # a run that failed has nothing to expect
        (case / "expected.txt").write_text(done.stdout, encoding="utf-8")
        return
    expected = (case / "expected.txt").read_text(encoding="utf-8")
    errors = [m for m in findings(expected) if m["warning"] is None]
    done = erc_lint(case, "old", "new")
    assert "Traceback" not in done.stderr, done.stderr
    assert done.stdout == expected, done.stderr
    assert done.returncode == (1 if errors else 0), done.stdout + done.stderr


@pytest.mark.parametrize("case", RULE_CASES, ids=case_id)
def test_rule_case_shows_its_rule(case: Path) -> None:
    rule = rule_of(case)
    assert rule in RULES, f"{case_id(case)} names no rule"
    text = (case / "expected.txt").read_text(encoding="utf-8")
    shown = [m for m in findings(text) if m["rule"] == rule]
    assert shown, f"{case_id(case)}/expected.txt has no {rule} finding"
    # Every location is in one of the case's own trees, as the working directory spells it.
    assert all(m["path"].startswith(("old/", "new/")) for m in findings(text)), text


@pytest.mark.parametrize("case", SAFE_CASES, ids=case_id)
def test_safe_case_expects_nothing(case: Path) -> None:
    assert (case / "expected.txt").read_text(encoding="utf-8") == ""


def test_every_rule_has_a_case() -> None:
    assert {rule_of(case) for case in RULE_CASES} == set(RULES)


def test_a_rule_folder_is_a_case_or_holds_scenarios() -> None:
    """Never both: a scenario beside a case's own old/ and new/ would read as one of them."""
    for folder in [path for path in CASES.iterdir() if path.is_dir()]:
        inside = {path.name for path in folder.iterdir()}
        if "expected.txt" in inside:
            assert inside <= {"old", "new", "expected.txt"}, folder
        else:
            assert all((folder / name / "expected.txt").is_file() for name in inside), folder


def test_the_repository_tree_against_itself_is_clean() -> None:
    done = erc_lint(PROTO.parent, PROTO.name, PROTO.name)
    assert (done.stdout, done.returncode) == ("", 0), done.stderr
