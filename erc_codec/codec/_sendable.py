"""Which messages erc-codec cannot encode or decode as nanopb does, though nanopb sizes them.

A codec loads such a schema and refuses only to encode or decode what ``unsendable`` names a
reason for; nanopb's sizes hold all the same.
"""

from collections.abc import Sequence

from google.protobuf.descriptor import Descriptor, FieldDescriptor

from erc_schema import Schema, Sizes

__all__ = ["unsendable"]

_T = FieldDescriptor
_DELIMITED = (
    "protobuf writes it delimited (a group: wire types 3 and 4) and nanopb as a length-prefixed "
    "message (wire type 2), so each side refuses or drops the other's bytes; make it a "
    "length-prefixed message field (nanopb's generated code stays the same)"
)
# What erc-codec and protobuf's json_format ask a message instance for: in upb, a field of one of
# these names is what the instance's attribute gives (its value, not the method), so they break
# on it. Other public names a field may take (Clear, Extensions, ByteSize, SerializeToString:
# erc-codec calls the class's); tests/codec/test_any_schema.py sends and reads such fields.
_MESSAGE_ATTRIBUTES = frozenset(
    (
        *("ClearField", "CopyFrom", "DESCRIPTOR", "HasField", "ListFields", "MergeFrom"),
        *("SerializePartialToString", "SetInParent", "WhichOneof"),
    )
)


def unsendable(
    schema: Schema,
    sizes: Sizes,
    root: Descriptor,
    fields: Sequence[FieldDescriptor] | None = None,
) -> str | None:
    """Why ``root`` cannot be encoded or decoded as nanopb does, or ``None``: the first thing,
    depth first from ``root`` (through ``fields`` of it, default all), that is one of these.

    - A message protobuf's Python runtime refuses to build (``Schema.refused``).
    - A message with a field named as a method erc-codec or json_format asks a message for:
      ignored by nanopb or not, it hides the method on every instance.
    - A field written as a group where nanopb has a length-prefixed message.
    - A field whose nanopb overrides protobuf does not write as nanopb reads them
      (``Sizes.wire_mismatch``).
    """
    refused = schema.refused
    pending: list[tuple[Descriptor, str, Sequence[FieldDescriptor]]] = [
        (root, root.full_name, root.fields if fields is None else fields)
    ]
    seen = {root.full_name}
    while pending:
        message, path, own = pending.pop()
        why = refused.get(message.full_name)
        if why is not None:
            reached = "" if path == root.full_name else f" (reached as {path})"
            return (
                f"{schema.where(message.full_name)}: {message.full_name}{reached}: "
                f"{why}; protobuf's Python runtime cannot encode or decode it (nanopb's "
                "sizes still hold)"
            )
        # A field hides a method of every instance, whichever fields a caller sends.
        hiding = next((f for f in message.fields if f.name in _MESSAGE_ATTRIBUTES), None)
        if hiding is not None:
            return (
                f"{schema.where(hiding.full_name)}: {hiding.full_name}: the field "
                f"{hiding.name} hides protobuf's Message.{hiding.name} in the Python runtime "
                f"(reached from {root.full_name} as {path}.{hiding.name}); erc-codec cannot "
                "encode or decode it (nanopb's sizes still hold)"
            )
        inner: list[tuple[Descriptor, str, Sequence[FieldDescriptor]]] = []
        for field in own:
            if sizes.ignored(field):
                continue
            here = f"{path}.{field.name}"
            mismatch = _DELIMITED if field.type == _T.TYPE_GROUP else None
            mismatch = mismatch or sizes.wire_mismatch(field)
            if mismatch is not None:
                return (
                    f"{schema.where(field.full_name)}: {field.full_name}: {mismatch} "
                    f"(reached from {root.full_name} as {here}); erc-codec cannot encode or "
                    "decode it as nanopb does (nanopb's sizes still hold)"
                )
            sub = field.message_type
            if sub is not None and sub.full_name not in seen:
                seen.add(sub.full_name)
                inner.append((sub, here, sub.fields))
        pending.extend(reversed(inner))
    return None
