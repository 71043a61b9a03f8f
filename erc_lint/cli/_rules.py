"""``erc-lint rules``: every rule with its default severity and purpose."""

import click

from ..rules import RULES

__all__ = ["list_rules"]


@click.command(name="rules")
def list_rules() -> None:
    """List every rule: ID, default severity and purpose."""
    for rule in RULES.values():
        severity = "error (warning if OLD has it)" if rule.pairs == "tree" else rule.severity
        click.echo(f"{rule.id:<26} {severity:<30} {rule.purpose}")
