"""The command lines' shell: ``OneLineGroup``, the click group both ``erc-codec`` and ``erc-lint``
are made of (every error one line, exit statuses as documented), ``generator_options``, the
nanopb generator inputs both take (``-I``, ``-f``, ``-s``), and ``main``, the ``erc-codec``
command itself (``erc_codec.cli._main``: one module per command group beside it), loaded only
when asked for: erc-lint, which imports this package for its group, does not pay for the
commands."""

from typing import Any as _Any

from ._generator import generator_options
from ._group import OneLineGroup

__all__ = ["OneLineGroup", "generator_options", "main"]


def __getattr__(name: str) -> _Any:
    if name == "main":
        from ._main import main

        return main
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(__all__)
