"""``erc-codec sizes``: every message's nanopb maximum size, and the envelope's members."""

import json

import click

from ._shared import load, schema_options, text_or_json

__all__ = ["sizes"]


@click.command()
@schema_options
@text_or_json
def sizes(tree: str | None, root: str | None, output: str) -> None:
    """Print every message's nanopb maximum size and the envelope's members."""
    codec = load(tree, root)
    root = codec.root
    members = [
        {
            "number": member.number,
            "kind": member.kind,
            "type": member.message,
            "max_size": codec.max_size(member.message),
            "direction": " -> ".join(member.direction) if member.direction else None,
        }
        for member in codec.members()
    ]
    messages = dict(sorted(codec.sizes().items()))
    if output == "json":
        document = {"root": root, "max_size": codec.max_size(root), "members": members}
        click.echo(json.dumps({**document, "messages": messages}, indent=2))
        return
    click.echo(f"{root} members")
    click.echo(f"  {'#':>3}  {'kind':<34}{'payload':<36}{'max':>5}  direction")
    for m in members:
        click.echo(
            f"  {m['number']:>3}  {m['kind']:<34}{m['type']:<36}{m['max_size']:>5}"
            f"  {m['direction'] or '-'}"
        )
    click.echo(f"{root}_size {codec.max_size(root)}")
    click.echo("")
    click.echo("nanopb maximum encoded size of every message")
    for name, size in messages.items():
        click.echo(f"  {name:<44}{'runtime' if size is None else size:>8}")
