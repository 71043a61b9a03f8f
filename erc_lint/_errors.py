"""What stops the linter from running, as opposed to what it finds: one base class, so a caller
(the command line among them) catches every such failure with one ``except LintError``.

The findings of a run are never errors: a tree that breaks the wire is a result, not a failure.
"""

__all__ = ["ConfigError", "GitError", "LedgerError", "LintError"]


class LintError(Exception):
    """erc-lint could not run: its configuration, a git input or the ledger is unusable."""


class ConfigError(LintError):
    """The configuration file cannot be read or says something invalid."""


class GitError(LintError):
    """The repository or an object in it cannot be read."""


class LedgerError(LintError):
    """A ledger file that cannot be read or is not a ledger; the message names the line."""
