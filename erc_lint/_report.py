"""Findings as text (people and editors), JSON lines (machines) or GitHub Actions annotations."""

import json
from collections.abc import Iterable

from ._finding import Finding

__all__ = ["FORMATS", "render"]

FORMATS = ("text", "json", "github")


def render(findings: Iterable[Finding], output: str) -> str:
    """The findings in ``output`` format, one line each."""
    return "".join(f"{_line(finding, output)}\n" for finding in findings)


def _line(finding: Finding, output: str) -> str:
    note = " (location in OLD: the element is gone from NEW)" if finding.in_old else ""
    if output == "json":
        return json.dumps(
            {
                "rule": finding.rule,
                "severity": finding.severity,
                "path": finding.path,
                "line": finding.line,
                "column": finding.column,
                "message": finding.message,
                "in_old": finding.in_old,
            }
        )
    if output == "github":
        text = f"{finding.rule} {finding.message}{note}".replace("%", "%25").replace("\n", "%0A")
        where = f"file={finding.path},line={finding.line},col={finding.column}"
        return f"::{finding.severity} {where}::{text}"
    label = "" if finding.severity == "error" else " (warning)"
    return (
        f"{finding.path}:{finding.line}:{finding.column}: {finding.rule}{label} "
        f"{finding.message}{note}"
    )
