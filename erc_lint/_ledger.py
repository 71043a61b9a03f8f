"""The number ledger: every number each message and enum has carried, with its name and type.

A ledger is a text file (``erc-lint.lock`` beside the protos) made to be read in a code review:

    message BasestationManualDrive 1 forward_backward float 5f3c2a1b9d0e
    message BasestationManualDrive 2 left_right float -
    enum ArmBoardMode 0 ARM_BOARD_MODE_IDLE - 5f3c2a1b9d0e
    message BasestationManualDrive 2 speed sint32 77a1c0e4b2d9 ack  # old boards retired

Columns: the kind of container (``message`` for fields, ``enum`` for values), its full name, the
number, the name the number carried, its type (``-`` for enum values), and the revision that first
used it (``-`` when it was added from a folder). ``ack`` after an entry accepts that use of a
number that carried something else before; ``#`` starts a comment.

Guarantees:
- Rendering is canonical: entries sorted by container, kind, number, name and type, one a line,
  so adding numbers adds lines and nothing else moves. An update never changes or drops an entry,
  an acknowledgement or a comment: a comment on its own line stays above the entry it precedes,
  one set apart by a blank line before the first entry stays at the top; line endings stay.
- A line that is not an entry, an entry given twice, or a merge conflict left in the file is a
  ``LedgerError`` naming the file and the line; so is a ledger that is not a regular file (a
  device, a FIFO) or is over ``LEDGER_LIMIT`` (64 MiB), refused before it is read.
"""

import os
import re
import tempfile
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

from erc_schema import FileError, read_file

from ._config import LEDGER_LIMIT
from ._errors import LedgerError

__all__ = ["Entry", "Key", "Ledger"]

HEADER = (
    "# erc-lint ledger: every number each message and enum has carried, with its name and type,\n"
    "# and the revision that first used it. Sorted, one entry a line; `erc-lint ledger update`\n"
    "# adds entries and never changes one. To accept a reused number, end its new entry with ack.\n"
)
_HEADER_LINES = frozenset(HEADER.splitlines())
_KINDS = ("message", "enum")
_NUMBER = re.compile(r"-?[0-9]+")
_REVISION = re.compile(r"-|[0-9a-f]{4,64}")


class Key(NamedTuple):
    """What one entry records: a number of a container and what it carried."""

    kind: str  # "message" (a field) or "enum" (a value)
    container: str
    number: int
    name: str
    type: str  # "-" for enum values


@dataclass
class Entry:
    key: Key
    since: str  # the revision that first used it, "-" when unknown
    ack: bool = False
    note: str = ""  # the comment after the entry, without its "#"
    above: list[str] = field(default_factory=list)  # comment lines just above it
    line: int = 0  # where it is in the file it was read from (0: not from a file)

    def render(self) -> str:
        k = self.key
        text = f"{k.kind} {k.container} {k.number} {k.name} {k.type} {self.since}"
        text += " ack" if self.ack else ""
        text += f"  #{self.note}" if self.note else ""
        return "".join(f"{line}\n" for line in self.above) + text + "\n"


