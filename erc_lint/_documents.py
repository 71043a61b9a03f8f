"""The document formats of ``_report``: SARIF 2.1.0, JUnit XML and GitLab Code Quality JSON."""

import inspect
import json
import os
import re
from importlib.metadata import version
from xml.sax.saxutils import quoteattr

from ._finding import Finding, printable, stable_text
from .rules import RULES

__all__ = ["gitlab", "junit", "sarif"]

_SARIF_SCHEMA = "https://json.schemastore.org/sarif-2.1.0.json"


def sarif(findings: list[Finding]) -> str:
    """One run of tool ``erc-lint``: every rule with its help text, one result per finding."""
    index = {rule: number for number, rule in enumerate(RULES)}
    rules = [
        {
            "id": rule.id,
            "shortDescription": {"text": rule.purpose},
            "help": {"text": inspect.cleandoc(rule.check.__doc__ or rule.purpose)},
            "defaultConfiguration": {"level": rule.severity},
            "properties": {"tags": list(rule.categories)},
        }
        for rule in RULES.values()
    ]
    results = []
    for finding in findings:
        place = finding.shown_at
        old = finding.in_old and finding.in_new is None
        location = {
            "physicalLocation": {
                "artifactLocation": {
                    "uri": _uri(place.path),
                    **({"uriBaseId": "OLD"} if old else {}),
                },
                "region": {"startLine": place.line, "startColumn": place.column},
            }
        }
        result = {
            "ruleId": finding.rule,
            "ruleIndex": index.get(finding.rule, -1),
            "level": finding.severity,
            "message": {"text": printable(finding.text)},
            "locations": [location],
            "partialFingerprints": {"ercLintFinding/v1": fingerprint(finding)},
        }
        if finding.in_old:
            result["relatedLocations"] = [
                {
                    "message": {"text": "where OLD had it"},
                    "physicalLocation": {
                        "artifactLocation": {"uri": _uri(finding.path), "uriBaseId": "OLD"},
                        "region": {"startLine": finding.line, "startColumn": finding.column},
                    },
                }
            ]
        results.append(result)
    tool = {
        "driver": {
            "name": "erc-lint",
            "version": version("erc-codec"),
            "informationUri": "https://pypi.org/project/erc-codec/",
            "rules": rules,
        }
    }
    document = {
        "$schema": _SARIF_SCHEMA,
        "version": "2.1.0",
        "runs": [{"tool": tool, "results": results}],
    }
    return json.dumps(document, indent=2) + "\n"


def gitlab(findings: list[Finding]) -> str:
    """GitLab Code Quality: an array of issues (errors ``major``, warnings ``minor``)."""
    issues = [
        {
            "description": f"{finding.rule}: {printable(finding.text)}",
            "check_name": finding.rule,
            "fingerprint": fingerprint(finding),
            "severity": "major" if finding.severity == "error" else "minor",
            "location": {
                "path": printable(finding.shown_at.path),
                "lines": {"begin": finding.shown_at.line},
            },
        }
        for finding in findings
    ]
    return json.dumps(issues, indent=2) + "\n"


def junit(findings: list[Finding]) -> str:
    """One test suite per file, one test case per finding: an error is a failure, a warning a
    passing case that says so in its output. No finding: one passing case, ``erc-lint``."""
    by_file: dict[str, list[Finding]] = {}
    for finding in findings:
        by_file.setdefault(finding.shown_at.path, []).append(finding)
    suites = []
    for path, found in sorted(by_file.items()):
        cases = []
        for finding in found:
            place = finding.shown_at
            name = _attribute(f"{finding.rule} {place.path}:{place.line}:{place.column}")
            if finding.severity == "error":
                kind, message = _attribute(finding.rule), _attribute(finding.text)
                body = f"<failure type={kind} message={message}>{_text(finding.text)}</failure>"
            else:
                body = f"<system-out>{_text('warning: ' + finding.text)}</system-out>"
            cases.append(
                f"    <testcase name={name} classname={_attribute(path)}>{body}</testcase>\n"
            )
        failures = sum(f.severity == "error" for f in found)
        suites.append(
            f'  <testsuite name={_attribute(path)} tests="{len(found)}" failures="{failures}" '
            f'errors="0">\n{"".join(cases)}  </testsuite>\n'
        )
    if not suites:
        suites.append(
            '  <testsuite name="erc-lint" tests="1" failures="0" errors="0">\n'
            '    <testcase name="erc-lint" classname="erc-lint"/>\n  </testsuite>\n'
        )
    errors = sum(f.severity == "error" for f in findings)
    tests = max(len(findings), 1)
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        f'<testsuites name="erc-lint" tests="{tests}" failures="{errors}" errors="0">\n'
        f"{''.join(suites)}</testsuites>\n"
    )


def fingerprint(finding: Finding) -> str:
    """A stable identity of the finding (no line numbers in it), hex."""
    import hashlib

    return hashlib.sha256(stable_text(finding, finding.path).encode("utf-8", "replace")).hexdigest()


# What XML 1.0 cannot hold, even escaped: control characters but tab, newline and return.
_NOT_XML = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ufffe\uffff]")


def _xml(text: str) -> str:
    """``text`` with what XML cannot hold written as ``\\x01``."""
    return _NOT_XML.sub(lambda match: f"\\x{ord(match[0]):02x}", text)


def _attribute(text: str) -> str:
    return quoteattr(_xml(printable(text)))


def _text(text: str) -> str:
    return _xml(printable(text)).replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


def _uri(path: str) -> str:
    """The URI reference (RFC 3986) of the file ``path`` names, relative as ``path`` is: each
    byte of the name but ``/``, letters, digits and ``-._~`` percent-encoded (``\\`` as ``%5C``,
    a space as ``%20``, ``%`` as ``%25``), a name's characters as their UTF-8 bytes and its bytes
    that are not UTF-8 as themselves. Only where the system separates folders with another
    character (Windows' ``\\``) is that written ``/``: elsewhere it is part of a name."""
    from urllib.parse import quote

    if os.sep != "/":
        path = path.replace(os.sep, "/")
    return quote(path.encode("utf-8", "surrogateescape"), safe="/")
