"""Bundles to bytes and back, as Proton's C libraries put them on the wire (2.0 and 1.0).

Guarantees: ``encode`` writes exactly the bytes Proton's C library writes for the same values
(``proton_encode_bundle`` in 2.0, ``PROTON_Encode`` in 1.0): fields in number order, a oneof
member even when it holds zero, an id of 0 left out as proto3 leaves it, minimal varints, a
negative ``int32`` sign-extended to ten bytes, list items unpacked (one tag each, as 1.0's
callbacks write them). ``decode`` accepts any valid protobuf spelling of a bundle (fields in any
order, packed or unpacked lists) and refuses, with a ``DecodeError`` naming the bundle, the signal
and the byte offset, whatever Proton's C library would refuse or read wrongly: an unknown bundle
id, a signal the bundle lacks or carries twice, a value of another type, an integer out of its
type's range, a string or bytes value over its capacity, a string without its terminating NUL (2.0)
or with bytes after it, a list of another length, a field Proton does not define.

One value does not survive the trip through Python: a ``float`` signal holding a signalling NaN
(exponent all ones, quiet bit clear) decodes to a Python float, which CPython 3.11 holds as a quiet
NaN, so it re-encodes with the quiet bit set. Every other float, NaN payloads and -0.0 included,
and every double, comes back bit for bit.

The two versions (facts from ``2.0-d269668/proto`` and ``1.0-8c898cf/proto``):
- 2.0: ``Proton { oneof operation { Bundle bundle = 1 } }``, ``Bundle { uint32 id = 1;
  repeated Signal signals = 2 }``, ``Signal { oneof signal { 1..9 }; uint32 id = 19 }`` (10 to 18
  reserved). Signals are found by id, in any order. A string goes with its terminating NUL
  (``value_size = strlen + 1``); the C registry's initial state sends it padded with NULs to its
  capacity, which decodes to the same string.
- 1.0: the ``Bundle`` is the whole message and its ``Signal`` has no id: signals are told apart by
  their position, in the configuration's order. Strings go without a NUL (``strlen``), bytes as
  their whole buffer, lists as ``length`` items.
"""

import struct
from collections.abc import Mapping
from typing import NamedTuple

from .._errors import DecodeError, EncodeError
from ..schema import (
    I32,
    I64,
    LEN,
    VARINT,
    WIRE_TYPE_NAMES,
    FieldSpan,
    WireError,
    encode_varint,
    next_field,
    read_varint,
)
from ._config import BundleConfig, Config, ProtonConfigError, SignalConfig
from ._types import TYPES, Value, Version, check, element_of, field_number, is_list

__all__ = ["Bundle", "BundleCodec"]

_SIGNAL_ID = 19  # 2.0's Signal.id
_BUNDLE, _BUNDLE_ID, _BUNDLE_SIGNALS = 1, 1, 2
_DOUBLE, _FLOAT = struct.Struct("<d"), struct.Struct("<f")
_WIRE = {"double": I64, "float": I32, "string": LEN, "bytes": LEN}  # others: VARINT
_RANGES = {
    "int32": (-(1 << 31), (1 << 31) - 1),
    "int64": (-(1 << 63), (1 << 63) - 1),
    "uint32": (0, (1 << 32) - 1),
    "uint64": (0, (1 << 64) - 1),
    "bool": (0, 1),
}


class _Span(NamedTuple):
    tag: int  # offset of the field's tag
    value: int  # its content, after the length prefix
    end: int


class Bundle(NamedTuple):
    """A decoded bundle: its name and id in the configuration, its signals' values by name in the
    configuration's order."""

    name: str
    id: int
    signals: dict[str, Value]


