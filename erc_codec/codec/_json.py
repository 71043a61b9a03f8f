"""Protobuf's JSON mapping as erc-codec writes and reads it: messages to dicts and JSON, and back.

Writing (``to_dict``, ``to_json``) gives exactly what ``json_format.MessageToDict`` gives with
``always_print_fields_with_no_presence`` and ``preserving_proto_field_name`` (what the command line
has always printed), keys in the order of the .proto at every level: field names as in the .proto;
every field without presence, defaults too; submessages, oneof members and ``optional`` fields when
set; enums by name (an undeclared number as the number); 64-bit integers as strings; bytes in
base64; a ``float`` as the shortest decimal that reads back to its 32 bits, NaN and infinities as
``"NaN"``, ``"Infinity"``, ``"-Infinity"``; map keys as strings. It is a straight converter built
once per message type from its descriptor rather than json_format's reflection, because ``erc-codec
listen`` writes each of 20,000 datagrams a second with it: benchmarks/bench_json.py measures it
against ``MessageToDict``, tests/codec/test_json.py holds it to ``MessageToDict``'s output.

Reading (``from_dict``, ``from_json``) takes what writing gives, and what protobuf's JSON mapping
allows: names as in the .proto or in lowerCamelCase, enums by name or by a declared number,
integers as numbers or decimal strings, floats as numbers, numeric strings or those three strings,
bytes in base64 (standard or URL-safe, padding optional), ``null`` for a field left unset. Every
value is checked before it is converted, so nothing is wrapped, rounded to another integer, turned
to infinity or to zero on its way: an integer fits its type (int32 for int32, sint32, sfixed32
and enums; uint32; the 64-bit ones), nothing fractional, boolean or infinite is an integer, a float
fits its width. nanopb's narrower limits (``int_size``, ``max_size``, ``max_count``) are the
contract's, which ``encode`` checks. Each failure is an ``EncodeError`` naming the full path from
the message type (``LimitsRecord.points[1].colour``, ``LimitsRecord.palette[key=1]``) and what the
field takes. Well-known types (``Timestamp``, wrappers, ...) read and write as json_format does.

What has no JSON form, a well-known type's value out of its range (a ``Timestamp`` with negative
nanos) or a string that is not UTF-8 (protobuf does not check a proto2 string on the wire), is a
``DecodeError`` of reason ``"not_json"``, naming it: the message decoded, but cannot be shown.
"""

import base64
import json
import math
import re
import struct
from collections.abc import Callable, Mapping
from decimal import Decimal
from typing import Any

from google.protobuf import json_format
from google.protobuf.descriptor import Descriptor, EnumDescriptor, FieldDescriptor
from google.protobuf.message import Message

from erc_schema import DecodeError, EncodeError, descriptor_of, enum_of, message_of

from ._fieldpaths import entry_path, key_text

__all__ = ["from_dict", "from_json", "load_json", "to_dict", "to_json"]

_T = FieldDescriptor
_F32 = struct.Struct("<f")
# The magnitudes from which a number rounds to infinity: the largest finite value and half a step.
_FLOAT_OVER = 2**128 - 2**103
_DOUBLE_OVER = 2**1024 - 2**970
_MAX_DEPTH = 100  # as protobuf's own parsers
_WELL_KNOWN = frozenset(  # what json_format reads and writes its own way
    f"google.protobuf.{name}"
    for name in [
        *("Any", "Duration", "FieldMask", "ListValue", "Struct", "Timestamp", "Value"),
        *("BoolValue", "BytesValue", "DoubleValue", "FloatValue", "Int32Value", "Int64Value"),
        *("StringValue", "UInt32Value", "UInt64Value"),
    ]
)
_NULLABLE = frozenset(("google.protobuf.Value", "google.protobuf.NullValue"))
_INTEGERS = {
    **dict.fromkeys((_T.TYPE_INT32, _T.TYPE_SINT32, _T.TYPE_SFIXED32), (-(2**31), 2**31 - 1)),
    **dict.fromkeys((_T.TYPE_UINT32, _T.TYPE_FIXED32), (0, 2**32 - 1)),
    **dict.fromkeys((_T.TYPE_INT64, _T.TYPE_SINT64, _T.TYPE_SFIXED64), (-(2**63), 2**63 - 1)),
    **dict.fromkeys((_T.TYPE_UINT64, _T.TYPE_FIXED64), (0, 2**64 - 1)),
}
_WIDE = {_T.TYPE_INT64, _T.TYPE_SINT64, _T.TYPE_SFIXED64, _T.TYPE_UINT64, _T.TYPE_FIXED64}
_TYPE_NAMES = {getattr(_T, name): name[5:].lower() for name in dir(_T) if name.startswith("TYPE_")}
_DECIMAL_INTEGER = re.compile(r"-?[0-9]{1,30}")
_JSON_NUMBER = re.compile(r"-?(?:0|[1-9][0-9]*)(?:\.[0-9]+)?(?:[eE][+-]?[0-9]+)?")
_SPECIAL_FLOATS = {"NaN": math.nan, "Infinity": math.inf, "-Infinity": -math.inf}


