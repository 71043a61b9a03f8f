"""erc_lint: the wire-compatibility linter for the rover's proto trees.

``lint(old, new)`` compares two revisions of a tree and returns the findings, sorted by location;
``erc-lint OLD NEW`` is the command line around it. Everything not re-exported here is private.
"""

from collections.abc import Sequence
from pathlib import Path

from ._config import Config, ConfigError
from ._finding import Finding, Severity
from ._loader import load_tree
from ._model import build
from ._pairing import Change
from .rules import RULES, Rule, run

__all__ = ["RULES", "Config", "ConfigError", "Finding", "Rule", "Severity", "lint"]


def lint(
    old: str | Path,
    new: str | Path,
    config: Config | None = None,
    includes: Sequence[str | Path] = (),
) -> list[Finding]:
    """Compare two proto trees (folders); every finding of every rule ``config`` does not ignore."""
    settings = config or Config()
    roots = [Path(folder) for folder in includes]
    revisions = [build(load_tree(Path(tree), roots, settings.exclude)) for tree in (old, new)]
    return run(Change(revisions[0], revisions[1], settings))
