"""``erc-codec encode``: one payload, given as protobuf JSON, to a datagram in hex."""

import sys
from typing import cast

import click

from erc_schema import EncodeError

from ..codec import Mode
from ..runtime import frame
from ._shared import MODE, Fatal, envelope_from_json, load, one_line, schema_options

__all__ = ["encode"]


@click.command()
@click.argument("kind")
@click.argument("payload", metavar="JSON")
@MODE
@click.option(
    "--frame",
    "framed",
    is_flag=True,
    help="Wrap the datagram in a Proton serial frame (50 52, length, payload, CRC-16).",
)
@schema_options
def encode(
    kind: str, payload: str, mode: str, framed: bool, tree: str | None, root: str | None
) -> None:
    """Encode one payload, given as protobuf JSON, and print the datagram in hex.

    KIND is the envelope member that carries it (erc-codec sizes lists them,
    e.g. gps_info). JSON is the payload in protobuf's JSON mapping: field names
    as in the .proto or in lowerCamelCase, enums by name or by a declared
    number, 64-bit integers as numbers or strings; fields left out are zero.
    A line erc-codec decode printed is JSON too (its "message", when its
    "kind" is KIND). '-' reads the JSON from standard input.

    \b
      erc-codec encode gps_info '{"latitude": 52.2389, "fix_quality": "DGPS_FIX"}'
      erc-codec encode gps_info '{"satellites": 9}' --frame | erc-codec decode --framed
      erc-codec decode 620b09d8817346941e4a404802 | erc-codec encode gps_info -

    \b
    Exit status: 0 printed; 1 bad input: not JSON, not a payload of this kind
    (unknown field, wrong type, a number out of its field's range, a fraction
    for an integer) or a message a nanopb receiver would drop or misread (an
    undeclared enum value, a value over a nanopb limit); 2 usage error:
    unknown KIND or option, or a schema that does not load. An error about
    KIND, the JSON or the message is one line on stderr, naming the field.
    """
    codec = load(tree, root)
    if payload == "-" and sys.stdin is None:
        raise Fatal("standard input is closed: give the JSON as an argument")
    envelope = envelope_from_json(codec, kind, sys.stdin.read() if payload == "-" else payload)
    try:
        datagram = codec.encode(envelope, cast(Mode, mode))
    except EncodeError as error:
        raise click.ClickException(one_line(str(error))) from None
    click.echo((frame(datagram) if framed else datagram).hex())