class BundleCodec:
    """Encodes and decodes the bundles of one configuration in one protocol version."""

    def __init__(self, config: Config, version: Version = "2.0") -> None:
        if version not in ("1.0", "2.0"):
            raise ValueError(f"version must be '1.0' or '2.0', not {version!r}")
        if version == "2.0":
            for signal in config.signals:
                if is_list(signal.type):
                    raise ProtonConfigError(
                        config.source,
                        signal.line,
                        f"signal {signal.name!r}",
                        f"{signal.type} is a Proton 1.0 type; 2.0 has no list types",
                    )
        self.config = config
        self.version: Version = version
        self._bundles = {bundle.name: bundle for bundle in config.bundles}
        self._by_id = {bundle.id: bundle for bundle in config.bundles}
        self._signals = {signal.name: signal for signal in config.signals}

    # -- values --------------------------------------------------------------------------------

    def signal(self, name: str) -> SignalConfig:
        """The configuration of the signal called ``name`` (``EncodeError`` if none is)."""
        signal = self._signals.get(name)
        if signal is None:
            raise EncodeError(f"no signal is called {name!r} in {self.config.source}")
        return signal

    def bundle(self, name: str) -> BundleConfig:
        """The configuration of the bundle called ``name`` (``EncodeError`` if none is)."""
        bundle = self._bundles.get(name)
        if bundle is None:
            known = ", ".join(self._bundles) or "none"
            raise EncodeError(f"no bundle is called {name!r} (the configuration has {known})")
        return bundle

    def check(self, name: str, value: object) -> Value:
        """``value`` as signal ``name`` holds and sends it; ``EncodeError`` naming the signal and
        what is wrong if it cannot be sent unchanged."""
        signal = self.signal(name)
        try:
            return check(signal.type, signal.capacity, signal.length, value, self.version)
        except ValueError as error:
            raise EncodeError(f"signal {name!r} ({signal.type}): {error}") from None

    # -- encoding ------------------------------------------------------------------------------

    def encode(self, bundle: str, values: Mapping[str, object]) -> bytes:
        """The message carrying bundle ``bundle`` with ``values``: one value for each of its
        signals, by name (``EncodeError`` for a missing, unknown or unsendable one)."""
        config = self.bundle(bundle)
        for name in values:
            if name not in config.signals:
                raise EncodeError(
                    f"signal {name!r} is not in bundle {bundle!r} (it holds "
                    f"{', '.join(config.signals) or 'no signals'})"
                )
        missing = [name for name in config.signals if name not in values]
        if missing:
            raise EncodeError(f"bundle {bundle!r} needs a value for {', '.join(missing)}")
        return self._encode(config, [self.check(n, values[n]) for n in config.signals])

    def _encode(self, bundle: BundleConfig, values: list[Value]) -> bytes:
        """``bundle`` with values already checked (``check``), in its signals' order."""
        body = bytearray(_key(_BUNDLE_ID, VARINT) + encode_varint(bundle.id) if bundle.id else b"")
        for name, value in zip(bundle.signals, values, strict=True):
            signal = self._signals[name]
            item = _value(signal.type, value, self.version)
            if self.version == "2.0" and signal.id:
                item += _key(_SIGNAL_ID, VARINT) + encode_varint(signal.id)
            body += _length_delimited(_BUNDLE_SIGNALS, item)
        return _length_delimited(_BUNDLE, bytes(body)) if self.version == "2.0" else bytes(body)

    # -- decoding ------------------------------------------------------------------------------

    def decode(self, data: bytes) -> Bundle:
        """The bundle ``data`` carries (``DecodeError`` saying what is wrong and where)."""
        data = bytes(data)
        if not data:
            raise DecodeError("no bytes: a Proton message holds a bundle", "empty")
        try:
            if self.version == "2.0":
                start, end = self._operation(data)
            else:
                start, end = 0, len(data)
            bundle_id, spans = self._bundle_fields(data, start, end)
        except WireError as error:
            raise DecodeError(f"not protobuf: {error}") from None
        bundle = self._by_id.get(bundle_id)
        if bundle is None:
            raise DecodeError(
                f"bundle id {bundle_id:#x} is not in {self.config.source}", "unknown_bundle"
            )
        where = f"bundle {bundle.name!r} ({bundle.id:#x})"
        if self.version == "2.0":
            found = self._by_signal_id(data, bundle, spans, where)
        else:
            found = self._by_position(data, bundle, spans, where)
        return Bundle(bundle.name, bundle.id, {name: found[name] for name in bundle.signals})

    def _operation(self, data: bytes) -> tuple[int, int]:
        """Where the bundle of a 2.0 ``Proton`` message lies."""
        pos, found = 0, None
        while pos < len(data):
            span = next_field(data, pos)
            if span.number != _BUNDLE:
                raise DecodeError(
                    f"field {span.number} at offset {pos} is an operation Proton 2.0 does not "
                    "define (its Proton message holds only bundle = 1)",
                    "unsupported_operation",
                )
            _expect(span.wire_type, LEN, f"the bundle at offset {pos}")
            if found is not None:
                raise DecodeError(f"a second bundle at offset {pos}: Proton's oneof holds one")
            found, pos = (span.value, span.end), span.end
        if found is None:
            raise DecodeError("no bundle: the message is empty", "empty")
        return found

    def _bundle_fields(self, data: bytes, pos: int, end: int) -> tuple[int, list[_Span]]:
        """The bundle's id and where each of its signals lies, in order."""
        bundle_id: int | None = None
        spans = []
        while pos < end:
            span = _field(data, pos, end, "bundle")
            if span.number == _BUNDLE_ID:
                _expect(span.wire_type, VARINT, f"the bundle id at offset {pos}")
                if bundle_id is not None:
                    raise DecodeError(f"the bundle id is given twice (again at offset {pos})")
                bundle_id = _integer(data, span.value, "uint32", f"the bundle id at offset {pos}")
            elif span.number == _BUNDLE_SIGNALS:
                _expect(span.wire_type, LEN, f"the signal at offset {pos}")
                spans.append(_Span(pos, span.value, span.end))
            else:
                raise DecodeError(f"field {span.number} at offset {pos} is not a field of Bundle")
            pos = span.end
        return bundle_id or 0, spans

    def _by_signal_id(
        self, data: bytes, bundle: BundleConfig, spans: list[_Span], where: str
    ) -> dict[str, Value]:
        members = {self._signals[name].id: self._signals[name] for name in bundle.signals}
        found: dict[str, Value] = {}
        for start, content, end in spans:
            signal_id, number, value_span = _signal_fields(data, start, content, end, self.version)
            signal = members.get(signal_id)
            if signal is None:
                raise DecodeError(
                    f"{where}: signal id {signal_id:#x} at offset {start} is not in it"
                )
            if signal.name in found:
                raise DecodeError(f"{where}: signal {signal.name!r} again at offset {start}")
            found[signal.name] = self._value(data, signal, number, value_span, where, start)
        missing = [name for name in bundle.signals if name not in found]
        if missing:
            raise DecodeError(f"{where}: lacks {', '.join(repr(n) for n in missing)}")
        return found

    def _by_position(
        self, data: bytes, bundle: BundleConfig, spans: list[_Span], where: str
    ) -> dict[str, Value]:
        if len(spans) != len(bundle.signals):
            raise DecodeError(
                f"{where}: {len(spans)} signals; Proton 1.0 tells them by position and the "
                f"bundle has {len(bundle.signals)}"
            )
        found: dict[str, Value] = {}
        for name, (start, content, end) in zip(bundle.signals, spans, strict=True):
            _, number, value_span = _signal_fields(data, start, content, end, self.version)
            signal = self._signals[name]
            found[name] = self._value(data, signal, number, value_span, where, start)
        return found

    def _value(
        self,
        data: bytes,
        signal: SignalConfig,
        number: int,
        span: tuple[int, int, int],
        where: str,
        offset: int,
    ) -> Value:
        what = f"{where}: signal {signal.name!r} at offset {offset}"
        if number != field_number(signal.type):
            sent = TYPES[number - 1] if number <= len(TYPES) else f"field {number}"
            raise DecodeError(f"{what} is sent as {sent}; the configuration says {signal.type}")
        try:
            return _decoded(data, signal, span, self.version)
        except WireError as error:
            raise DecodeError(f"{what}: not protobuf: {error}") from None
        except ValueError as error:
            raise DecodeError(f"{what}: {error}") from None


