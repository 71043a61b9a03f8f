"""Lines to standard output or standard error that never hold up the caller: the relay's output.

A reader that stops reading (``| less``, a stuck log shipper) fills its pipe, and a plain write
then blocks the writer, here the event loop that routes and brakes; a reader that has gone makes
the write fail (``BrokenPipeError``). So each stream is written by a thread of its own from a
bounded queue: ``write`` returns at once, a line that finds the queue full is dropped and counted,
and a stream whose write failed stays closed, every later line counted as dropped too. Lines go to
the file descriptor with ``os.write``, past Python's buffered stream objects, so a thread stuck in
a write holds no lock that the interpreter's shutdown would wait for.
"""

import os
import queue
import select
import sys
import threading
import time
from collections.abc import Callable
from typing import Any

__all__ = ["LineStream", "flush_standard_streams"]

_QUEUED = 256  # lines waiting for a slow reader, at most (a status line is under a few KiB)


class LineStream:
    """Lines to file descriptor ``fd`` (``name`` in what it reports), written by a thread.

    ``on_closed(name, reason)`` is called once, from that thread, when a write fails."""

    def __init__(
        self, fd: int, name: str, on_closed: Callable[[str, str], object] | None = None
    ) -> None:
        self.name = name
        self._fd = fd
        self._on_closed = on_closed
        self._queue: queue.Queue[bytes | None] = queue.Queue(_QUEUED)
        self._written = 0
        self._dropped = 0  # lines refused by write(): the queue full, or the stream closed
        self._lost = 0  # lines the thread took but could not write
        self._failure: str | None = None
        self._writing = False  # the thread is inside a write
        try:
            os.fstat(fd)
        except OSError as error:  # started with the stream closed (2>&-)
            self._failure = error.strerror or "closed"
        self._thread = threading.Thread(target=self._run, name=f"{name} writer", daemon=True)
        self._thread.start()

    def write(self, line: str) -> bool:
        """Queue ``line`` (a newline is added); whether it was queued, or dropped and counted."""
        if self._failure is None:
            try:
                self._queue.put_nowait((line + "\n").encode("utf-8", "replace"))
                return True
            except queue.Full:
                pass
        self._dropped += 1
        return False

    def stats(self) -> dict[str, Any]:
        """Lines written, lines dropped (never written: a full queue, a closed stream), and why
        the stream closed (``None`` while it is open)."""
        return {
            "written": self._written,
            "dropped": self._dropped + self._lost,
            "closed": self._failure,
        }

    def close(self, timeout: float) -> None:
        """Write what is queued, waiting at most ``timeout`` seconds for a slow reader; what is
        still queued then is dropped and counted."""
        deadline, ended = time.monotonic() + timeout, False
        while not ended and time.monotonic() < deadline:
            try:
                self._queue.put_nowait(None)
                ended = True
            except queue.Full:
                time.sleep(0.01)
        self._thread.join(max(0.0, deadline - time.monotonic()))
        if self._thread.is_alive():  # a reader that never came back: what waits is dropped
            self._dropped += self._queue.qsize() - ended + self._writing

    def _run(self) -> None:
        while (line := self._queue.get()) is not None:
            if self._failure is not None:
                self._lost += 1
                continue
            self._writing = True
            try:
                _write_all(self._fd, line)
            except OSError as error:
                self._failure = error.strerror or type(error).__name__
                self._lost += 1
                if self._on_closed is not None:
                    self._on_closed(self.name, self._failure)
            else:
                self._written += 1
            finally:
                self._writing = False


def _write_all(fd: int, data: bytes) -> None:
    """Write all of ``data``; on a descriptor another process made non-blocking, wait until it
    takes more, as a blocking one would."""
    view = memoryview(data)
    while view:
        try:
            view = view[os.write(fd, view) :]
        except BlockingIOError:
            select.select([], [fd], [])


def flush_standard_streams() -> None:
    """Flush what Python's own ``sys.stdout`` and ``sys.stderr`` hold, before a ``LineStream``
    writes past them (a stream that fails to flush is left as it is)."""
    for stream in (sys.stdout, sys.stderr):
        try:
            if stream is not None:
                stream.flush()
        except (OSError, ValueError):
            pass
