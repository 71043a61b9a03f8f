"""The rules: importing this package registers them all, in the order ``erc-lint rules`` lists."""

from . import (  # noqa: F401 - registration
    enums,
    extensions,
    fields,
    messages,
    nanopb,
    services,
    suppressions,
    tree,
)
from ._registry import CATEGORIES, DEFAULT_CATEGORIES, RULES, Report, Rule, run, select

__all__ = ["CATEGORIES", "DEFAULT_CATEGORIES", "RULES", "Report", "Rule", "run", "select"]