# -- the wire, value by value ------------------------------------------------------------------


def _field(data: bytes, pos: int, end: int, container: str) -> FieldSpan:
    """The field at ``pos``, which must end within its container (ending at ``end``)."""
    span = next_field(data, pos)
    if span.end > end:
        raise WireError(f"field {span.number} at offset {pos} runs past the end of its {container}")
    return span


def _key(number: int, wire_type: int) -> bytes:
    return encode_varint(number << 3 | wire_type)


def _length_delimited(number: int, content: bytes) -> bytes:
    return _key(number, LEN) + encode_varint(len(content)) + content


def _item(element: str, value: object, version: Version, number: int) -> bytes:
    """One scalar as field ``number``: its tag and its value."""
    if element == "double":
        return _key(number, I64) + _DOUBLE.pack(value)
    if element == "float":
        return _key(number, I32) + _FLOAT.pack(value)
    if element == "string":
        assert isinstance(value, str)
        text = value.encode("utf-8")
        return _length_delimited(number, text + b"\0" if version == "2.0" else text)
    if element == "bytes":
        assert isinstance(value, bytes)
        return _length_delimited(number, value)
    assert isinstance(value, int)
    return _key(number, VARINT) + encode_varint(int(value))


def _value(type_name: str, value: Value, version: Version) -> bytes:
    """A signal's value field: its oneof member (1.0's list types: one tag per item)."""
    number = field_number(type_name)
    if not is_list(type_name):
        return _item(type_name, value, version, number)
    assert isinstance(value, list)
    element = element_of(type_name)
    return _length_delimited(number, b"".join(_item(element, v, version, 1) for v in value))


