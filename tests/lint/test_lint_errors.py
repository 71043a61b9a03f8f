"""erc_lint's errors: the linter's own failures to run are ``LintError``; a tree that cannot be
read (a git revision's among them) is the schema layer's ``SchemaError``."""

import pytest

import erc_codec
import erc_lint
from erc_lint import ConfigError, GitError, LedgerError, LintError


@pytest.mark.parametrize("error", [ConfigError, LedgerError])
def test_the_linters_own_failures_are_lint_errors(error: type[Exception]) -> None:
    assert issubclass(error, LintError)
    with pytest.raises(LintError, match="why"):
        raise error("why")


def test_a_git_revision_that_cannot_be_read_is_a_schema_error() -> None:
    """``erc_lint.GitError`` stays importable: it is the codec's, which reads git revisions."""
    assert GitError is erc_codec.schema.GitError
    assert issubclass(GitError, erc_codec.SchemaError)
    assert not issubclass(GitError, LintError)


def test_the_errors_are_public() -> None:
    assert {"LintError", "ConfigError", "GitError", "LedgerError"} <= set(erc_lint.__all__)
    assert not issubclass(LintError, erc_lint.Finding)  # findings are results, never errors
