"""Hypothesis strategies for any message of a loaded schema, derived from its descriptors.

``messages(codec, "SensorBoardGPSInfo")`` draws messages a fixed-size receiver accepts and decodes
back equal: declared enum values only, every integer over its full range (or its nanopb
``int_size``), floats including ±0, subnormals, the extremes and ±inf (NaN only on request: NaN !=
NaN makes equality useless), strings without NUL (nanopb stores them NUL-terminated) and bytes
within their nanopb ``max_size`` (``fixed_length`` bytes exactly that long), repeated fields within
``max_count`` (``fixed_count`` ones exactly that many), proto2 ``required`` fields always set, and
every submessage, oneof member and ``optional`` field both present and absent. Fields are drawn as
nanopb's generator types them (``Sizes.field_type``, ``repeated``, ``required``): a repeated field
whose ``label_override`` makes it single holds at most one item (a required one exactly one, a
required proto3 scalar never its default, which protobuf would not send), a string whose
``type_override`` is bytes may hold NULs and ``max_length + 1`` bytes, bytes overridden to a
string hold no NUL. An envelope root has exactly one payload member set (one the codec can
send), its metadata drawn as any field. A string or bytes field whose ``max_size`` leaves no
room for any value (a string's 0: nanopb's array holds not even the NUL) is never set. Test your
own handlers with it.
"""

from typing import Any

from google.protobuf.descriptor import Descriptor, FieldDescriptor
from google.protobuf.message import Message
from hypothesis import strategies as st

from erc_schema import PYTHON_INT_RANGE, SchemaError, Sizes, descriptor_of, enum_of, message_of

from .codec import Codec

__all__ = ["messages"]

_T = FieldDescriptor
# Strings and bytes with no nanopb max_size get this bound, so examples stay small.
_UNBOUNDED_TEXT = 64
_UNBOUNDED_COUNT = 8


def messages(codec: Codec, name: str, *, allow_nan: bool = False) -> st.SearchStrategy[Message]:
    """A strategy drawing instances of message ``name`` (a full name) of ``codec``'s schema."""
    codec.message_class(name)  # SchemaError for an unknown name, before anything is drawn
    builder = _Builder(codec, allow_nan)
    descriptor = descriptor_of(codec.message_class(name))
    if name == codec.root and codec.kinds():  # an envelope root: its payload is always set
        return builder.envelope(descriptor)
    return builder.message(descriptor)


