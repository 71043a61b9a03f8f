"""Editions features as protoc resolves them: what each field and enum of a file means on the wire.

Guarantees:
- Every file gets its edition's defaults exactly as protoc compiles them into its
  ``FeatureSetDefaults``: from the ``edition_defaults`` that descriptor.proto's own
  ``FeatureSet`` declares on each feature (the latest entry at or before the file's edition).
  proto2 and proto3 files are editions ``PROTO2`` and ``PROTO3``.
- Only the features that change how bytes are read are kept: presence, enum openness, repeated
  field encoding, UTF-8 validation, message encoding. descriptor.proto lets a file and a field set
  them (and an enum its ``enum_type``), never a message or a oneof: an element's features are
  its file's with its own merged in, exactly what the descriptor pool's inheritance through
  messages and oneofs comes to. In proto2 and proto3 files what the syntax says becomes
  features as protoc infers them: ``required`` is ``LEGACY_REQUIRED``, a ``group`` is
  ``DELIMITED``, ``[packed = ...]`` is ``PACKED`` or ``EXPANDED``.

tests/lint/test_lint_model.py holds the resolution to the protobuf runtime's on a tree of every
construct (its descriptor pool's ``is_required``, the ``TYPE_GROUP`` of a delimited field,
``is_closed``; its parser's UTF-8 checks), and holds the features' targets to those above.
"""

import functools
from typing import Literal, NamedTuple

from google.protobuf import descriptor_pb2

__all__ = ["Features", "edition_of", "file_features"]

_FS = descriptor_pb2.FeatureSet
_FD = descriptor_pb2.FieldDescriptorProto
_Name = Literal[
    "field_presence", "enum_type", "repeated_field_encoding", "utf8_validation", "message_encoding"
]
_NAMES: tuple[_Name, ...] = (
    "field_presence",
    "enum_type",
    "repeated_field_encoding",
    "utf8_validation",
    "message_encoding",
)


class Features(NamedTuple):
    """The resolved wire features of one element (values of descriptor.proto's enums)."""

    field_presence: int
    enum_type: int
    repeated_field_encoding: int
    utf8_validation: int
    message_encoding: int

    def merged(self, raw: descriptor_pb2.FeatureSet) -> "Features":
        """These features with what ``raw`` (an element's own ``features`` option) sets."""
        if not raw.ListFields():
            return self
        return Features(*(getattr(raw, n) if raw.HasField(n) else getattr(self, n) for n in _NAMES))

    def of_field(self, field: _FD, edition: int) -> "Features":
        """A field's features, ``self`` being its file's: its own ``features``, or what its
        proto2/proto3 syntax implies."""
        options = field.options if field.HasField("options") else None
        if edition >= descriptor_pb2.EDITION_2023:
            return self.merged(options.features) if options is not None else self
        own = self
        if field.label == _FD.LABEL_REQUIRED:
            own = own._replace(field_presence=_FS.LEGACY_REQUIRED)
        if field.type == _FD.TYPE_GROUP:
            own = own._replace(message_encoding=_FS.DELIMITED)
        if options is not None and options.HasField("packed"):
            encoding = _FS.PACKED if options.packed else _FS.EXPANDED
            own = own._replace(repeated_field_encoding=encoding)
        return own

    @property
    def required(self) -> bool:
        return self.field_presence == _FS.LEGACY_REQUIRED

    @property
    def delimited(self) -> bool:
        return self.message_encoding == _FS.DELIMITED

    @property
    def closed(self) -> bool:
        return self.enum_type == _FS.CLOSED

    @property
    def verifies_utf8(self) -> bool:
        return self.utf8_validation == _FS.VERIFY


def edition_of(file: descriptor_pb2.FileDescriptorProto) -> int:
    """The edition a file is read in: proto2 and proto3 files are editions of their own."""
    if file.syntax == "editions":
        return file.edition
    if file.syntax == "proto3":
        return descriptor_pb2.EDITION_PROTO3
    return descriptor_pb2.EDITION_PROTO2


def file_features(file: descriptor_pb2.FileDescriptorProto) -> Features:
    """The features of ``file`` itself: its edition's defaults and its own ``features`` option."""
    return defaults(edition_of(file)).merged(file.options.features)


@functools.cache
def defaults(edition: int) -> Features:
    """What protoc's ``FeatureSetDefaults`` hold for ``edition``: for each feature, the value of
    the latest ``edition_defaults`` entry at or before it."""
    values = []
    for name in _NAMES:
        feature = _FS.DESCRIPTOR.fields_by_name[name]
        assert feature.enum_type is not None, name  # every feature is an enum
        entries = [e for e in feature.GetOptions().edition_defaults if e.edition <= edition]
        latest = max(entries, key=lambda entry: entry.edition)
        values.append(feature.enum_type.values_by_name[latest.value].number)
    return Features(*values)
