"""Findings as text (people and editors), JSON lines (machines) or GitHub Actions annotations."""

from collections.abc import Iterable

from ._finding import Finding

__all__ = ["FORMATS", "render"]

FORMATS = ("text", "json", "github")


def render(findings: Iterable[Finding], output: str) -> str:
    """The findings in ``output`` format, one line each."""
    return "".join(f"{_line(finding, output)}\n" for finding in findings)


def _line(finding: Finding, output: str) -> str:
    note = " (location in OLD)" if finding.in_old else ""
    if output == "json":
        # Only this format needs it: for bench_lint's 30-file ratio (start-up is most of a run),
        # the text format does not pay for it (about 2 ms).
        import json

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
        text = _escape(f"{finding.rule} {finding.message}{note}")
        path = _escape(finding.path).replace(",", "%2C").replace(":", "%3A")
        where = f"file={path},line={finding.line},col={finding.column}"
        return f"::{finding.severity} {where}::{text}"
    label = "" if finding.severity == "error" else " (warning)"
    return (
        f"{finding.path}:{finding.line}:{finding.column}: {finding.rule}{label} "
        f"{finding.message}{note}"
    )


def _escape(text: str) -> str:
    """GitHub's workflow-command escaping of a message (properties also escape , and :)."""
    return text.replace("%", "%25").replace("\r", "%0D").replace("\n", "%0A")
