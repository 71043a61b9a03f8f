"""The baseline: findings a team accepted once (``erc-lint baseline``), so later runs report only
what is new. A text file, ``erc-lint.baseline``, one finding a line, sorted, made to be reviewed:

    FIELD_DELETED gps.proto Previously present field "3" with name "altitude" on message ...

Each line is the rule, the file relative to its tree's root and the message with every
``:line:column`` and the closing ``Fix: ...`` left out and every path in it relative to its
tree's root too (``erc_lint._inputs.baseline_keys``): keyed by rule and element, a finding stays
baselined when lines move, a fix's "next free number" changes, or the tree is read from another
folder (however spelled) or from a git revision.
Lines starting with ``#`` are comments. A baseline over ``BASELINE_LIMIT`` is refused.
"""

from collections.abc import Iterable
from pathlib import Path

from erc_schema import FileError, read_text

from ._errors import LintError

__all__ = ["BASELINE", "BASELINE_LIMIT", "read_baseline", "render_baseline"]

BASELINE = "erc-lint.baseline"
BASELINE_LIMIT = 64 * 1024 * 1024
HEADER = (
    "# erc-lint baseline: findings accepted when it was written; erc-lint reports only others.\n"
    "# One a line: RULE FILE MESSAGE (no line numbers). Rewrite it with `erc-lint baseline`.\n"
)


def read_baseline(path: Path) -> frozenset[str]:
    """The findings ``path`` holds, as stable keys."""
    try:
        text = read_text(path, BASELINE_LIMIT)
    except FileError as error:
        raise LintError(str(error)) from None
    return frozenset(
        line.rstrip() for line in text.splitlines() if line.strip() and not line.startswith("#")
    )


def render_baseline(keys: Iterable[str]) -> str:
    return HEADER + "".join(f"{key}\n" for key in sorted(set(keys)))
