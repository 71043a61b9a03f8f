"""What stops the linter from running, as opposed to what it finds: ``LintError`` is the base of
the linter's own failures (its configuration, its ledger), so a caller catches them with one
``except LintError``; a tree that cannot be read (a git revision among them: ``GitError``, the
schema layer's) is an ``erc_schema.SchemaError``. The command line turns both into one line and
exit status 2.

The findings of a run are never errors: a tree that breaks the wire is a result, not a failure.
"""

from erc_schema import GitError

__all__ = ["ConfigError", "GitError", "LedgerError", "LintError"]


class LintError(Exception):
    """erc-lint could not run: its configuration or its ledger is unusable."""


class ConfigError(LintError):
    """The configuration file cannot be read or says something invalid."""


class LedgerError(LintError):
    """A ledger file that cannot be read or is not a ledger; the message names the line."""
