"""The ``erc-codec`` command: its group, and every command group of this package added to it."""

import click

from erc_schema.cli import OneLineGroup

from ._decode import decode
from ._encode import encode
from ._net import listen, send
from ._proton import proton
from ._record import record, replay
from ._relay import relay
from ._schema import schema
from ._shared import schema_options
from ._sizes import sizes
from ._stubs import stubs
from ._wireshark import wireshark

__all__ = ["main"]


@click.group(cls=OneLineGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="erc-codec")
@schema_options
def main(tree: str | None, root: str | None) -> None:
    """Encode, decode and size the ERC rover's PBEnvelope datagrams.

    --proto, --root and nanopb's generator inputs -I, -f and -s here hold
    for the command that follows, unless it gives its own. Without them, the
    schema is found (erc-codec schema says which): $ERC_CODEC_PROTO, else
    [tool.erc-codec] in the nearest pyproject.toml from here up, else the
    packaged one.
    """


_COMMANDS = (
    schema,
    sizes,
    decode,
    encode,
    send,
    listen,
    relay,
    record,
    replay,
    stubs,
    proton,
    wireshark,
)
for _command in _COMMANDS:
    main.add_command(_command)
