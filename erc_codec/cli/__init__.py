"""The command lines' shell: ``OneLineGroup``, the click group both ``erc-codec`` and ``erc-lint``
are made of (every error one line, exit statuses as documented). The ``erc-codec`` command itself
is ``erc_codec.cli._main``: one module per command group beside it."""

from ._group import OneLineGroup

__all__ = ["OneLineGroup"]
