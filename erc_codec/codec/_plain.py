"""One plain message (a root that is not an envelope) in the three transmission forms.

The forms, restoring, cut detection and strict checks are ``_forms``', shared with
``_envelope``. What this module guarantees beside them:
- ``encode`` produces exactly the bytes protobuf (and nanopb) would for the message, after the
  fixed-size contract's checks, in the form asked for.
- ``encode`` never lets through what a fixed-size receiver would drop.
- ``encode`` never lets through a class of another schema named as the root (``_foreign``).
- A plain root has no metadata to set.
- ``decode`` returns the same message for the exact, the stripped and the zero-padded form.
- An empty datagram is the message with every field at its default.
- A cut datagram is a ``DecodeError`` of reason ``"truncated"``.
- With ``strict``, unknown fields (reason ``"unknown_fields"``) and what nanopb's decoder refuses
  are errors too, as for envelopes, in the same words.
- Every failure is a ``DecodeError`` or ``EncodeError`` saying what and where.
- What is no message or no datagram is a ``TypeError``.

Some roots cannot be encoded or decoded as nanopb does (``_sendable.unsendable``):
- a message protobuf's Python runtime cannot build;
- one with a DELIMITED field;
- one with an override protobuf does not write as nanopb reads it;
- one with a field hiding a Message method.

Such a root still loads, with nanopb's size. Encoding it is a ``SchemaError`` saying why.
Decoding it is an ``UnreadableKind``: a ``SchemaError`` and a ``DecodeError`` of reason
``"unsupported"``. ``peek`` finds nothing in it.
"""

from collections.abc import Callable
from typing import cast

from google.protobuf.descriptor import Descriptor
from google.protobuf.message import Message

from erc_schema import EncodeError, SchemaError, UnreadableKind, descriptor_of

from ._contract import Contract
from ._envelope import Decoded, Unsendable
from ._foreign import Foreign
from ._forms import Forms, Mode, as_bytes, in_form, strict_error

__all__ = ["Plain"]


class Plain:
    """Encoder and decoder for one plain message type; a decode's ``kind`` is its full name."""

    def __init__(
        self,
        cls: type[Message],
        max_size: int,
        contract: Callable[[Descriptor], Contract | None],
        refusal: Callable[[Message, bytes], str | None] | None = None,
        unsendable: Unsendable | None = None,
    ) -> None:
        descriptor = descriptor_of(cls)
        self._refusal = refusal
        self._name = descriptor.full_name
        self._class = cls
        self._forms = Forms(cls, max_size, f"{self._name}'s", groups=True, inside=False)
        self._foreign = Foreign([cls])  # classes built elsewhere: of this schema's root, or not
        # why the root cannot be encoded or decoded as nanopb does (then it has no contract)
        self._root_blocked = unsendable(descriptor, None) if unsendable is not None else None
        rules = contract(descriptor) if self._root_blocked is None else None
        self._check = rules.check if rules is not None else None

    def kinds(self) -> dict[int, str]:
        """A plain message has no envelope members: ``{}``."""
        return {}

    def metadata_fields(self) -> dict[int, str]:
        """A plain message has no envelope metadata fields: ``{}``."""
        return {}

    def _root_class(self) -> type[Message]:
        return self.payload_class(self._name)

    def payload_class(self, kind: str) -> type[Message]:
        """The root's class, for ``kind`` its full name (what a decode returns as the kind)."""
        if kind != self._name:
            raise SchemaError(f"{kind!r} is not {self._name}, the plain message this codec sends")
        if self._root_blocked is not None:
            raise SchemaError(self._root_blocked)
        return self._class

    def encode(self, message: Message, mode: Mode = "strip", /, **metadata: object) -> bytes:
        """The datagram carrying ``message`` (an instance of the root message) in ``mode``.

        A plain root has no envelope, so no metadata to set. ``mode=`` as a keyword is the mode.
        """
        if "mode" in metadata:
            if mode != "strip":
                raise TypeError(
                    f"encode got the mode twice: {mode!r} and mode={metadata['mode']!r}"
                )
            mode = cast(Mode, metadata.pop("mode"))
        if not isinstance(message, Message):
            raise TypeError(
                f"encode takes a protobuf message (a {self._name}), not {type(message).__name__}"
            )
        if self._root_blocked is not None:
            raise SchemaError(self._root_blocked)
        if metadata:
            raise EncodeError(
                f"{self._name} is no envelope: it has no metadata fields to set "
                f"({', '.join(metadata)})"
            )
        if message.DESCRIPTOR.full_name != self._name:
            raise EncodeError(
                f"{message.DESCRIPTOR.full_name} is not {self._name}, the message this codec sends"
            )
        if type(message) is not self._class:
            refused = self._foreign.refusal(type(message))
            if refused is not None:
                raise refused
        if self._check is not None:
            self._check(message)
        data = message.SerializePartialToString()  # unset required fields: the check's to name
        if len(data) > self._forms.max_size:
            raise self._forms.oversize(self._name, len(data))
        return in_form(data, mode, self._forms.max_size)

    def reencode(self, decoded: Decoded, mode: Mode = "strip") -> bytes:
        """The datagram ``decoded`` (what ``decode`` returned) came from, in ``mode``.

        It is the root's message as it is now, with the fields it kept that the schema does not
        know.
        """
        if not isinstance(decoded, Decoded):
            raise TypeError(
                f"reencode takes what decode returned (a Decoded), not {type(decoded).__name__}"
            )
        return self.encode(decoded.message, mode)

    def peek(self, data: bytes) -> tuple[str, bytes] | None:
        """The kind and exact bytes of a datagram in exact, stripped or padded form.

        It is ``None`` where only ``decode`` can say what is wrong with the datagram; a cut
        datagram is one such.
        """
        if self._root_blocked is not None:
            return None  # decode says why
        exact = self._forms.peek(as_bytes(data))
        return None if exact is None else (self._name, exact)

    def decode(self, data: bytes, strict: bool = False) -> Decoded:
        """The message of a datagram in exact, stripped or zero-padded form.

        ``data`` is bytes or any bytes-like object. With ``strict``, fields the schema does not
        know and what nanopb's decoder refuses are a ``DecodeError`` too, as in
        ``Envelope.decode``.
        """
        if self._root_blocked is not None:
            raise UnreadableKind(self._root_blocked)
        received = as_bytes(data)
        message = self._forms.parse(received)
        if strict:
            exact = self._forms.restore(received)  # what nanopb reads: the exact bytes
            error = strict_error(len(received), message, exact, self._name, self._refusal)
            if error is not None:
                raise error
        return Decoded(self._name, message)
