"""erc_lint: the wire-compatibility linter for the rover's proto trees.

``lint(old, new)`` compares two revisions of a tree (folders or git revisions) and returns the
findings, sorted by location; ``check(tree)`` lints one tree on its own; ``erc-lint`` is the
command line around them. Everything not re-exported here is private. The names load on first
use, so the command can tune the process before the heavy imports (see ``_entry``).
"""

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
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

_LAZY = {
    "Config": "._config",
    "ConfigError": "._errors",
    "Finding": "._finding",
    "Severity": "._finding",
    "GitError": "._errors",
    "LedgerError": "._errors",
    "LintError": "._errors",
    "check": "._run",
    "lint": "._run",
    "RULES": ".rules",
    "Rule": ".rules",
}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name], __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