def _expect(wire_type: int, wanted: int, what: str) -> None:
    if wire_type != wanted:
        raise DecodeError(
            f"{what} has wire type {WIRE_TYPE_NAMES.get(wire_type, wire_type)}, not "
            f"{WIRE_TYPE_NAMES[wanted]}"
        )


def _signal_fields(
    data: bytes, start: int, pos: int, end: int, version: Version
) -> tuple[int, int, tuple[int, int, int]]:
    """A signal's id (0 in 1.0), the number of its value field and (wire type, start, end);
    its tag is at ``start``, its fields from ``pos`` to ``end``."""
    signal_id: int | None = None
    value: tuple[int, int, int, int] | None = None  # number, wire type, start, end
    members = 9 if version == "2.0" else 18
    while pos < end:
        span = _field(data, pos, end, "signal")
        if version == "2.0" and span.number == _SIGNAL_ID:
            _expect(span.wire_type, VARINT, f"the signal id at offset {pos}")
            if signal_id is not None:
                raise DecodeError(f"the signal at offset {start} gives its id twice")
            signal_id = _integer(data, span.value, "uint32", f"the signal id at offset {pos}")
        elif 1 <= span.number <= members:
            if value is not None:
                raise DecodeError(
                    f"the signal at offset {start} carries two values (fields {value[0]} and "
                    f"{span.number}); its oneof holds one"
                )
            value = (span.number, span.wire_type, span.value, span.end)
        elif version == "2.0" and 10 <= span.number <= 18:
            raise DecodeError(
                f"field {span.number} at offset {pos} is Proton 1.0's {TYPES[span.number - 1]}, "
                "reserved in 2.0"
            )
        else:
            raise DecodeError(f"field {span.number} at offset {pos} is not a field of Signal")
        pos = span.end
    if value is None:
        raise DecodeError(f"the signal at offset {start} carries no value")
    return signal_id or 0, value[0], value[1:]


def _decoded(
    data: bytes, signal: SignalConfig, span: tuple[int, int, int], version: Version
) -> Value:
    wire_type, start, end = span
    element = element_of(signal.type)
    if not is_list(signal.type):
        return _scalar(data, element, wire_type, start, end, signal.capacity, version)
    if wire_type != LEN:
        raise ValueError(f"its list has wire type {WIRE_TYPE_NAMES.get(wire_type, wire_type)}")
    items: list[float | int | bool | str | bytes] = []
    pos = start
    while pos < end:
        item = _field(data, pos, end, "list")
        if item.number != 1:
            raise ValueError(f"field {item.number} at offset {pos} is not a field of its list")
        packed = item.wire_type == LEN and element not in ("string", "bytes")
        if packed:  # a packed run of numbers: protobuf's default spelling for repeated scalars
            items += _packed(data, element, item.value, item.end)
        else:
            items.append(
                _scalar(data, element, item.wire_type, item.value, item.end, signal.capacity, "1.0")
            )
        pos = item.end
    if len(items) != signal.length:
        raise ValueError(f"its list holds {len(items)} items, not its length {signal.length}")
    return items  # type: ignore[return-value]  # one item type per list


