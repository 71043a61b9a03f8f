"""The exception hierarchy of erc_schema and erc_codec: one base class, one subclass per
direction of failure.

Every error names what was wrong and where (a file:line for schemas, a field path for messages, a
byte offset for datagrams), so a caller can print ``str(error)`` as a complete one-line diagnosis.
"""

__all__ = ["CodecError", "DecodeError", "EncodeError", "SchemaError", "UnreadableKind"]


class CodecError(Exception):
    """Base class of every error erc_schema and erc_codec raise on purpose."""


class SchemaError(CodecError):
    """A proto tree cannot be loaded, or breaks the fixed-size contract of nanopb receivers."""


class EncodeError(CodecError):
    """A message cannot be sent: a fixed-size receiver would reject or misread it."""


class DecodeError(CodecError):
    """A datagram is not an exact, stripped or zero-padded encoding of a known envelope.

    ``reason`` sorts the failure for counters: ``"empty"``, ``"too_long"``, ``"no_payload"``,
    ``"unknown_member"`` (a payload number this schema lacks: a newer sender), ``"truncated"``
    (cut short, not stripped: restoring its zeros would make what no encoder sends, a field
    without presence at its default or a varint ending in ``80 00``), ``"unsupported"`` (a member
    the schema has but nobody can read as nanopb does: ``UnreadableKind``), ``"not_json"`` (it
    decoded, but holds what protobuf's JSON mapping cannot write: ``Codec.to_dict``) or
    ``"corrupt"``.
    """

    def __init__(self, message: str, reason: str = "corrupt") -> None:
        super().__init__(message)
        self.reason = reason


class UnreadableKind(SchemaError, DecodeError):
    """A datagram of a member the schema declares but which cannot be decoded as nanopb decodes
    it (an editions ``DELIMITED`` field, a message the protobuf runtime cannot build): the
    schema's fault, so a ``SchemaError``, and a ``DecodeError`` of reason ``"unsupported"``, so
    that whatever counts datagrams by reason (``Dispatcher``, ``Router``) counts it. ``kind`` is
    the envelope member the datagram carries, ``None`` where it is not known."""

    def __init__(self, message: str, kind: str | None = None) -> None:
        DecodeError.__init__(self, message, "unsupported")
        self.kind = kind


# Tracebacks and reprs name each class where users import it from.
for _error in (CodecError, SchemaError, EncodeError, DecodeError, UnreadableKind):
    _error.__module__ = "erc_schema"
