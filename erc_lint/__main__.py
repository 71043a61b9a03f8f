"""``python -m erc_lint``: the same as the ``erc-lint`` command."""

from ._entry import run

run()
