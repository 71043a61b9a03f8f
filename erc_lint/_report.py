"""Findings as CI systems and editors read them: lines (``text`` for people and editors,
``json`` lines, ``github`` Actions annotations, ``msvs`` Visual Studio's error format) or one
document (``sarif`` 2.1.0 for GitHub code scanning, ``junit`` XML for GitLab, Jenkins and Azure,
``gitlab`` Code Quality JSON).

Every CI format points at a place in NEW: a deleted element at its container in NEW
(``Finding.in_new``), and only what NEW has no file for at OLD's line, marked as OLD's (SARIF:
``uriBaseId`` ``OLD``; GitHub: an annotation without a file). SARIF, GitLab and JUnit identify a
finding by its rule, file and message without line numbers (``stable_text``), so a CI that
deduplicates sees a moved finding as the same one.
"""

from collections.abc import Iterable

from ._finding import Finding, printable_finding

__all__ = ["FORMATS", "render"]

FORMATS = ("text", "json", "github", "msvs", "sarif", "junit", "gitlab")
_DOCUMENTS = ("sarif", "junit", "gitlab")


def render(findings: Iterable[Finding], output: str) -> str:
    """The findings in ``output`` format: one line each, or one document."""
    if output in _DOCUMENTS:
        # Imported on first use: only these formats load json, hashlib and the rules' docs.
        from ._documents import gitlab, junit, sarif

        return {"sarif": sarif, "junit": junit, "gitlab": gitlab}[output](list(findings))
    return "".join(f"{_line(finding, output)}\n" for finding in findings)


def _line(finding: Finding, output: str) -> str:
    note = " (location in OLD)" if finding.in_old else ""
    if output == "json":
        import json

        finding = printable_finding(finding)  # valid UTF-8: a name's odd bytes as \\xff
        return json.dumps(
            {
                "rule": finding.rule,
                "severity": finding.severity,
                "path": finding.path,
                "line": finding.line,
                "column": finding.column,
                "message": finding.text,
                "in_old": finding.in_old,
                "in_new": finding.in_new._asdict() if finding.in_new else None,
            }
        )
    place = finding.shown_at
    if finding.in_new is not None and output != "text":  # at NEW's container: where OLD had it
        # OLD's file that does not compile (COMPILE's warning) is no element gone from NEW.
        gone = "" if finding.rule == "COMPILE" else "gone from NEW; "
        note = f" ({gone}OLD had it at {finding.path}:{finding.line})"
    if output == "github":
        text = _escape(f"{finding.rule} {finding.text}{note}")
        if finding.in_old and finding.in_new is None:  # no file of NEW to point at
            return f"::{finding.severity} title={finding.rule}::{text}"
        path = _escape(place.path).replace(",", "%2C").replace(":", "%3A")
        where = f"file={path},line={place.line},col={place.column}"
        return f"::{finding.severity} {where}::{text}"
    if output == "msvs":
        return (
            f"{place.path}({place.line},{place.column}) : {finding.severity} {finding.rule} : "
            f"{finding.text}{note}"
        )
    label = "" if finding.severity == "error" else " (warning)"
    return (
        f"{finding.path}:{finding.line}:{finding.column}: {finding.rule}{label} "
        f"{finding.text}{note}"
    )


def _escape(text: str) -> str:
    """GitHub's workflow-command escaping of a message (properties also escape , and :)."""
    return text.replace("%", "%25").replace("\r", "%0D").replace("\n", "%0A")
