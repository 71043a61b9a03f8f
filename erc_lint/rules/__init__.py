"""The rules: importing this package registers them all, in the order ``erc-lint rules`` lists."""

from .._finding import Finding, Severity
from .._pairing import Change
from . import enums, fields, messages, tree  # noqa: F401 - registration
from ._registry import RULES, Rule

__all__ = ["RULES", "Rule", "run"]


def run(change: Change) -> list[Finding]:
    """Every finding of every rule the configuration does not ignore, sorted by location."""
    found: list[Finding] = []
    for rule in RULES.values():
        if rule.id in change.config.ignore:
            continue
        if rule.pair is not None:
            for where, message, in_old in rule.pair(change):
                found.append(Finding.at(where, rule.id, message, rule.severity, in_old))
        elif rule.tree is not None:
            existing = {key for key, _, _ in rule.tree(change.old, change)}
            for key, where, message in rule.tree(change.new, change):
                severity: Severity = "warning" if key in existing else "error"
                found.append(Finding.at(where, rule.id, message, severity))
    if "COMPILE" not in change.config.ignore:
        found += _uncompared(change)
    return sorted(set(found))


def _uncompared(change: Change) -> list[Finding]:
    """A file OLD could not compile hides every change to it: say so, once per file."""
    return [
        Finding(
            str(change.old.root / name),
            1,
            1,
            "COMPILE",
            f"OLD's {name} does not compile, so its messages were not compared with NEW's.",
            "warning",
            in_old=True,
        )
        for name in sorted(change.old.tree.failed)
        if name not in change.new.tree.failed
    ]