# -- writing -----------------------------------------------------------------------------------

Value = Callable[[Any], Any]  # a field's value → its JSON value
# (field name, whether it is shown only when set, converter; None: the value as it is)
_Plan = list[tuple[str, bool, Value | None]]
_writers: dict[Descriptor, Callable[[Message], Any]] = {}
_by_class: dict[type[Message], Callable[[Message], Any]] = {}


class _NoJson(Exception):
    """A value with no JSON form, found ``path`` (field names, innermost first) down."""

    def __init__(self, why: str) -> None:
        super().__init__(why)
        self.why = why
        self.path: list[str] = []


def to_dict(message: Message) -> dict[str, Any]:
    """``message`` in protobuf's JSON mapping, as a dict (see the module's docstring)."""
    write = _by_class.get(type(message))
    if write is None:
        write = _by_class[type(message)] = _writer(descriptor_of(type(message)))
    try:
        return write(message)  # type: ignore[no-any-return]
    except _NoJson as error:
        where = ".".join([message.DESCRIPTOR.full_name, *reversed(error.path)])
        raise DecodeError(f"{where}: {error.why}", "not_json") from None


def to_json(message: Message) -> str:
    """``to_dict(message)`` as one line of JSON text."""
    return json.dumps(to_dict(message))


def _writer(descriptor: Descriptor) -> Callable[[Message], Any]:
    """The converter of ``descriptor``'s messages, built once (converters are kept per type)."""
    if descriptor in _writers:
        return _writers[descriptor]
    if descriptor.full_name in _WELL_KNOWN:
        _writers[descriptor] = _well_known_writer
        return _well_known_writer
    plan: _Plan = []
    extensions = descriptor.is_extendable

    def write(message: Message) -> dict[str, Any]:
        out: dict[str, Any] = {}
        name = ""
        try:
            for name, has_presence, convert in plan:
                if has_presence and not message.HasField(name):
                    continue
                value = getattr(message, name)
                out[name] = value if convert is None else convert(value)
        except _NoJson as error:
            error.path.append(name)
            raise
        if extensions:
            for field, value in message.ListFields():
                if field.is_extension:
                    convert = _field_value(field)
                    out[f"[{field.full_name}]"] = value if convert is None else convert(value)
        return out

    _writers[descriptor] = write  # before the plan: a type may contain itself
    for field in descriptor.fields:
        present = field.has_presence and not field.is_repeated
        plan.append((field.name, present, _field_value(field)))
    return write


def _well_known_writer(message: Message) -> Any:
    try:
        return json_format.MessageToDict(
            message, always_print_fields_with_no_presence=True, preserving_proto_field_name=True
        )
    except (ValueError, json_format.Error) as error:  # a Timestamp's nanos out of range, ...
        raise _NoJson(f"{message.DESCRIPTOR.full_name} has no JSON form: {error}") from None


