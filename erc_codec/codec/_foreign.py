"""Message classes built elsewhere (generated code, another descriptor pool) given to a codec.

What this module guarantees: ``Foreign.refusal`` lets a class through only when it is of a
message the codec sends, declared as the codec's schema declares it (the same declaration, and
the same declarations of every message and enum it reaches, as generated code of the same .proto
files has); a class of another schema that shares a message's name is an ``EncodeError`` saying
so, never encoded by its name. The verdict is reached once per class.
"""

from collections.abc import Iterable
from typing import Any

from google.protobuf.message import Message

from erc_schema import EncodeError, descriptor_of

__all__ = ["Foreign"]


class Foreign:
    """The verdicts on classes of the messages ``own`` (a codec's own classes) names."""

    def __init__(self, own: Iterable[type[Message]]) -> None:
        self._own = {descriptor_of(cls).full_name: descriptor_of(cls) for cls in own}
        self._verdicts: dict[type[Message], bool] = {}

    def refusal(self, cls: type[Message]) -> EncodeError | None:
        """The error for ``cls`` if it is of one of the codec's messages by name but not as the
        codec's schema declares it; ``None`` otherwise (a message the codec does not send is the
        caller's to refuse)."""
        descriptor = descriptor_of(cls)
        name = descriptor.full_name
        if name not in self._own:
            return None
        same = self._verdicts.get(cls)
        if same is None:
            same = self._verdicts[cls] = _shape(descriptor) == _shape(self._own[name])
        if same:
            return None
        return EncodeError(
            f"{name} is a message class of another schema: it is not this schema's {name} "
            "(its fields or those of a message it holds differ); build the message with "
            "this codec (message_class, from_dict)"
        )


def _shape(descriptor: Any) -> list[bytes]:
    """The declarations of a message and of every message and enum it reaches, serialized."""
    from google.protobuf import descriptor_pb2

    shapes: list[bytes] = []
    seen: set[str] = set()
    pending = [descriptor]
    while pending:
        current = pending.pop()
        if current.full_name in seen:
            continue
        seen.add(current.full_name)
        proto: Any = (
            descriptor_pb2.DescriptorProto()
            if hasattr(current, "fields")
            else descriptor_pb2.EnumDescriptorProto()
        )
        current.CopyToProto(proto)
        shapes.append(current.full_name.encode() + proto.SerializeToString(deterministic=True))
        for field in getattr(current, "fields", ()):
            pending.extend(kind for kind in (field.message_type, field.enum_type) if kind)
    return sorted(shapes)
