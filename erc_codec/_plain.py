"""One plain message (a root that is not an envelope) in the three transmission forms.

What this module guarantees, as ``_envelope`` does for envelopes:
- ``encode`` produces exactly the bytes protobuf (and nanopb) would for the message, after the
  fixed-size contract's checks, then strips or pads trailing zeros relative to the root's nanopb
  maximum size; it never lets through what a fixed-size receiver would drop.
- ``decode`` accepts the exact, the stripped and the zero-padded form and returns the same message
  for all three: a stripped form lost only zeros of the value of its last top-level field, so one
  walk over the top-level fields restores them (bytes past the end count as zeros for as long as
  that field needs), and a zero byte where a tag is expected ends the message, provided nothing
  but zeros follows it. An empty datagram is the message with every field at its default.
  Restored zeros that make what no encoder sends (a field without presence at its default, a
  varint ending in ``80 00``: see ``_truncation``) are a datagram cut short, reason
  ``"truncated"``, as for envelopes.
- Every failure is a ``DecodeError``/``EncodeError`` saying what and where.
"""

from collections.abc import Callable

from google.protobuf.descriptor import Descriptor
from google.protobuf.message import DecodeError as ProtobufDecodeError
from google.protobuf.message import Message

from ._contract import Contract
from ._envelope import Decoded, Mode
from ._errors import DecodeError, EncodeError, SchemaError
from ._truncation import cut_reason, presence_table
from .schema import WireError, descriptor_of, next_field

__all__ = ["Plain"]


class Plain:
    """Encoder and decoder for one plain message type; a decode's ``kind`` is its full name."""

    def __init__(
        self,
        cls: type[Message],
        max_size: int,
        contract: Callable[[Descriptor], Contract | None],
        refusal: Callable[[Message, bytes], str | None] | None = None,
    ) -> None:
        descriptor = descriptor_of(cls)
        self._refusal = refusal
        self._name = descriptor.full_name
        self._class = cls
        self._max_size = max_size
        rules = contract(descriptor)
        self._check = rules.check if rules is not None else None
        self._table = presence_table(descriptor)

    def kinds(self) -> dict[int, str]:
        """A plain message has no envelope members: ``{}``."""
        return {}

    def payload_class(self, kind: str) -> type[Message]:
        """The root's class, for ``kind`` its full name (what a decode returns as the kind)."""
        if kind != self._name:
            raise SchemaError(f"{kind!r} is not {self._name}, the plain message this codec sends")
        return self._class

    def encode(self, message: Message, mode: Mode = "strip", /, **metadata: object) -> bytes:
        """The datagram carrying ``message`` (an instance of the root message) in ``mode``; a
        plain root has no envelope, so no metadata to set."""
        if metadata:
            raise EncodeError(
                f"{self._name} is no envelope: it has no metadata fields to set "
                f"({', '.join(metadata)})"
            )
        if message.DESCRIPTOR.full_name != self._name:
            raise EncodeError(
                f"{message.DESCRIPTOR.full_name} is not {self._name}, the message this codec sends"
            )
        if self._check is not None:
            self._check(message)
        data = message.SerializePartialToString()  # unset required fields: the check's to name
        if len(data) > self._max_size:
            raise EncodeError(
                f"{self._name}: the datagram would be {len(data)} bytes, more than the "
                f"{self._max_size} a fixed-size receiver accepts (unknown fields from a newer "
                "sender?)"
            )
        if mode == "strip":
            return data.rstrip(b"\0")
        if mode == "exact":
            return data
        if mode == "pad":
            return data + bytes(self._max_size - len(data))
        raise EncodeError(f"unknown mode {mode!r}: use 'strip', 'exact' or 'pad'")

    def peek(self, data: bytes) -> tuple[str, bytes] | None:
        """The kind and exact bytes of a datagram in exact, stripped or padded form; ``None``
        where only ``decode`` can say what is wrong with it."""
        try:
            return self._name, self._restore(bytes(data))
        except DecodeError:
            return None

    def decode(self, data: bytes, strict: bool = False) -> Decoded:
        """The message of a datagram in exact, stripped or zero-padded form (bytes or any
        bytes-like object); with ``strict``, a ``DecodeError`` too for what nanopb's decoder
        refuses (as ``Envelope.decode``)."""
        if isinstance(data, str):
            raise TypeError("a datagram is bytes (or bytearray, memoryview), not str")
        received = bytes(data)
        exact = self._restore(received)
        try:
            message = self._class.FromString(exact)
        except ProtobufDecodeError as error:
            form = "" if len(exact) == len(received) else " (after restoring its trailing zeros)"
            raise DecodeError(
                f"datagram of {len(received)} bytes is not a valid {self._name}{form}: {error}"
            ) from None
        if len(exact) > len(received):  # zeros were restored: stripped, or cut short?
            canonical = message.SerializePartialToString() == exact
            cut = cut_reason(self._table, exact, message, len(received), canonical)
            if cut:
                raise DecodeError(
                    f"datagram of {len(received)} bytes was cut short: {cut}", "truncated"
                )
        if strict and self._refusal is not None:
            refused = self._refusal(message, exact)
            if refused is not None:
                raise DecodeError(f"nanopb's decoder refuses the {self._name}: {refused}")
        return Decoded(self._name, message)

    def _restore(self, data: bytes) -> bytes:
        """The exact encoding of a datagram sent exact, stripped or zero-padded."""
        if len(data) > self._max_size:
            raise DecodeError(
                f"datagram of {len(data)} bytes is longer than {self._name}'s maximum of "
                f"{self._max_size}: a fixed-size receiver drops it",
                "too_long",
            )
        pos, end = 0, len(data)
        try:
            while pos < end:
                if data[pos] == 0:
                    return _unpad(data, pos)
                pos = next_field(data, pos, zeros_past_end=True).end
        except WireError as error:
            raise DecodeError(f"truncated or corrupt datagram: {error}") from None
        if pos > self._max_size:
            raise DecodeError(
                f"restoring its stripped zeros makes the datagram {pos} bytes long, more than "
                f"{self._name}'s maximum of {self._max_size}"
            )
        return data + bytes(pos - end)


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