def _string_value(value: str | bytes) -> str:
    """A string field's value, which protobuf hands out as bytes where they are not UTF-8 (a
    proto2 string is not checked on the wire): JSON has no way to show those."""
    if type(value) is str:
        return value
    raise _NoJson(
        f"{len(value)} bytes that are not UTF-8 ({value[:16]!r}), for which protobuf's JSON "
        "mapping has no form"
    )


def _field_value(field: FieldDescriptor) -> Value | None:
    """The converter of a field's whole value: a scalar, a message, a list or a map."""
    entry = field.message_type
    if entry is not None and entry.GetOptions().map_entry:
        value = _scalar_value(entry.fields_by_name["value"])
        if value is None:
            return lambda items: {key_text(key): item for key, item in items.items()}
        return lambda items: {key_text(key): value(item) for key, item in items.items()}
    item = _scalar_value(field)
    if not field.is_repeated:
        return item
    if item is None:
        return list
    return lambda items: [item(one) for one in items]


def _scalar_value(field: FieldDescriptor) -> Value | None:
    """The converter of one value of ``field``'s type; ``None`` where it is its own JSON."""
    kind = field.type
    if field.cpp_type == _T.CPPTYPE_MESSAGE:  # a message or a group
        return _writer(message_of(field))
    if kind == _T.TYPE_ENUM:
        enum = enum_of(field)
        if enum.full_name == "google.protobuf.NullValue":
            return lambda number: None
        names = {number: value.name for number, value in enum.values_by_number.items()}
        return lambda number: names.get(number, number)
    if kind == _T.TYPE_FLOAT:
        return _float_value
    if kind == _T.TYPE_DOUBLE:
        return _double_value
    if kind in _WIDE:
        return str
    if kind == _T.TYPE_BYTES:
        return _bytes_value
    if kind == _T.TYPE_STRING:
        return _string_value
    return None


def _bytes_value(value: bytes) -> str:
    return base64.b64encode(value).decode("ascii")


def _double_value(value: float) -> float | str:
    return value if math.isfinite(value) else _special(value)


def _float_value(value: float) -> float | str:
    """A float field's value as protobuf writes it: the shortest decimal of 6 or more significant
    digits that reads back to the same 32-bit float (json_format's ``ToShortestFloat``)."""
    if not math.isfinite(value):
        return _special(value)
    if value == 0.0:
        return value  # 0.0 or -0.0, as "%g" writes them
    # ToShortestFloat tries 6, 7, 8, 9 digits in turn. Whether p digits read back is monotone
    # in p (a rounding to more digits is never farther off), so this tries 7 first and then
    # 6 or 8: two formattings where it takes 2.5 on average, for the to_dict target of
    # benchmarks/bench_json.py. tests/codec/test_json.py holds it to ToShortestFloat.
    pack, unpack = _F32.pack, _F32.unpack
    rounded = float(f"{value:.7g}")
    if unpack(pack(rounded))[0] == value:
        shorter = float(f"{value:.6g}")
        return shorter if unpack(pack(shorter))[0] == value else rounded
    rounded = float(f"{value:.8g}")
    if unpack(pack(rounded))[0] == value:
        return rounded
    return float(f"{value:.9g}")  # nine digits tell every 32-bit float apart


def _special(value: float) -> str:
    return "NaN" if math.isnan(value) else "Infinity" if value > 0 else "-Infinity"


# -- reading -----------------------------------------------------------------------------------


def load_json(text: str | bytes) -> Any:
    """JSON text as Python values, read strictly: a key given twice in an object is an error
    (json.loads would keep the last silently), numbers with a fraction or an exponent stay exact
    (``Decimal``), and every failure is an ``EncodeError`` of one line."""
    try:
        return json.loads(text, object_pairs_hook=_unique_keys, parse_float=Decimal)
    except RecursionError:
        raise EncodeError("JSON is not valid: it nests too deeply") from None
    except ValueError as error:
        raise EncodeError(f"JSON is not valid: {' '.join(str(error).split())}") from None


def _unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    document: dict[str, Any] = {}
    for key, value in pairs:
        if key in document:
            raise ValueError(f"key {key!r} appears twice")
        document[key] = value
    return document


