"""``erc-lint rules``: every rule with its default severity, its categories and its purpose; and
the categories, with what each holds and which ones run by default. ``erc-lint rules RULE``,
``erc-lint rules --explain RULE`` and ``erc-lint explain RULE`` print one rule's documentation,
its docstring: what it protects, why a change breaks old readers or writers, an example before
and after, and the fix."""

import inspect

import click

from .._suggest import did_you_mean
from ..rules import CATEGORIES, DEFAULT_CATEGORIES, RULES

__all__ = ["explain", "list_rules"]


@click.command(name="rules")
@click.argument("rule", required=False)
@click.option("--explain", "explained", metavar="RULE", help="Print RULE's documentation.")
def list_rules(rule: str | None, explained: str | None) -> None:
    """List every rule (ID, default severity, categories, purpose), then the categories; with
    RULE (or --explain RULE), print that rule's documentation."""
    if rule or explained:
        click.echo(documentation(explained or rule or ""))
        return
    for each in RULES.values():
        severity: str = "error (warning if OLD has it)" if each.pairs == "tree" else each.severity
        if each.errors_in:
            severity += f" ({', '.join(each.errors_in)}: error)"
        categories = ",".join(each.categories)
        click.echo(f"{each.id:<30} {severity:<30} {categories:<15} {each.purpose}")
    click.echo()
    for category, holds in CATEGORIES.items():
        default = "default" if category in DEFAULT_CATEGORIES else ""
        if category == "RPC":
            default = "default when a revision declares a service"
        click.echo(f"{category:<10} {holds} [{default or 'use to select'}]")


@click.command()
@click.argument("rule")
def explain(rule: str) -> None:
    """Print RULE's documentation: what it protects, why, an example, the fix."""
    click.echo(documentation(rule))


def documentation(name: str) -> str:
    """``RULE — purpose`` and the rule's docstring; an unknown name is a usage error naming the
    closest rule (or category: its rules are listed)."""
    wanted = name.upper()
    if wanted in CATEGORIES:
        members = [r.id for r in RULES.values() if wanted in r.categories]
        return f"{wanted}: {CATEGORIES[wanted]}\nRules: {', '.join(members)}"
    rule = RULES.get(wanted)
    if rule is None:
        hint = did_you_mean(name, [*RULES, *CATEGORIES])
        raise click.UsageError(f"no rule {name!r}{hint}; `erc-lint rules` lists them")
    doc = inspect.cleandoc(rule.check.__doc__ or "")
    return f"{rule.id} ({rule.severity}; {', '.join(rule.categories)}): {rule.purpose}\n\n{doc}"
