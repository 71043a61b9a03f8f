"""The ``erc-lint`` command as a process: its exit tuned for a run of a fraction of a second.

The process ends with ``os._exit`` once the output is flushed: freeing every module, class and
descriptor one by one at interpreter shutdown takes longer than linting a small tree. Nothing the
command does is left to shutdown: files and scratch folders are closed by the commands.
"""

import os
import sys

from ._main import main

__all__ = ["run"]


def run() -> None:
    """``erc-lint`` with ``sys.argv``, then leave the process with the command's exit status."""
    try:
        main()
    except SystemExit as done:
        status = _status(done.code)
    else:  # click's standalone mode always exits; a plain return means success
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
