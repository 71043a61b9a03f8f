"""``python -m erc_codec``: the same as the ``erc-codec`` command."""

from .cli import main

main()
