"""The ``erc-codec`` command: its group, and every command group of this package added to it."""

import click

from ._decode import decode
from ._encode import encode
from ._group import OneLineGroup
from ._net import listen, send
from ._proton import proton
from ._record import record, replay
from ._sizes import sizes
from ._wireshark import wireshark

__all__ = ["main"]


@click.group(cls=OneLineGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="erc-codec")
def main() -> None:
    """Encode, decode and size the ERC rover's PBEnvelope datagrams."""


for _command in (sizes, decode, encode, send, listen, record, replay, proton, wireshark):
    main.add_command(_command)
