"""The rules: importing this package registers them all, in the order ``erc-lint rules`` lists."""

from . import enums, extensions, fields, messages, nanopb, services, tree  # noqa: F401 - registration
from ._registry import CATEGORIES, DEFAULT_CATEGORIES, RULES, Report, Rule, run, select

__all__ = ["CATEGORIES", "DEFAULT_CATEGORIES", "RULES", "Report", "Rule", "run", "select"]
