"""erc_lint's rules: each is handed one pair and explains itself (tests/lint_cases/ shows each
one firing, through the command line)."""

import inspect
import re
from pathlib import Path

import pytest

import erc_lint
from erc_lint import RULES, Rule
from erc_lint.rules._registry import PAIRS

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
    assert rule.pairs in PAIRS or rule.pairs == "tree"
    assert list(inspect.signature(rule.check).parameters)[1:] == ["change"]
    assert re.fullmatch(r"[A-Z]+(_[A-Z]+)*", rule.id)
    assert rule.severity in ("error", "warning")
    assert rule.pairs != "tree" or rule.severity == "error"  # graded by OLD instead


# Examples that need more than one file of each revision: a configuration, a ledger, a second file.
SETUP = {
    "EMBEDDED_ROOT_MISSING",
    "IMPORT_AMBIGUOUS",
    "LEDGER_NUMBER_REUSED",
    "MESSAGE_DELETED",
    "NAME_COLLISION",
}
FENCED = re.compile(r"^(Before|After)\b[^\n]*\n```proto\n(.*?)```", re.DOTALL | re.MULTILINE)


@pytest.mark.parametrize(
    "rule", [r for r in RULES.values() if r.id not in SETUP], ids=lambda r: r.id
)
def test_every_rules_example_shows_the_rule(rule: Rule, tmp_path: Path) -> None:
    """The example a rule explains itself with is true: linted, before against after, it fires."""
    doc = inspect.cleandoc(rule.check.__doc__ or "")
    blocks = dict(FENCED.findall(doc.split("## Example", 1)[1]))
    assert set(blocks) == {"Before", "After"}, rule.id
    for side, text in blocks.items():
        (tmp_path / side).mkdir()
        (tmp_path / side / "example.proto").write_text(f'syntax = "proto3";\n{text}')
    found = erc_lint.lint(tmp_path / "Before", tmp_path / "After")
    assert rule.id in {finding.rule for finding in found}, found


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
    config = erc_lint.Config(roots=("PBEnvelope",), roots_line=1)
    found = {finding.rule for finding in erc_lint.check(root, config)}
    assert found == ({"COMPILE", "EMBEDDED_ROOT_MISSING"} if missing else {"COMPILE"})
