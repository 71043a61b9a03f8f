"""The ``erc-codec`` command line: a thin shell over the codec."""

import json
import re
from pathlib import Path

import click

from ._codec import Codec, default_tree
from ._errors import CodecError
from ._schema import descriptor_of, message_of

__all__ = ["main"]

_DIRECTION = re.compile(r"direction:\s*(.+)", re.IGNORECASE)


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="erc-codec")
def main() -> None:
    """Encode, decode and size the ERC rover's PBEnvelope datagrams."""


@main.command()
@click.option(
    "--proto",
    "tree",
    type=click.Path(file_okay=False, path_type=Path),
    help="Proto tree to load (its import root). Default: the packaged rover schema.",
)
@click.option("--root", default="PBEnvelope", show_default=True, help="The envelope message.")
@click.option(
    "--format",
    "output",
    type=click.Choice(["text", "json"]),
    default="text",
    show_default=True,
)
def sizes(tree: Path | None, root: str, output: str) -> None:
    """Print every message's nanopb maximum size and the envelope's members."""
    try:
        codec = Codec.from_path(tree or default_tree(), root)
    except CodecError as error:
        raise click.ClickException(str(error)) from None
    members = []
    for number, kind in sorted(codec.kinds().items()):
        field = descriptor_of(codec.message_class(root)).fields_by_name[kind]
        payload = message_of(field).full_name
        note = _DIRECTION.search(codec._schema.comments.get(field.full_name, ""))
        members.append(
            {
                "number": number,
                "kind": kind,
                "type": payload,
                "max_size": codec.max_size(payload),
                "direction": note.group(1).strip() if note else None,
            }
        )
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