def _packed(data: bytes, element: str, pos: int, end: int) -> list[float | int | bool]:
    values: list[float | int | bool] = []
    size = {"double": 8, "float": 4}.get(element)
    while pos < end:
        if size is not None:
            if pos + size > end:
                raise WireError(f"the packed {element} at offset {pos} is cut off")
            values.append(_fixed(data, element, pos))
            pos += size
        else:
            value, after = read_varint(data, pos)
            if after > end:
                raise WireError(f"the packed {element} at offset {pos} is cut off")
            values.append(_ranged(value, element, f"the item at offset {pos}"))
            pos = after
    return values


def _scalar(
    data: bytes,
    element: str,
    wire_type: int,
    start: int,
    end: int,
    capacity: int,
    version: Version,
) -> float | int | bool | str | bytes:
    wanted = _WIRE.get(element, VARINT)
    if wire_type != wanted:
        raise ValueError(
            f"its {element} has wire type {WIRE_TYPE_NAMES.get(wire_type, wire_type)}, not "
            f"{WIRE_TYPE_NAMES[wanted]}"
        )
    if element in ("double", "float"):
        return _fixed(data, element, start)
    if element == "string":
        return _text(data[start:end], capacity, version, start)
    if element == "bytes":
        raw = data[start:end]
        if len(raw) > capacity or (version == "1.0" and len(raw) != capacity):
            exactly = "exactly " if version == "1.0" else "at most "
            raise ValueError(f"is {len(raw)} bytes; its capacity takes {exactly}{capacity}")
        return raw
    value, _ = read_varint(data, start)
    return _ranged(value, element, "its value")


def _fixed(data: bytes, element: str, pos: int) -> float:
    layout = _DOUBLE if element == "double" else _FLOAT
    return float(layout.unpack_from(data, pos)[0])


def _ranged(value: int, element: str, what: str) -> int | bool:
    if element in ("int32", "int64") and value >= 1 << 63:
        value -= 1 << 64  # a negative value, sign-extended to 64 bits
    low, high = _RANGES[element]
    if not low <= value <= high:
        raise ValueError(f"{what} is {value}, out of {element}'s range {low}..{high}")
    return bool(value) if element == "bool" else value


def _integer(data: bytes, pos: int, element: str, what: str) -> int:
    """A varint field that must fit ``element`` (an id, say)."""
    value, _ = read_varint(data, pos)
    try:
        return int(_ranged(value, element, what))
    except ValueError as error:
        raise DecodeError(str(error)) from None


def _text(raw: bytes, capacity: int, version: Version, offset: int) -> str:
    """A string's wire bytes as the C registry reads them: up to its NUL (2.0), all (1.0)."""
    if version == "2.0":
        if len(raw) > capacity:
            raise ValueError(f"is {len(raw)} bytes with its NUL, over its capacity of {capacity}")
        cut = raw.find(b"\0")
        if cut < 0:
            raise ValueError("lacks its terminating NUL (Proton 2.0 sends strlen + 1 bytes)")
        if raw[cut:].strip(b"\0"):
            raise ValueError(f"holds bytes after its terminating NUL at offset {offset + cut}")
        raw = raw[:cut]
    else:
        if len(raw) > capacity - 1:
            raise ValueError(f"is {len(raw)} bytes; capacity {capacity} takes {capacity - 1}")
        if b"\0" in raw:
            raise ValueError(f"holds a NUL at offset {offset + raw.index(0)}")
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as error:
        raise ValueError(f"is not UTF-8 at offset {offset + error.start}") from None
