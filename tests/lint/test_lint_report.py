"""erc_lint's report formats: text, JSON lines, GitHub Actions annotations."""

import json
from pathlib import Path

from lint_support import erc_lint_cli, tree

from erc_lint import Finding
from erc_lint._report import render


def test_output_formats(tmp_path: Path) -> None:
    old = tree(tmp_path / "old", {"a.proto": "message A { float x = 1; float z = 2; }\n"})
    new = tree(tmp_path / "new", {"a.proto": "message A { float y = 1; }\n"})
    lines = [
        json.loads(line)
        for line in erc_lint_cli(str(old), str(new), "--format", "json").stdout.splitlines()
    ]
    assert [(line["rule"], line["severity"], line["in_old"]) for line in lines] == [
        ("FIELD_RENAMED", "warning", False),
        ("FIELD_DELETED", "error", True),
    ]
    assert set(lines[0]) >= {"rule", "severity", "path", "line", "column", "message"}
    github = erc_lint_cli(str(old), str(new), "--format", "github").stdout.splitlines()
    assert github[0].startswith(f"::warning file={new / 'a.proto'},line=2,col=")
    # A deleted field: at its message in NEW, never at a line of OLD (which says where it was).
    assert github[1].startswith(f"::error file={new / 'a.proto'},line=2,col=1::FIELD_DELETED ")
    assert github[1].endswith(f"(gone from NEW; OLD had it at {old / 'a.proto'}:2)")


def test_github_annotations_escape_what_their_syntax_uses() -> None:
    finding = Finding("odd, name: 100%.proto", 3, 4, "COMPILE", 'Expected ";".\nthen 50%')
    assert render([finding], "github") == (
        "::error file=odd%2C name%3A 100%25.proto,line=3,col=4::"
        'COMPILE Expected ";".%0Athen 50%25\n'
    )
