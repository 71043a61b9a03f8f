"""``python -m erc_codec``: the same as the ``erc-codec`` command."""

from .cli._main import main

main()
