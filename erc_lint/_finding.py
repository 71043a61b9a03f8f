"""What the linter reports: one finding per problem, located where a CI or an editor can open it."""

from typing import Literal, NamedTuple

from erc_codec.schema import Location

__all__ = ["Finding", "Severity"]

Severity = Literal["error", "warning"]


class Finding(NamedTuple):
    """One problem: where (in NEW, or in OLD for what NEW no longer has), which rule, what."""

    path: str
    line: int
    column: int
    rule: str
    message: str
    severity: Severity = "error"
    in_old: bool = False  # the location is in OLD: the element is gone from NEW

    @classmethod
    def at(
        cls,
        location: Location,
        rule: str,
        message: str,
        severity: Severity = "error",
        in_old: bool = False,
    ) -> "Finding":
        return cls(location.path, location.line, location.column, rule, message, severity, in_old)
