"""erc_lint: the wire-compatibility linter for the rover's proto trees.

``lint(old, new)`` compares two revisions of a tree (folders or git revisions) and returns the
findings, sorted by location; ``check(tree)`` lints one tree on its own; ``erc-lint`` is the
command line around them (``erc_lint.cli``). Everything not re-exported here is private.
"""

from ._config import Config
from ._errors import ConfigError, GitError, LedgerError, LintError
from ._finding import Finding, Severity
from ._run import check, lint
from .rules import RULES, Rule

__all__ = [
    "RULES",
    "Config",
    "ConfigError",
    "Finding",
    "GitError",
    "LedgerError",
    "LintError",
    "Rule",
    "Severity",
    "check",
    "lint",
]