def from_json(cls: type[Message], text: str | bytes) -> Message:
    """A ``cls`` message from JSON text in protobuf's JSON mapping (see ``from_dict``)."""
    return from_dict(cls, load_json(text))


def from_dict(cls: type[Message], document: Any) -> Message:
    """A ``cls`` message from ``document``, protobuf's JSON mapping of one as Python values (a
    dict from ``json.loads``, or built by hand: ints, floats, ``math.inf`` and ``Decimal`` are
    numbers). Every value is range-checked before it is converted; each failure is an
    ``EncodeError`` naming the field's full path and what the field takes."""
    message = cls()
    _read_message(message, document, message.DESCRIPTOR.full_name, 0)
    return message


class _Reader:
    """How to read one message type: its fields by every name the JSON mapping accepts."""

    def __init__(self, descriptor: Descriptor) -> None:
        self.descriptor = descriptor
        self.fields: dict[str, FieldDescriptor] = {}
        for field in descriptor.fields:
            self.fields[field.json_name] = field
        for field in descriptor.fields:
            self.fields[field.name] = field
        self.names = ", ".join(field.name for field in descriptor.fields)


_readers: dict[Descriptor, _Reader] = {}


def _read_message(message: Message, document: Any, path: str, depth: int) -> None:
    descriptor = descriptor_of(type(message))
    if descriptor.full_name in _WELL_KNOWN:
        try:
            json_format.ParseDict(document, message)
        except (json_format.ParseError, RecursionError) as error:
            raise EncodeError(f"{path}: {' '.join(str(error).split())}") from None
        return
    if not isinstance(document, Mapping):
        raise EncodeError(
            f"{path}: {_shown(document)} is not an object (the fields of {descriptor.full_name})"
        )
    if depth >= _MAX_DEPTH:
        raise EncodeError(f"{path}: messages nest more than {_MAX_DEPTH} deep")
    reader = _readers.get(descriptor)
    if reader is None:
        reader = _readers[descriptor] = _Reader(descriptor)
    given: dict[str, str] = {}  # field name → the key it was given as
    chosen: dict[str, str] = {}  # oneof name → the member given
    for key, value in document.items():
        field = reader.fields.get(key) if isinstance(key, str) else None
        if field is None:
            raise EncodeError(
                f"{path}: no field named {_shown(key)}: {descriptor.full_name} has {reader.names}"
            )
        if field.name in given:
            raise EncodeError(
                f"{path}.{field.name}: given twice, as {given[field.name]!r} and {key!r}"
            )
        given[field.name] = key
        if value is None and not _takes_null(field):
            continue  # null: the field is left unset
        oneof = field.containing_oneof
        if oneof is not None:
            if oneof.name in chosen:
                raise EncodeError(
                    f"{path}: {chosen[oneof.name]} and {field.name} are both members of oneof "
                    f"{oneof.name}: give one"
                )
            chosen[oneof.name] = field.name
        _read_field(message, field, value, f"{path}.{field.name}", depth)


def _takes_null(field: FieldDescriptor) -> bool:
    """Whether JSON ``null`` is a value of ``field`` (a ``Value``'s or a ``NullValue``'s), not
    the field left unset."""
    if field.is_repeated:
        return False
    kind = field.message_type or field.enum_type
    return kind is not None and kind.full_name in _NULLABLE


def _read_field(
    message: Message, field: FieldDescriptor, value: Any, path: str, depth: int
) -> None:
    entry = field.message_type
    if entry is not None and entry.GetOptions().map_entry:
        _read_map(getattr(message, field.name), entry, value, path, depth)
    elif field.is_repeated:
        if not isinstance(value, (list, tuple)):
            raise EncodeError(f"{path}: {_shown(value)} is not a list (a repeated {_type(field)})")
        items = getattr(message, field.name)
        for index, item in enumerate(value):
            where = f"{path}[{index}]"
            if item is None:
                raise EncodeError(f"{where}: null is not an item of a list")
            if field.cpp_type == _T.CPPTYPE_MESSAGE:
                _read_message(items.add(), item, where, depth + 1)
            else:
                items.append(_scalar(field, item, where))
    elif field.cpp_type == _T.CPPTYPE_MESSAGE:
        inner = getattr(message, field.name)
        inner.SetInParent()
        _read_message(inner, value, path, depth + 1)
    else:
        setattr(message, field.name, _scalar(field, value, path))


