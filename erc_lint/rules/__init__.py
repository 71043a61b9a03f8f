"""The rules: importing this package registers them all, in the order ``erc-lint rules`` lists."""

from . import enums, fields, messages, tree  # noqa: F401 - registration
from ._registry import RULES, Report, Rule, run

__all__ = ["RULES", "Report", "Rule", "run"]
