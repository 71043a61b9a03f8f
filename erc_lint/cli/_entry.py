"""The ``erc-lint`` command as a process: ``main`` (the click group), then the process left with
``os._exit`` once standard output and standard error are flushed.

A speed trick: freeing every module, class and descriptor one by one at interpreter shutdown
takes 15 to 18 ms of a 110 to 170 ms run. Its target is erc-lint's wall time against ``buf
breaking``, benchmarks/bench_lint.py: at most 1.0x on each pair. Nothing a command does is left
to shutdown: every file it writes (a baseline, the ledger) is written and closed before it
returns, and scratch folders are removed by the blocks that made them; nothing registers an
``atexit`` handler or starts a thread.
``test_the_quick_exit_gives_what_the_plain_exit_gives`` runs commands both ways (``main``, the
plain console script, and ``run``) and compares their output, files and statuses.
"""

import os
import sys
from typing import NoReturn

from ._main import main

__all__ = ["run"]


def run() -> NoReturn:
    """``erc-lint`` with ``sys.argv``, then leave the process with the command's exit status."""
    try:
        main()
    except SystemExit as done:
        status = _status(done.code)
    else:  # the group always exits; a plain return would mean success
        status = 0
    for stream in (sys.stdout, sys.stderr):
        if stream is None:  # started with the descriptor closed: nothing was written to it
            continue
        try:
            stream.flush()
        except (OSError, ValueError):  # Python's own status for a failed final flush, unless
            status = status or 120  # the run had failed already: its status says more
    os._exit(status)


def _status(code: object) -> int:
    """The exit status ``SystemExit(code)`` means, as Python's own exit handling reads it."""
    if code is None:
        return 0
    if isinstance(code, int):
        return code
    print(code, file=sys.stderr)
    return 1
