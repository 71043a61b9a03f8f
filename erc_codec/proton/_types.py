"""Proton's signal types: their names, their numbers in ``Signal``'s oneof, and the Python values
they take.

Guarantees: ``check`` accepts a value only if Proton's C library would send it unchanged and the
other side would read it back as the same value, and returns it in its one canonical Python form
(``float`` for ``double``/``float``, ``int``, ``bool``, ``str``, ``bytes``, ``list`` of those);
anything else is a ``ValueError`` whose text says what is wrong with the value. The one change it
makes is the one a C ``float`` makes: a ``float`` signal's value is rounded to the nearest 32-bit
float (out of its range is an error).

Facts, from Proton's sources (``2.0-d269668`` and ``1.0-8c898cf``):
- the scalar types are oneof members 1 to 9 (``double`` … ``bytes``) in both versions; 1.0 adds
  the list types, members 10 to 18, each a message with one ``repeated`` field 1;
- a string's capacity counts its terminating NUL: at most ``capacity - 1`` bytes of UTF-8 (2.0's
  registry sends ``strlen + 1`` bytes; 1.0's decoder refuses more than ``capacity - 1``);
- 1.0 sends a ``bytes`` signal as its whole buffer (``capacity`` bytes), a list as exactly
  ``length`` items (``proton_list_t.length``), each ``list_bytes`` item ``capacity`` bytes long.
"""

import math
import struct
from typing import Literal, NamedTuple, get_args

__all__ = [
    "LIST_TYPES",
    "SCALAR_TYPES",
    "TYPES",
    "SignalType",
    "Value",
    "Version",
    "check",
    "element_of",
    "field_number",
    "is_list",
    "needs_capacity",
    "zero",
]

Version = Literal["1.0", "2.0"]
Value = (
    float
    | int
    | bool
    | str
    | bytes
    | list[float]
    | list[int]
    | list[bool]
    | list[str]
    | list[bytes]
)

SignalType = Literal[
    "double",
    "float",
    "int32",
    "int64",
    "uint32",
    "uint64",
    "bool",
    "string",
    "bytes",
    "list_double",
    "list_float",
    "list_int32",
    "list_int64",
    "list_uint32",
    "list_uint64",
    "list_bool",
    "list_string",
    "list_bytes",
]
TYPES: tuple[SignalType, ...] = get_args(SignalType)  # member n of Signal's oneof: TYPES[n - 1]
SCALAR_TYPES = TYPES[:9]
LIST_TYPES = TYPES[9:]


class _Range(NamedTuple):
    low: int
    high: int


_RANGES = {
    "int32": _Range(-(1 << 31), (1 << 31) - 1),
    "int64": _Range(-(1 << 63), (1 << 63) - 1),
    "uint32": _Range(0, (1 << 32) - 1),
    "uint64": _Range(0, (1 << 64) - 1),
}
_FLOAT32 = struct.Struct("<f")


def is_list(type_name: str) -> bool:
    return type_name.startswith("list_")


def element_of(type_name: str) -> str:
    """The scalar type of a list type's items (a scalar type is its own)."""
    return type_name.removeprefix("list_")


def field_number(type_name: str) -> int:
    """The type's member number in ``Signal``'s oneof."""
    return TYPES.index(type_name) + 1


def needs_capacity(type_name: str) -> bool:
    """Whether the type's values (or items) are sized by a capacity: strings and bytes."""
    return element_of(type_name) in ("string", "bytes")


def zero(type_name: str, capacity: int, length: int) -> Value:
    """The value a signal holds when its configuration gives none, as Proton's generated
    registry holds it: zeros, an empty string, ``capacity`` zero bytes, ``length`` such items."""
    item = _zero_item(element_of(type_name), capacity)
    if is_list(type_name):
        return [item] * length  # type: ignore[return-value]  # one item type per list
    return item


def _zero_item(element: str, capacity: int) -> float | int | bool | str | bytes:
    if element in ("double", "float"):
        return 0.0
    if element == "bool":
        return False
    if element == "string":
        return ""
    if element == "bytes":
        return bytes(capacity)
    return 0


def check(type_name: str, capacity: int, length: int, value: object, version: Version) -> Value:
    """``value`` in its canonical form for a signal of this type, capacity and length, as
    ``version`` sends it; ``ValueError`` saying what is wrong otherwise."""
    element = element_of(type_name)
    if not is_list(type_name):
        return _item(element, capacity, value, version, fixed_bytes=version == "1.0")
    if not isinstance(value, list | tuple):
        raise ValueError(f"{_shown(value)} is not a list (a {type_name} is a list of {element})")
    if len(value) != length:
        raise ValueError(
            f"{_shown(value)} holds {len(value)} items; a {type_name} of length {length} is sent "
            f"as exactly {length}"
        )
    items = []
    for index, item in enumerate(value):
        try:
            items.append(_item(element, capacity, item, version, fixed_bytes=True))
        except ValueError as error:
            raise ValueError(f"item {index}: {error}") from None
    return items  # type: ignore[return-value]  # one item type per list


def _item(
    element: str, capacity: int, value: object, version: Version, fixed_bytes: bool
) -> float | int | bool | str | bytes:
    if element in ("double", "float"):
        return _real(element, value)
    if element in _RANGES:
        if not isinstance(value, int) or isinstance(value, bool):
            raise ValueError(f"{_shown(value)} is not an integer")
        low, high = _RANGES[element]
        if not low <= value <= high:
            raise ValueError(f"{value} is out of {element}'s range {low}..{high}")
        return value
    if element == "bool":
        if not isinstance(value, bool):
            raise ValueError(f"{_shown(value)} is not a bool")
        return value
    if element == "string":
        return _string(capacity, value)
    return _bytes(capacity, value, fixed_bytes)


def _real(element: str, value: object) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ValueError(f"{_shown(value)} is not a number")
    number = float(value)
    if isinstance(value, int) and number != value:
        raise ValueError(f"{value} has no exact {element} (it would be sent as {number!r})")
    if element == "double" or math.isnan(number):
        return number
    try:
        return float(_FLOAT32.unpack(_FLOAT32.pack(number))[0])
    except OverflowError:
        raise ValueError(f"{number!r} is out of float's range (32 bits)") from None


def _string(capacity: int, value: object) -> str:
    if not isinstance(value, str):
        raise ValueError(f"{_shown(value)} is not a str")
    try:
        encoded = value.encode("utf-8")
    except UnicodeEncodeError as error:
        raise ValueError(
            f"{_shown(value)} is not UTF-8 text: {error.reason} at index {error.start}"
        ) from None
    if b"\0" in encoded:
        raise ValueError(
            f"{_shown(value)} holds a NUL at index {value.index(chr(0))}: Proton's C strings end "
            "at the first NUL"
        )
    if len(encoded) + 1 > capacity:
        raise ValueError(
            f"{_shown(value)} is {len(encoded)} bytes of UTF-8; capacity {capacity} holds "
            f"{capacity - 1} and the terminating NUL"
        )
    return value


def _bytes(capacity: int, value: object, fixed: bool) -> bytes:
    if not isinstance(value, bytes | bytearray | memoryview):
        raise ValueError(f"{_shown(value)} is not bytes")
    data = bytes(value)
    if fixed and len(data) != capacity:
        raise ValueError(
            f"{_shown(data)} is {len(data)} bytes; Proton 1.0 sends a bytes value of capacity "
            f"{capacity} as exactly {capacity}"
        )
    if len(data) > capacity:
        raise ValueError(f"{_shown(data)} is {len(data)} bytes, over its capacity of {capacity}")
    return data


def _shown(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 40 else f"{text[:37]}..."