class _Builder:
    def __init__(self, codec: Codec, allow_nan: bool) -> None:
        self._codec = codec
        self._allow_nan = allow_nan
        self._memo: dict[str, st.SearchStrategy[Message]] = {}

    def message(self, descriptor: Descriptor) -> st.SearchStrategy[Message]:
        name = descriptor.full_name
        if name not in self._memo:
            # deferred() lets a message type that contains itself refer to its own strategy.
            self._memo[name] = st.deferred(lambda: built)
            built = self._build(descriptor)
            self._memo[name] = built
        return self._memo[name]

    def envelope(self, descriptor: Descriptor) -> st.SearchStrategy[Message]:
        """The envelope root: exactly one payload member set (one of those the codec can send),
        with metadata drawn as any field (the codec refuses an envelope without a payload)."""
        sendable = []
        for kind in self._codec.kinds().values():
            try:
                self._codec.payload_class(kind)
            except SchemaError:
                continue  # a member nobody can send or read as nanopb does
            sendable.append(kind)
        if not sendable:
            raise SchemaError(f"{descriptor.full_name} has no member the codec can send")
        field = descriptor.fields_by_name[sendable[0]]
        assert field.containing_oneof is not None, field.full_name
        return self._build(descriptor, (field.containing_oneof.name, frozenset(sendable)))

    def _build(
        self, descriptor: Descriptor, payload: tuple[str, frozenset[str]] | None = None
    ) -> st.SearchStrategy[Message]:
        """``payload``: an envelope's oneof and the members to draw from, one always set."""
        cls = self._codec.message_class(descriptor.full_name)
        sizes = self._codec.nanopb
        required: dict[str, st.SearchStrategy[Any]] = {}
        optional: dict[str, st.SearchStrategy[Any]] = {}
        oneofs: dict[str, list[st.SearchStrategy[dict[str, Any]]]] = {}
        for field in descriptor.fields:
            if sizes.ignored(field):
                continue
            if _no_room(sizes, field):  # never set: nanopb takes no value of it, sent at all
                if sizes.required(field):
                    raise SchemaError(
                        f"{field.full_name}: nanopb requires it, but its max_size leaves no "
                        f"room for any value: no {descriptor.full_name} can be sent"
                    )
                continue
            oneof = sizes.real_oneof(field)
            if payload is not None and oneof is not None and oneof.name == payload[0]:
                if field.name in payload[1]:
                    member = st.fixed_dictionaries({field.name: self._field(field)})
                    oneofs.setdefault(oneof.name, []).append(member)
            elif oneof is not None:
                member = st.fixed_dictionaries({field.name: self._field(field)})
                oneofs.setdefault(oneof.name, [st.just({})]).append(member)
            elif field.has_presence and not sizes.required(field):  # submessages, `optional`s
                optional[field.name] = self._field(field)
            elif sizes.required(field) and not field.is_repeated and not field.has_presence:
                # a proto3 scalar nanopb requires (label_override): protobuf sends no default
                required[field.name] = self._field(field).filter(bool)
            else:
                required[field.name] = self._field(field)
        fields = st.fixed_dictionaries(required, optional=optional)
        for members in oneofs.values():
            fields = st.builds(_merge, fields, st.one_of(members))
        return fields.map(lambda values: cls(**values))

    def _field(self, field: FieldDescriptor) -> st.SearchStrategy[Any]:
        if field.message_type is not None and field.message_type.GetOptions().map_entry:
            return self._map(field)
        value = self._scalar(field)
        if not field.is_repeated:
            return value
        if not self._codec.nanopb.repeated(field):  # label_override: nanopb holds one value
            least = 1 if self._codec.nanopb.required(field) else 0
            return st.lists(value, min_size=least, max_size=1)
        count = self._codec.nanopb.max_count(field)
        if count is not None and self._codec.nanopb.options(field).fixed_count:
            return st.lists(value, min_size=count, max_size=count)
        return st.lists(value, max_size=_UNBOUNDED_COUNT if count is None else count)

    def _map(self, field: FieldDescriptor) -> st.SearchStrategy[Any]:
        entry = message_of(field)
        key, value = entry.fields_by_name["key"], entry.fields_by_name["value"]
        count = self._codec.nanopb.max_count(field)
        return st.dictionaries(
            self._scalar(key),
            self._scalar(value),
            max_size=_UNBOUNDED_COUNT if count is None else count,
        )

    def _scalar(self, field: FieldDescriptor) -> st.SearchStrategy[Any]:
        kind = field.type
        if kind in PYTHON_INT_RANGE:
            low, high = self._codec.nanopb.int_range(field) or PYTHON_INT_RANGE[kind]
            return st.integers(low, high)
        if kind == _T.TYPE_BOOL:
            return st.booleans()
        if kind == _T.TYPE_FLOAT:
            return st.floats(width=32, allow_nan=self._allow_nan)
        if kind == _T.TYPE_DOUBLE:
            return st.floats(allow_nan=self._allow_nan)
        if kind == _T.TYPE_ENUM:
            return st.sampled_from(sorted({value.number for value in enum_of(field).values}))
        if kind == _T.TYPE_MESSAGE:
            return self.message(message_of(field))
        limit = self._codec.nanopb.max_bytes(field)
        room = _UNBOUNDED_TEXT if limit is None else limit
        # nanopb's type decides what a value may hold; protobuf's, what Python holds it in
        string = self._codec.nanopb.field_type(field) == _T.TYPE_STRING
        exact = not string and limit is not None and self._codec.nanopb.options(field).fixed_length
        if kind == _T.TYPE_BYTES:
            if exact:
                return st.binary(min_size=room, max_size=room)
            if string:  # no NUL: nanopb's string would end there
                return st.binary(max_size=room).map(lambda value: value.replace(b"\0", b"\1"))
            return st.binary(max_size=room)
        if kind == _T.TYPE_STRING:
            if exact:  # a string written as fixed_length bytes: ASCII fills them exactly
                return st.text(st.characters(max_codepoint=0x7F), min_size=room, max_size=room)
            # codec="utf-8" leaves out the surrogates (category Cs): str, but no UTF-8
            characters = st.characters(codec="utf-8", exclude_characters="\0" if string else "")
            return st.text(characters, max_size=room).map(lambda value: _fit_utf8(value, room))
        raise SchemaError(f"{field.full_name}: a group, which nanopb does not support")


def _no_room(sizes: Sizes, field: FieldDescriptor) -> bool:
    """Whether ``field`` holds strings or bytes (map keys or values too) whose nanopb
    ``max_size`` leaves no room for any value, an empty one included (a string's 0 or less,
    bytes' below 0: the contract refuses any sent)."""
    entry = field.message_type
    if entry is not None and entry.GetOptions().map_entry:
        return any(_no_room(sizes, inner) for inner in entry.fields)
    if field.type not in (_T.TYPE_STRING, _T.TYPE_BYTES):
        return False
    limit = sizes.max_bytes(field)
    return limit is not None and limit < 0


def _merge(left: dict[str, Any], right: dict[str, Any]) -> dict[str, Any]:
    return {**left, **right}


def _fit_utf8(text: str, room: int) -> str:
    """``text`` cut to at most ``room`` UTF-8 bytes, on a character boundary."""
    return text.encode("utf-8")[:room].decode("utf-8", "ignore")
