"""``record``'s MCAP file, written by a second process.

Why: writing one message costs the ``mcap`` library more than receiving and decoding a datagram
costs ``record`` (about 13 µs against 4 µs, beside asyncio's own cost per datagram), so one
process doing both falls behind well before 20,000 datagrams a second and the kernel drops what
it cannot hold (benchmarks/bench_record.py). Here the receiving process only batches each payload
(its exact bytes) or drop with its time and sender, and hands batches over a pipe to a child that
owns the ``McapWriter``; the child runs on another core.

Guarantees: the child is ready (its schema loaded, the mcap library imported) before the socket is
bound, and the file is created only once the socket is; every item handed over is written, in
order; a child that cannot write says why and the recording stops with that error; a parent that
dies leaves the child to finish the file (it reads the end of the pipe as the end of the
recording: the child closes its inherited copy of the parent's end first). The child ignores
Ctrl-C and SIGHUP, which the terminal sends to both: the parent decides when to stop. Memory is
bounded by one batch and the pipe's buffer, whatever the rate: a child that falls behind blocks
the parent, and the kernel's drop counter says what that cost.
"""

import contextlib
import multiprocessing
import signal
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

from erc_schema import CodecError

from ..capture import McapWriter, RecordingStats
from ..capture._recording import require
from ..codec import Codec
from ._shared import Fatal

__all__ = ["WriterProcess"]

_BATCH = 256  # items per hand-over: the pipe's cost per item falls until about here
_CHUNK = 1 << 18  # a live recording's chunks: 256 KiB, so a crash loses little


class WriterProcess:
    """An ``McapWriter`` in a child process, fed in batches."""

    def __init__(self, codec: Codec) -> None:
        methods = multiprocessing.get_all_start_methods()
        # fork hands the loaded schema over as it is; spawn (other systems) loads it again.
        context: Any = multiprocessing.get_context("fork" if "fork" in methods else "spawn")
        self._conn, child = context.Pipe()
        forked = "fork" in methods
        inherited = codec if forked else None
        # A forked child holds a copy of the parent's end too: it closes it first thing, or it
        # would never read the end of the pipe when the parent dies.
        parents = self._conn if forked else None
        tree, root = codec.schema.tree, codec.root
        self._process = context.Process(
            target=_serve, args=(child, parents, inherited, tree, root), name="erc-codec writer"
        )
        self._process.start()
        child.close()
        self._batch: list[tuple[Any, ...]] = []
        self._expect("ready")

    def open(self, output: Path, source: str) -> None:
        """Create the file (never over an existing one)."""
        self._conn.send(("open", str(output), source))
        self._expect("opened")

    def message(self, kind: str, data: bytes, log_time: int, source: str) -> None:
        self._batch.append((kind, data, log_time, source))
        if len(self._batch) >= _BATCH:
            self.flush()

    def drop(self, data: bytes, log_time: int, reason: str, error: str, source: str) -> None:
        self._batch.append((None, data, log_time, source, reason, error))
        if len(self._batch) >= _BATCH:
            self.flush()

    def flush(self) -> None:
        """Hand over what is batched; a child that has stopped is the recording's error."""
        if self._conn.poll():
            self._answer()  # only an error comes unasked
        if self._batch:
            try:
                self._conn.send(("batch", self._batch))
            except OSError:
                raise Fatal(f"the MCAP writer stopped: {self._why()}") from None
            self._batch = []

    def close(self, summary: dict[str, str]) -> tuple[RecordingStats, int]:
        """Finish the file with ``summary`` in its metadata: what was written, and its size."""
        self.flush()
        self._conn.send(("close", summary))
        _, stats, size = self._expect("closed")
        self._process.join()
        return stats, size

    def abort(self) -> None:
        """Stop the child without a file (the socket could not be bound)."""
        with contextlib.suppress(OSError):
            self._conn.send(("quit",))
        self._process.join(timeout=10)

    def shutdown(self) -> None:
        """However the recording ended: a child still running finishes what it has (a file it
        has open is closed complete) and is gone when this returns."""
        if self._process.is_alive():
            with contextlib.suppress(OSError):
                self._conn.send(("close", {"ended": "the recording stopped on an error"}))
            self._process.join(timeout=30)
        if self._process.is_alive():
            self._process.terminate()
            self._process.join()
        self._conn.close()

    def _expect(self, word: str) -> tuple[Any, ...]:
        answer = self._answer()
        if answer[0] != word:
            raise Fatal(f"the MCAP writer said {answer!r}, not {word!r}")
        return answer

    def _answer(self) -> tuple[Any, ...]:
        try:
            answer: tuple[Any, ...] = self._conn.recv()
        except (EOFError, OSError):
            raise Fatal(f"the MCAP writer stopped: {self._why()}") from None
        if answer[0] == "error":
            self._process.join()
            raise Fatal(answer[1])
        return answer

    def _why(self) -> str:
        self._process.join(timeout=5)
        return f"exit status {self._process.exitcode}"


def _serve(
    conn: Connection, parents: Connection | None, codec: Codec | None, tree: Path, root: str
) -> None:
    """The child: load the schema, then write what arrives until told to close."""
    if parents is not None:
        parents.close()
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if hasattr(signal, "SIGHUP"):  # a dropped ssh session: as Ctrl-C
        signal.signal(signal.SIGHUP, signal.SIG_IGN)
    try:
        codec = codec or Codec.from_path(tree, root)
        require("mcap.writer", "mcap", "mcap", "writing MCAP")  # before the socket is bound
    except (CodecError, ImportError) as error:  # an ImportError names the extra to install
        conn.send(("error", str(error)))
        return
    conn.send(("ready",))
    writer: McapWriter | None = None
    output = ""
    try:
        while True:
            try:
                command = conn.recv()
            except EOFError:  # the parent is gone: the recording ends here
                command = ("close", {"ended": "the recording process stopped unannounced"})
            if command[0] == "open":
                _, output, source = command
                try:
                    file = Path(output).open("xb")  # noqa: SIM115 (closed after the writer)
                except FileExistsError:  # never over an existing file, however new
                    conn.send(("error", f"{output} exists: remove it or choose another name"))
                    return
                writer = McapWriter(file, codec, source=source, chunk_size=_CHUNK)
                conn.send(("opened",))
            elif command[0] == "batch" and writer is not None:
                _write(writer, command[1])
            elif command[0] == "close" and writer is not None:
                writer.close(command[1])
                file.close()
                conn.send(("closed", writer.stats(), Path(output).stat().st_size))
                return
            else:  # quit
                return
    except (OSError, CodecError) as error:
        text = error.strerror if isinstance(error, OSError) and error.strerror else str(error)
        with contextlib.suppress(OSError):  # a parent that is gone hears nothing
            conn.send(("error", f"cannot write {output or 'the MCAP file'}: {text}"))


def _write(writer: McapWriter, batch: list[tuple[Any, ...]]) -> None:
    message, drop = writer.message, writer.drop
    for item in batch:
        if item[0] is None:
            _, data, log_time, source, reason, error = item
            drop(data, log_time, reason, error, source)
        else:
            message(*item)