def _read_map(items: Any, entry: Descriptor, value: Any, path: str, depth: int) -> None:
    key_field, value_field = entry.fields_by_name["key"], entry.fields_by_name["value"]
    if not isinstance(value, Mapping):
        raise EncodeError(
            f"{path}: {_shown(value)} is not an object "
            f"(a map<{_type(key_field)}, {_type(value_field)}>)"
        )
    for key, item in value.items():
        where = entry_path(path, key)
        converted = _map_key(key_field, key, where)
        if item is None:
            raise EncodeError(f"{where}: null is not a value of a map")
        if value_field.cpp_type == _T.CPPTYPE_MESSAGE:
            _read_message(items[converted], item, where, depth + 1)
        else:
            items[converted] = _scalar(value_field, item, where)


def _map_key(field: FieldDescriptor, key: Any, path: str) -> Any:
    """A map key from its JSON spelling (a string), or from a Python int, bool or str."""
    kind = field.type
    if kind == _T.TYPE_STRING:
        if isinstance(key, str):
            return _text(key, path)
    elif kind == _T.TYPE_BOOL:
        if isinstance(key, bool):
            return key
        if key in ("true", "false"):
            return key == "true"
    elif isinstance(key, (str, int)) and not isinstance(key, bool):
        return _integer(kind, key, path, f"a key of type {_TYPE_NAMES[kind]}")
    raise EncodeError(f"{path}: {_shown(key)} is not a key of type {_TYPE_NAMES[kind]}")


def _scalar(field: FieldDescriptor, value: Any, path: str) -> Any:
    """The Python value protobuf stores for JSON ``value`` of ``field``'s type, or an error."""
    kind = field.type
    if kind in _INTEGERS:
        return _integer(kind, value, path, f"an integer ({_TYPE_NAMES[kind]})")
    if kind == _T.TYPE_ENUM:
        if value is None:  # a NullValue's one value (see _takes_null)
            return 0
        return _enum(enum_of(field), value, path)
    if kind == _T.TYPE_BOOL:
        if isinstance(value, bool):
            return value
        raise EncodeError(f"{path}: {_shown(value)} is not true or false (a bool)")
    if kind in (_T.TYPE_FLOAT, _T.TYPE_DOUBLE):
        return _floating(kind == _T.TYPE_FLOAT, value, path)
    if kind == _T.TYPE_STRING:
        if isinstance(value, str):
            return _text(value, path)
        raise EncodeError(f"{path}: {_shown(value)} is not a string")
    if isinstance(value, str):  # bytes
        text = value.replace("-", "+").replace("_", "/")
        try:
            return base64.b64decode(text + "=" * (-len(text) % 4), validate=True)
        except ValueError:  # binascii.Error, or a character beyond ASCII
            pass
    raise EncodeError(f"{path}: {_shown(value)} is not base64 text (bytes)")


def _integer(kind: int, value: Any, path: str, expected: str) -> int:
    """``value`` as an integer of type ``kind``, checked against its range before conversion."""
    low, high = _INTEGERS[kind]
    if isinstance(value, str):
        if not _DECIMAL_INTEGER.fullmatch(value):
            raise EncodeError(f"{path}: {_shown(value)} is not {expected}")
        number: Any = int(value)
    elif isinstance(value, (int, float, Decimal)) and not isinstance(value, bool):
        if not _integral(value):
            raise EncodeError(f"{path}: {_shown(value)} is not {expected}")
        number = value
    else:
        raise EncodeError(f"{path}: {_shown(value)} is not {expected}")
    if not low <= number <= high:
        raise EncodeError(
            f"{path}: {_shown(value)} is out of range for {_TYPE_NAMES[kind]} ({low}..{high})"
        )
    return int(number)


