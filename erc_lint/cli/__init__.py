"""``erc-lint``, the linter's command line: ``main`` is the click group (``erc-lint OLD NEW`` is
its ``diff`` command), ``run`` the process around it, the console script. One module per command
group beside them: ``_diff`` (diff and check), ``_rules``, ``_ledger``; what they share in
``_shared``; the group itself in ``_main``, the process in ``_entry``."""

from ._entry import run
from ._main import main

__all__ = ["main", "run"]
