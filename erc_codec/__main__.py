"""``python -m erc_codec``: the same as the ``erc-codec`` command."""

from ._cli import main

main()
