"""Suppressions written where the code is: ``// erc-lint:ignore RULE[,RULE...] reason`` in a
.proto of NEW (TREE for ``check``), ruff's ``# noqa`` and buf's ``// buf:lint:ignore`` in
erc-lint's spelling.

Guarantees:
- A comment at the end of a line covers the findings on that line; a comment on a line of its
  own covers the next line that is not a comment (so several suppressions may stack above one
  element). A finding located in OLD (a deleted element) is covered where NEW has its
  container (``Finding.in_new``).
- A suppression names rule IDs and gives a reason; without one it silences nothing (a
  suppression nobody can explain is a finding of ``SUPPRESSION_INVALID``), and one that silences
  nothing is a finding of ``SUPPRESSION_UNUSED``, as ruff reports an unused ``noqa``.
- Only a ``//`` comment outside string literals counts.
"""

import re
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import NamedTuple

from erc_schema import Location

from ._finding import Finding

__all__ = ["MARK", "Suppression", "apply", "suppressions"]

MARK = "erc-lint:ignore"
_COMMENT = re.compile(r"//\s*erc-lint:ignore\b(?P<rest>[^\n]*)")
_RULES = re.compile(r"\s*(?P<rules>[A-Za-z0-9_]+(?:\s*,\s*[A-Za-z0-9_]+)*)(?P<reason>.*)")


class Suppression(NamedTuple):
    """One ``erc-lint:ignore`` comment: where it is, the line it covers, what and why."""

    location: Location  # the comment itself
    covers: int  # the line whose findings it silences
    rules: tuple[str, ...]
    reason: str


def suppressions(texts: Mapping[str, str], root: str) -> list[Suppression]:
    """Every ``erc-lint:ignore`` comment of the files ``texts`` (``{path under root: text}``)."""
    found = []
    for name, text in sorted(texts.items()):
        if MARK not in text:  # nearly every file: no scan
            continue
        lines = text.splitlines()
        for number, line in enumerate(lines, 1):
            code = _code(line)
            match = _COMMENT.search(line, len(code))
            if match is None:
                continue
            words = _RULES.match(match["rest"])
            rules = tuple(r.strip() for r in words["rules"].split(",")) if words else ()
            reason = words["reason"].strip() if words else ""
            covers = number
            if not code.strip():  # a line of its own: the next line that is not a comment
                covers = next(
                    (
                        k
                        for k in range(number + 1, len(lines) + 1)
                        if not lines[k - 1].lstrip().startswith("//")
                    ),
                    number + 1,
                )
            # Named as findings name files (``root / name``: no "./" when NEW is spelled ".").
            where = Location(str(Path(root) / name), number, match.start() + 1)
            found.append(Suppression(where, covers, rules, reason))
    return found


def apply(
    findings: Iterable[Finding], given: list[Suppression]
) -> tuple[list[Finding], set[Suppression]]:
    """The findings no valid suppression covers, and the suppressions that covered one."""
    valid: dict[tuple[str, int, str], Suppression] = {}
    for suppression in given:
        if suppression.reason:
            for rule in suppression.rules:
                key = (suppression.location.path, suppression.covers, rule)
                valid.setdefault(key, suppression)
    kept: list[Finding] = []
    used: set[Suppression] = set()
    for finding in findings:
        place = finding.shown_at
        covering = valid.get((place.path, place.line, finding.rule))
        if covering is None:
            kept.append(finding)
        else:
            used.add(covering)
    return kept, used


def _code(line: str) -> str:
    """The part of ``line`` before its ``//`` comment, string literals skipped."""
    quote = ""
    index = 0
    while index < len(line):
        char = line[index]
        if quote:
            if char == "\\":
                index += 1
            elif char == quote:
                quote = ""
        elif char in "\"'":
            quote = char
        elif line.startswith("//", index):
            return line[:index]
        index += 1
    return line
