"""The three transmission forms of a root message, written once for both codecs.

The forms are:
- exact;
- stripped of its trailing zeros;
- padded with zeros to the root's nanopb maximum size.

``_envelope`` (an envelope root) and ``_plain`` (any other root) each keep only what is theirs.

What this module guarantees, for a root of maximum size ``max_size``:
- ``in_form`` puts an exact encoding in a form. It is the one cut every sender uses (the codecs,
  the router).
- ``Forms.oversize`` is the error for an encoding longer than ``max_size``, which a fixed-size
  receiver drops.
- ``Forms.restore`` gives back the exact encoding of a datagram sent in any form.
- ``Forms.parse`` restores and parses.
- ``Forms.parse`` refuses restored zeros that make what no encoder sends: a field without presence
  at its default, or a varint ending in ``80 00`` (see ``_truncation``). That is a datagram cut
  short, reason ``"truncated"``.
- ``Forms.peek`` is the exact encoding, without the parse where no zeros were restored.
- ``Forms.peek`` is ``None`` for what ``parse`` would refuse before parsing.
- ``strict_error`` is what a strict decode refuses beyond that. First come fields the schema does
  not know, the envelope's own and the payload's (reason ``"unknown_fields"``). Then comes what
  nanopb's decoder refuses.
- Every failure is a ``DecodeError`` or ``EncodeError`` saying what and where (offset, field
  path).
- A datagram is bytes or any bytes-like object (``as_bytes``); a ``str`` is a ``TypeError``.

A stripped form lost only zeros of the value of its last top-level field. So one walk over the
top-level fields restores them:
- bytes past the end count as zeros for as long as that field needs;
- a zero byte where a tag is expected ends the message, provided nothing but zeros follows it.
"""

from collections.abc import Callable
from typing import Literal

from google.protobuf.message import DecodeError as ProtobufDecodeError
from google.protobuf.message import Message

from erc_schema import (
    EGROUP,
    SGROUP,
    DecodeError,
    EncodeError,
    WireError,
    descriptor_of,
    next_field,
)

from ._truncation import Table, cut_reason, presence_table
from ._unknown import UnknownField, unknown_fields

__all__ = ["Forms", "Mode", "as_bytes", "cut_short", "in_form", "strict_error"]

Mode = Literal["strip", "exact", "pad"]


class Forms:
    """The forms of root message ``cls``, whose longest encoding is ``max_size`` bytes.

    - ``whose`` names the root in errors (``"the envelope's"``, ``"Probe's"``).
    - ``groups`` says whether a group may stand at the top level; a proto3 envelope has none.
    - ``inside`` names cut fields from the envelope's member type, not from the root.
    - ``tables`` holds the presence tables already built (see ``presence_table``), shared with
      the caller's.
    """

    def __init__(
        self,
        cls: type[Message],
        max_size: int,
        whose: str,
        *,
        groups: bool,
        inside: bool,
        tables: dict[str, Table] | None = None,
    ) -> None:
        descriptor = descriptor_of(cls)
        self.name = descriptor.full_name
        self.max_size = max_size
        self._whose = whose
        self._groups = groups
        self._inside = inside
        self._from_string = cls.FromString
        self._table = presence_table(descriptor, tables)

    def oversize(self, name: str, length: int) -> EncodeError:
        """The error for a datagram of ``length`` bytes, carrying message ``name``, that does not
        fit the root's maximum."""
        return EncodeError(
            f"{name}: the datagram would be {length} bytes, more than the {self.max_size} a "
            "fixed-size receiver accepts (unknown fields from a newer sender?)"
        )

    def restore(self, data: bytes) -> bytes:
        """The exact encoding of a datagram sent exact, stripped or zero-padded."""
        if len(data) > self.max_size:
            raise DecodeError(
                f"datagram of {len(data)} bytes is longer than {self._whose} maximum of "
                f"{self.max_size}: a fixed-size receiver drops it",
                "too_long",
            )
        pos, end = 0, len(data)
        try:
            while pos < end:
                if data[pos] == 0:
                    return _unpad(data, pos)
                field = next_field(data, pos, zeros_past_end=True)
                if not self._groups and field.wire_type in (SGROUP, EGROUP):
                    raise DecodeError(
                        f"field {field.number} uses wire type {field.wire_type} (a group), "
                        "which a proto3 envelope never contains"
                    )
                pos = field.end
        except WireError as error:
            raise DecodeError(f"truncated or corrupt datagram: {error}") from None
        if pos > self.max_size:
            raise DecodeError(
                f"restoring its stripped zeros makes the datagram {pos} bytes long, more than "
                f"{self._whose} maximum of {self.max_size}"
            )
        return data + bytes(pos - end)

    def parse(self, data: bytes) -> Message:
        """The root message a datagram (``bytes``) in exact, stripped or padded form carries."""
        exact = self.restore(data)
        try:
            message = self._from_string(exact)
        except ProtobufDecodeError as error:
            form = "" if exact == data else " (after restoring its trailing zeros)"
            raise DecodeError(
                f"datagram of {len(data)} bytes is not a valid {self.name}{form}: {error}"
            ) from None
        if len(exact) > len(data):
            cut = self._cut(exact, message, len(data))
            if cut:
                raise cut_short(data, cut)
        return message

    def peek(self, data: bytes) -> bytes | None:
        """The exact encoding of a datagram (``bytes``) in exact, stripped or padded form.

        It is ``None`` where ``parse`` refuses the datagram for its form, its length or a cut.
        Only a datagram whose zeros were restored is parsed, to tell stripped from cut.
        """
        try:
            exact = self.restore(data)
        except DecodeError:
            return None
        if len(exact) > len(data):
            try:
                message = self._from_string(exact)
            except ProtobufDecodeError:
                return exact  # not a message at all: its parse says what is wrong
            if self._cut(exact, message, len(data)):
                return None
        return exact

    def _cut(self, exact: bytes, message: Message, boundary: int) -> str:
        """What restoring ``exact``'s zeros from ``boundary`` on made that no encoder sends, or
        ``""``. Partial: a proto2 message missing a required field parses, and the comparison
        with its restored bytes must not raise where the parse did not."""
        canonical = message.SerializePartialToString() == exact
        return cut_reason(self._table, exact, message, boundary, canonical, inside=self._inside)


