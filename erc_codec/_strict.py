"""What nanopb's decoder refuses in a message protobuf's runtime parsed, for ``strict`` decodes.

protobuf parses some messages a nanopb receiver built from the same schema refuses ("missing
required field", "string overflow", "bytes overflow", "array overflow", "incorrect fixed length
bytes size", "wrong size for fixed count field", "integer too large"). ``refusal`` names the first
such field by its path, or returns ``None``. It is the decode side of the fixed-size contract, a
plain walk (strict decoding is asked for, not the fast path): undeclared enum values and strings
holding a NUL, which nanopb's decoder takes, are not refused here.
"""

from typing import Any

from google.protobuf.descriptor import FieldDescriptor
from google.protobuf.message import Message

from .schema import Sizes, descriptor_of, message_of

__all__ = ["refusal"]

_T = FieldDescriptor


def refusal(sizes: Sizes, message: Message) -> str | None:
    """Why nanopb's decoder would refuse ``message``, naming the field; ``None`` if it takes it."""
    pending: list[tuple[Message, str]] = [(message, descriptor_of(type(message)).full_name)]
    while pending:
        current, path = pending.pop()
        for field in descriptor_of(type(current)).fields:
            if sizes.ignored(field):
                continue
            here = f"{path}.{field.name}"
            if field.is_required and not current.HasField(field.name):
                return f"{here} is required but missing (nanopb: missing required field)"
            value = getattr(current, field.name)
            if field.is_repeated:
                why = _count(sizes, field, here, len(value)) or _keys(sizes, field, here, value)
                if why is not None:
                    return why
                items = value.values() if hasattr(value, "values") else value
                numbered = [(f"{here}[{j}]", item) for j, item in enumerate(items)]
            elif field.has_presence and not current.HasField(field.name):
                continue
            else:
                numbered = [(here, value)]
            for at, item in numbered:
                if isinstance(item, Message):
                    pending.append((item, at))
                else:
                    why = _value(sizes, field, at, item)
                    if why is not None:
                        return why
    return None


def _count(sizes: Sizes, field: FieldDescriptor, path: str, count: int) -> str | None:
    limit = sizes.max_count(field)
    if limit is None:
        return None
    if count > limit:
        return f"{path} holds {count} items, more than its max_count {limit} (array overflow)"
    if count and count != limit and sizes.options(field).fixed_count:
        return f"{path} holds {count} items; fixed_count needs exactly {limit}"
    return None


def _keys(sizes: Sizes, field: FieldDescriptor, path: str, value: Any) -> str | None:
    """Why nanopb's decoder refuses a key of the map ``value`` (a key is a nanopb field too:
    "string overflow"); ``None`` for any other repeated field."""
    if not hasattr(value, "values"):
        return None
    key = message_of(field).fields_by_name["key"]
    return next(
        (why for name in value if (why := _value(sizes, key, f"{path} key {name!r}", name))),
        None,
    )


def _value(sizes: Sizes, field: FieldDescriptor, path: str, value: Any) -> str | None:
    if field.message_type is not None:  # a map entry's scalar value
        field = field.message_type.fields_by_name["value"]
    if field.type in (_T.TYPE_STRING, _T.TYPE_BYTES):
        length = len(value.encode("utf-8")) if field.type == _T.TYPE_STRING else len(value)
        limit = sizes.max_bytes(field)
        if limit is not None and length > limit:
            return f"{path} is {length} bytes long, more than the {limit} allowed (overflow)"
        fixed = field.type == _T.TYPE_BYTES and sizes.options(field).fixed_length
        if fixed and length not in (0, limit):  # nanopb reads an empty value as zeros
            return f"{path} is {length} bytes long; fixed_length needs exactly {limit}"
        return None
    bounds = sizes.int_range(field)
    if bounds is not None and not bounds[0] <= value <= bounds[1]:
        return f"{path} = {value} does not fit nanopb int_size ({bounds[0]}..{bounds[1]})"
    return None
