"""``erc-lint``, the linter's command line: ``main`` is the click group and the console script
(``erc-lint OLD NEW`` is its ``diff`` command). One module per command group beside it:
``_diff`` (diff and check), ``_rules``, ``_ledger``; what they share in ``_shared``; the group
itself in ``_main``."""

from ._main import main

__all__ = ["main"]
