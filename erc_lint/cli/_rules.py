"""``erc-lint rules``: every rule with its default severity, its categories and its purpose; and
the categories, with what each holds and which ones run by default."""

import click

from ..rules import CATEGORIES, DEFAULT_CATEGORIES, RULES

__all__ = ["list_rules"]


@click.command(name="rules")
def list_rules() -> None:
    """List every rule (ID, default severity, categories, purpose), then the categories."""
    for rule in RULES.values():
        severity: str = "error (warning if OLD has it)" if rule.pairs == "tree" else rule.severity
        if rule.errors_in:
            severity += f" ({', '.join(rule.errors_in)}: error)"
        categories = ",".join(rule.categories)
        click.echo(f"{rule.id:<30} {severity:<30} {categories:<15} {rule.purpose}")
    click.echo()
    for category, holds in CATEGORIES.items():
        default = "default" if category in DEFAULT_CATEGORIES else ""
        if category == "RPC":
            default = "default when a revision declares a service"
        click.echo(f"{category:<10} {holds} [{default or 'use to select'}]")