@dataclass
class Ledger:
    path: str  # how messages name the file
    entries: dict[Key, Entry] = field(default_factory=dict)
    preamble: list[str] = field(default_factory=list)  # comments before the first entry
    trailer: list[str] = field(default_factory=list)  # comment lines after the last entry
    newline: str = "\n"  # as the file had them
    _numbers: dict[tuple[str, str, int], list[Entry]] | None = None
    _bodies: dict[tuple[str, str], set[tuple[int, str, str]]] | None = None

    @classmethod
    def read(cls, path: Path, shown: str | None = None) -> "Ledger":
        """The ledger in ``path`` (named ``shown`` in messages)."""
        name = shown or str(path)
        try:
            text = read_file(path, LEDGER_LIMIT).decode("utf-8")  # line endings as they are
        except FileError as error:
            raise LedgerError(f"{name}: {error.reason}") from None
        except UnicodeDecodeError:
            raise LedgerError(f"{name}: not UTF-8 text") from None
        return cls.parse(text, name)

    @classmethod
    def parse(cls, text: str, path: str) -> "Ledger":
        ledger = cls(path, newline="\r\n" if "\r\n" in text else "\n")
        pending: list[str] = []
        for number, raw in enumerate(text.removeprefix("\ufeff").splitlines(), 1):
            line = raw.rstrip()
            if line.startswith(("<<<<<<<", "=======", ">>>>>>>", "|||||||")):
                raise LedgerError(
                    f"{path}:{number}: unresolved merge conflict; keep both sides' "
                    "entries and delete the markers"
                )
            if not line.strip() and not ledger.entries:  # a comment block apart from any entry
                ledger.preamble += pending
                pending = []
            if not line.strip() or line in _HEADER_LINES:
                continue
            if line.lstrip().startswith("#"):
                pending.append(line)
                continue
            entry = _entry(line, f"{path}:{number}")
            entry.line, entry.above, pending = number, pending, []
            twin = ledger.entries.get(entry.key)
            if twin is not None:
                raise LedgerError(
                    f"{path}:{number}: entry given twice (first on line {twin.line}): "
                    f"{entry.key.kind} {entry.key.container} {entry.key.number} "
                    f"{entry.key.name}"
                )
            ledger.entries[entry.key] = entry
        ledger.trailer = pending
        return ledger

    def render(self) -> str:
        body = "".join(self.entries[key].render() for key in sorted(self.entries, key=_order))
        preamble = "".join(f"{line}\n" for line in self.preamble)
        text = HEADER + preamble + body + "".join(f"{line}\n" for line in self.trailer)
        return text.replace("\n", self.newline)

    def add(self, keys: Iterable[Key], since: str) -> list[Entry]:
        """Record the keys not yet recorded, as first used in ``since``; the new entries."""
        added = [Entry(key, since) for key in sorted(set(keys) - set(self.entries), key=_order)]
        for entry in added:
            self.entries[entry.key] = entry
        self._numbers = self._bodies = None
        return added

    def at(self, kind: str, container: str, number: int) -> list[Entry]:
        """Every entry for one number of one container."""
        if self._numbers is None:
            self._numbers = {}
            for key in sorted(self.entries, key=_order):
                slot = (key.kind, key.container, key.number)
                self._numbers.setdefault(slot, []).append(self.entries[key])
        return self._numbers.get((kind, container, number), [])

    def body(self, kind: str, container: str) -> set[tuple[int, str, str]]:
        """``(number, name, type)`` of every entry of one container: all it ever carried."""
        if self._bodies is None:
            self._bodies = {}
            for key in self.entries:
                self._bodies.setdefault((key.kind, key.container), set()).add(
                    (key.number, key.name, key.type)
                )
        return self._bodies.get((kind, container), set())

    def write(self, target: Path) -> None:
        """Replace ``target`` with the ledger at once, so an interrupted or failed update (a
        full disk) never leaves half a ledger: the old one stays, and the failure is a
        ``LedgerError``."""
        try:
            target.parent.mkdir(parents=True, exist_ok=True)
            handle, scratch = tempfile.mkstemp(prefix=f".{target.name}.", dir=target.parent)
        except OSError as error:
            raise LedgerError(f"{target}: cannot write: {error.strerror}") from None
        try:
            with os.fdopen(handle, "w", encoding="utf-8", newline="\n") as stream:
                stream.write(self.render())
            os.replace(scratch, target)
        except BaseException as error:
            Path(scratch).unlink(missing_ok=True)
            if isinstance(error, OSError):
                raise LedgerError(f"{target}: cannot write: {error.strerror}") from None
            raise

    def where(self, entry: Entry) -> str:
        """``file:line`` of an entry read from a file, else the file."""
        return f"{self.path}:{entry.line}" if entry.line else self.path


def _order(key: Key) -> tuple[str, str, int, str, str]:
    return (key.container, key.kind, key.number, key.name, key.type)


def _entry(line: str, where: str) -> Entry:
    code, _, note = line.partition("#")
    words = code.split()
    if len(words) == 7 and words[6] == "ack":
        words, ack = words[:6], True
    else:
        ack = False
    if len(words) != 6:
        raise LedgerError(
            f"{where}: expected KIND CONTAINER NUMBER NAME TYPE REVISION [ack], "
            f"not {code.strip()!r}"
        )
    kind, container, number, name, type_, since = words
    if kind not in _KINDS:
        raise LedgerError(f"{where}: kind must be message or enum, not {kind!r}")
    if not _NUMBER.fullmatch(number):
        raise LedgerError(f"{where}: number {number!r} is not an integer")
    if not _REVISION.fullmatch(since):
        raise LedgerError(f"{where}: revision {since!r} is neither a commit id nor -")
    value = int(number)
    if (kind == "enum") != (type_ == "-"):
        raise LedgerError(f"{where}: the type of an enum value is -, of a field never")
    return Entry(Key(kind, container, value, name, type_), since, ack, note.rstrip())
