"""What the linter reports: one finding per problem, located where a CI or an editor can open it,
and named in a way that does not move with the lines (for baselines and CI deduplication)."""

import re
from typing import Literal, NamedTuple

from erc_schema import Location

__all__ = ["Finding", "Severity", "printable", "printable_finding", "stable_text"]

Severity = Literal["error", "warning"]

# A place inside a message (``file.proto:12:3``, ``erc-lint.lock:7``): what a line move changes.
_PLACE = re.compile(r":\d+(?::\d+)?\b")


class Finding(NamedTuple):
    """One problem: where (in NEW, or in OLD for what NEW no longer has), which rule, what."""

    path: str
    line: int
    column: int
    rule: str
    message: str
    severity: Severity = "error"
    in_old: bool = False  # the location is in OLD: the element is gone from NEW
    # For a finding located in OLD: where NEW has the element's container (the message of a
    # deleted field, the enum of a deleted value, the file of a deleted message), if it does.
    in_new: Location | None = None
    fix: str = ""  # what to do about it, in a few words (it may name the next free number)

    @classmethod
    def at(
        cls,
        location: Location,
        rule: str,
        message: str,
        severity: Severity = "error",
        in_old: bool = False,
        in_new: Location | None = None,
        fix: str = "",
    ) -> "Finding":
        return cls(
            location.path,
            location.line,
            location.column,
            rule,
            message,
            severity,
            in_old,
            in_new,
            fix,
        )

    @property
    def text(self) -> str:
        """The message as every report prints it: with its fix, when it has one, after it."""
        return f"{self.message} Fix: {self.fix}." if self.fix else self.message

    def order(self) -> tuple[str, int, int, str, str, str, bool]:
        """The order findings are reported in: by place, rule, then what they say."""
        return (self.path, self.line, self.column, self.rule, self.text, self.severity, self.in_old)

    @property
    def shown_at(self) -> Location:
        """Where a CI or an editor should point: in NEW whenever NEW has the place."""
        return self.in_new or Location(self.path, self.line, self.column)


def stable_text(finding: Finding, path: str) -> str:
    """``RULE path message`` with every ``:line[:column]`` left out of the message, and without
    the fix (which may name the next free number): the same element's finding after lines moved
    or numbers were added, named by ``path`` (as the caller wants it shown)."""
    return f"{finding.rule} {path} {_PLACE.sub('', finding.message)}"


def printable(text: str) -> str:
    """``text`` as valid Unicode: a file name's bytes that are not UTF-8 (held as lone
    surrogates, ``os.fsdecode``'s ``surrogateescape``) written as ``\\xff``, for the formats
    that must be valid UTF-8 (JSON, SARIF, GitLab, JUnit)."""
    if text.isascii() or not any("\udc80" <= char <= "\udcff" for char in text):
        return text
    return text.encode("utf-8", "surrogateescape").decode("utf-8", "backslashreplace")


def printable_finding(finding: Finding) -> Finding:
    """The finding with its paths and message ``printable``."""
    where = finding.in_new
    return finding._replace(
        path=printable(finding.path),
        message=printable(finding.message),
        fix=printable(finding.fix),
        in_new=where._replace(path=printable(where.path)) if where else None,
    )
