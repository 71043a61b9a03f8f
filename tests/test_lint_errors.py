"""erc_lint's errors: whatever stops the linter from running is a ``LintError``."""

import pytest

import erc_lint
from erc_lint import ConfigError, GitError, LedgerError, LintError


@pytest.mark.parametrize("error", [ConfigError, GitError, LedgerError])
def test_every_failure_to_run_is_a_lint_error(error: type[Exception]) -> None:
    assert issubclass(error, LintError)
    with pytest.raises(LintError, match="why"):
        raise error("why")


def test_the_errors_are_public() -> None:
    assert {"LintError", "ConfigError", "GitError", "LedgerError"} <= set(erc_lint.__all__)
    assert not issubclass(LintError, erc_lint.Finding)  # findings are results, never errors
