"""erc-lint over fixture trees, run as a user would (a subprocess in the case's folder).

Every case is a folder of ``tests/lint_cases`` holding ``old/``, ``new/`` and ``expected.txt``:
exactly what ``erc-lint old new`` prints there. ``lint_cases/<RULE>/`` shows rule ``<RULE>``
firing (and nothing that change does not unavoidably trigger too); ``lint_cases/safe/<name>/``
is a change that breaks nothing, so its ``expected.txt`` is empty.
"""

import re
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import PROTO

from erc_lint import RULES

CASES = Path(__file__).resolve().parent / "lint_cases"
SAFE = CASES / "safe"
RULE_CASES = sorted(path for path in CASES.iterdir() if path.is_dir() and path != SAFE)
SAFE_CASES = sorted(path for path in SAFE.iterdir() if path.is_dir())
# One finding in text format: ``path:line:col: RULE[ (warning)] message``.
FINDING = re.compile(r"^(?P<path>[^:\s]+):\d+:\d+: (?P<rule>[A-Z_]+)(?P<warning> \(warning\))? \S")


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


@pytest.mark.parametrize("case", RULE_CASES + SAFE_CASES, ids=case_id)
def test_case_prints_exactly_its_expected_findings(case: Path) -> None:
    assert (case / "old").is_dir(), case
    assert (case / "new").is_dir(), case
    expected = (case / "expected.txt").read_text(encoding="utf-8")
    errors = [m for m in findings(expected) if m["warning"] is None]
    done = erc_lint(case, "old", "new")
    assert "Traceback" not in done.stderr, done.stderr
    assert done.stdout == expected, done.stderr
    assert done.returncode == (1 if errors else 0), done.stdout + done.stderr


@pytest.mark.parametrize("case", RULE_CASES, ids=case_id)
def test_rule_case_shows_its_rule(case: Path) -> None:
    assert case.name in RULES, f"{case_id(case)} names no rule"
    text = (case / "expected.txt").read_text(encoding="utf-8")
    shown = [m for m in findings(text) if m["rule"] == case.name]
    assert shown, f"{case_id(case)}/expected.txt has no {case.name} finding"
    # Every location is in one of the case's own trees, as the working directory spells it.
    assert all(m["path"].startswith(("old/", "new/")) for m in findings(text)), text


@pytest.mark.parametrize("case", SAFE_CASES, ids=case_id)
def test_safe_case_expects_nothing(case: Path) -> None:
    assert (case / "expected.txt").read_text(encoding="utf-8") == ""


def test_every_rule_has_a_case() -> None:
    assert {case.name for case in RULE_CASES} == set(RULES)


def test_the_repository_tree_against_itself_is_clean() -> None:
    done = erc_lint(PROTO.parent, PROTO.name, PROTO.name)
    assert (done.stdout, done.returncode) == ("", 0), done.stderr
