"""``python -m erc_lint``: the same as the ``erc-lint`` command."""

from ._cli import main

main()
