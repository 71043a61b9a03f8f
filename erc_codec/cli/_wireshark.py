"""``erc-codec wireshark``: a Lua dissector for the schema's envelope, on standard output."""

import click

from erc_schema import SchemaError

from ..capture._wireshark import DEFAULT_PORTS, wireshark_dissector
from ._shared import Fatal, load, one_line, schema_options

__all__ = ["wireshark"]


@click.command()
@click.option(
    "--port",
    "ports",
    type=click.IntRange(1, 65535),
    multiple=True,
    metavar="N",
    help="A UDP port to dissect (repeatable). Default: 5000 and 7, the fleet's.",
)
@schema_options
def wireshark(ports: tuple[int, ...], tree: str | None, root: str | None) -> None:
    """Print a Wireshark dissector (Lua) for the schema's envelope.

    \b
      erc-codec wireshark > erc_envelope.lua
      tshark -X lua_script:erc_envelope.lua -r run.pcapng -V
    Or copy the file into Wireshark's personal Lua plugins folder (Help >
    About Wireshark > Folders). The dissector restores stripped trailing
    zeros and cuts padding exactly as erc-codec decode does, names the
    envelope member, shows every field with its name and value (a field not
    on the wire shows its default, in brackets), and marks unknown members,
    unknown fields and corrupt datagrams with expert info; filter on
    erc.kind, erc.reason or erc.<Message>.<field>. It needs no .proto files:
    the schema is written into it, so regenerate it when the schema changes.
    """
    codec = load(tree, root)
    try:
        text = wireshark_dissector(codec, ports or DEFAULT_PORTS)
    except SchemaError as error:
        raise Fatal(one_line(str(error))) from None
    click.echo(text, nl=False)
