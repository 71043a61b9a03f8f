"""erc_lint: the wire-compatibility linter for the rover's proto trees.

``lint(old, new)`` compares two revisions of a tree (folders or git revisions) and returns the
findings, sorted by location; ``check(tree)`` lints one tree on its own; ``erc-lint`` is the
command line around them (``erc_lint.cli``). Everything not re-exported here is private.

One module per job, and data flows one way: ``_inputs`` (a folder, or a git revision read by the
schema layer, ``erc_schema.open_tree``) → ``_loader`` (compiled files and load
problems) → ``_model`` (one revision: its messages, enums, extensions, services, names, sizes;
``_features`` resolves what each element means on the wire) → ``_pairing`` (OLD and NEW paired)
→ ``rules/`` (one pair at a time, in categories; ``_suppressions`` reads the ``erc-lint:ignore``
comments) → ``_report`` (text, JSON, GitHub annotations, msvs; ``_documents``: SARIF, JUnit,
GitLab Code Quality) → ``cli/``. ``_run`` is one lint run (and one ledger update), ``_baseline``
the accepted findings, ``_config`` reads ``[tool.erc-lint]``, ``_ledger`` and
``_history`` keep the number ledger, and ``_errors`` holds ``LintError``, the base of the
linter's own failures to run (``GitError``, for a revision that cannot be read, is the schema
layer's, an ``erc_schema.SchemaError``).
"""

from ._config import Config
from ._errors import ConfigError, GitError, LedgerError, LintError
from ._finding import Finding, Severity
from ._run import check, lint
from .rules import CATEGORIES, RULES, Rule

__all__ = [
    "CATEGORIES",
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
