"""``python -m erc_lint``: the same as the ``erc-lint`` command."""

from .cli import run

run()