def in_form(exact: bytes, mode: Mode, max_size: int) -> bytes:
    """The exact encoding ``exact`` in transmission form ``mode``.

    - ``"exact"``: as it is.
    - ``"strip"``: stripped of its trailing zeros. Every one of them belongs to the last field,
      so nothing else is lost.
    - ``"pad"``: padded with zeros to ``max_size`` bytes.
    """
    if mode == "strip":
        return exact.rstrip(b"\0")
    if mode == "exact":
        return exact
    if mode == "pad":
        if len(exact) > max_size:
            raise EncodeError(f"{len(exact)} bytes cannot be padded to {max_size}: they are more")
        return exact + bytes(max_size - len(exact))
    raise EncodeError(f"unknown mode {mode!r}: use 'strip', 'exact' or 'pad'")


def strict_error(
    size: int,
    message: Message,
    exact: bytes,
    subject: str,
    refusal: Callable[[Message, bytes], str | None] | None,
    around: tuple[UnknownField, ...] = (),
) -> DecodeError | None:
    """What a strict decode refuses in ``message``, decoded from a datagram of ``size`` bytes
    whose exact encoding (the root's: the envelope's, for a payload) is ``exact`` (``subject``
    names it: ``"gps_info payload"``, ``"Probe"``): fields its schema does not know, with
    ``around``, those the envelope around it does not know (their path is its name), before
    them; then what nanopb's decoder refuses (``refusal``, given the message and the exact
    bytes, which it reads as nanopb does); ``None`` if nothing."""
    found = []
    if around:
        found.append(_not_known("envelope", around[0].path, around, around[0].path))
    unknown = unknown_fields(message)
    if unknown:
        found.append(_not_known(subject, message.DESCRIPTOR.full_name, unknown, ""))
    if found:
        return DecodeError(
            f"datagram of {size} bytes: {'; '.join(found)} (another schema?)", "unknown_fields"
        )
    why = refusal(message, exact) if refusal is not None else None
    if why is not None:
        return DecodeError(f"nanopb's decoder refuses the {subject}: {why}")
    return None


def _not_known(subject: str, name: str, fields: tuple[UnknownField, ...], own: str) -> str:
    """``its SUBJECT holds fields NAME does not know: N (wire type W[, in PATH]), ...``; the
    path is shown for a field inside a nested message, not for one whose path is ``own``."""
    listed = ", ".join(
        f"{field.number} (wire type {field.wire_type}"
        + (f", in {field.path})" if field.path != own else ")")
        for field in fields
    )
    return f"its {subject} holds fields {name} does not know: {listed}"


def cut_short(data: bytes, why: str) -> DecodeError:
    """The error for a datagram whose restored zeros make what no encoder sends."""
    return DecodeError(f"datagram of {len(data)} bytes was cut short: {why}", "truncated")


def as_bytes(data: object) -> bytes:
    """The bytes of a bytes-like object; ``TypeError`` for anything else."""
    if isinstance(data, str):
        raise TypeError("a datagram is bytes (or bytearray, memoryview), not str")
    try:
        return memoryview(data).tobytes()  # type: ignore[arg-type]
    except TypeError:
        raise TypeError(
            f"a datagram is bytes (or bytearray, memoryview), not {type(data).__name__}"
        ) from None


def _unpad(data: bytes, pos: int) -> bytes:
    """Cut zero padding that starts at ``pos``; anything non-zero after it is corruption."""
    stray = len(data.rstrip(b"\0"))
    if stray > pos:
        first = next(i for i in range(pos, stray) if data[i])
        raise DecodeError(
            f"zero byte at offset {pos} ends the message, "
            f"but a non-zero byte follows at offset {first}"
        )
    return data[:pos]