def _integral(value: int | float | Decimal) -> bool:
    """Whether a number is a whole one (``1.0`` and ``1e3`` are; infinities and NaN are not)."""
    if isinstance(value, int):
        return True
    if isinstance(value, Decimal):
        return value.is_finite() and value == value.to_integral_value()
    return math.isfinite(value) and value.is_integer()


def _enum(enum: EnumDescriptor, value: Any, path: str) -> int:
    """The number of an enum value given by name, or by a declared number."""
    names = ", ".join(value.name for value in enum.values)
    if isinstance(value, str):
        declared = enum.values_by_name.get(value)
        if declared is not None:
            return declared.number
        if not _DECIMAL_INTEGER.fullmatch(value):
            raise EncodeError(
                f"{path}: {_shown(value)} is not one of its names: {enum.full_name} takes one "
                f"of {names}"
            )
        value = int(value)
    elif isinstance(value, bool) or not isinstance(value, (int, float, Decimal)):
        raise EncodeError(
            f"{path}: {_shown(value)} is not a name or an integer: {enum.full_name} takes one "
            f"of {names}"
        )
    elif not _integral(value):
        raise EncodeError(
            f"{path}: {_shown(value)} is not an integer: {enum.full_name} takes one of {names}"
        )
    if not -(2**31) <= value < 2**31 or int(value) not in enum.values_by_number:
        raise EncodeError(
            f"{path}: {_shown(value)} is not a declared value: {enum.full_name} takes one of "
            f"{names}"
        )
    return int(value)


def _floating(single: bool, value: Any, path: str) -> float:
    """A float (``single``) or double from a number, a numeric string or a special string."""
    width = "float" if single else "double"
    if isinstance(value, str):
        if value in _SPECIAL_FLOATS:
            return _SPECIAL_FLOATS[value]
        if not _JSON_NUMBER.fullmatch(value):
            raise EncodeError(f"{path}: {_shown(value)} is not a number ({width})")
        number: Any = Decimal(value)
    elif isinstance(value, (int, float, Decimal)) and not isinstance(value, bool):
        number = value
    else:
        raise EncodeError(f"{path}: {_shown(value)} is not a number ({width})")
    if isinstance(number, float) and not math.isfinite(number):
        return number  # NaN or an infinity, given as itself
    if isinstance(number, Decimal) and not number.is_finite():
        raise EncodeError(f"{path}: {_shown(value)} is not a number ({width})")
    # A float field stores the double a number rounds to, rounded again to 32 bits (as protobuf
    # does): the double's range is checked exactly, before float() rounds or overflows, and a
    # float's on that double, before struct would overflow.
    result = float(number) if abs(number) < _DOUBLE_OVER else math.inf
    if abs(result) >= (_FLOAT_OVER if single else _DOUBLE_OVER):
        raise EncodeError(
            f"{path}: {_shown(value)} is out of range for {width}: it would be infinity"
        )
    stored = _F32.unpack(_F32.pack(result))[0] if single else result
    if stored == 0.0 and number != 0:
        raise EncodeError(f"{path}: {_shown(value)} is too small for {width}: it would be 0")
    return result


def _text(value: str, path: str) -> str:
    try:
        value.encode("utf-8")
    except UnicodeEncodeError:
        raise EncodeError(
            f"{path}: {_shown(value)} is not valid Unicode (a lone surrogate)"
        ) from None
    return value


def _type(field: FieldDescriptor) -> str:
    """A field's type as the .proto spells it."""
    if field.cpp_type == _T.CPPTYPE_MESSAGE:
        return message_of(field).full_name
    if field.type == _T.TYPE_ENUM:
        return enum_of(field).full_name
    return _TYPE_NAMES[field.type]


def _shown(value: Any) -> str:
    """``value`` as JSON spells it, cut short when long, for an error message."""
    if isinstance(value, Decimal):
        text = str(value).lower()  # 1e+39, as json writes a float
    else:
        try:
            text = json.dumps(value, default=repr)
        except (TypeError, ValueError):
            text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."
