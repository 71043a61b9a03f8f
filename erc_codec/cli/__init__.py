"""The ``erc-codec`` command line: ``main`` (``erc_codec.cli._main``), one module per command group
beside it."""

from ._main import main

__all__ = ["main"]
