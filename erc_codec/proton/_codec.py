"""Bundles to bytes and back, as Proton's C libraries put them on the wire (2.0 and 1.0).

Guarantees: ``encode`` writes exactly the bytes Proton's C library writes for the same values
(``proton_encode_bundle`` in 2.0, ``PROTON_Encode`` in 1.0): fields in number order, a oneof
member even when it holds zero, an id of 0 left out as proto3 leaves it, minimal varints, a
negative ``int32`` sign-extended to ten bytes, list items unpacked (one tag each, as 1.0's
callbacks write them).

``decode`` accepts a message exactly when protobuf (Proton's .proto) and Proton's C library (the
nanopb 0.4.9.1 both versions vendor, and their callbacks) read it as the same bundle, and returns
those values. So it takes any spelling both accept: fields in any order within a signal, packed
or unpacked lists, varints of any length up to ten bytes, an ``int32`` as a 5-byte varint (its low
32 bits: both truncate), any nonzero ``bool``, a field given twice where both keep the last (an
id, a number), a bundle split across two ``Proton.bundle`` fields (both merge them), and fields
Proton does not define (both skip them; each is reported in ``Bundle.unknown_fields``, so none
goes unseen). It refuses, with a ``DecodeError`` naming the bundle, the signal and the byte
offset, what either refuses or what the C library would hold wrongly: an unknown bundle id; a
signal the bundle lacks (C refuses it, or keeps an earlier message's value) or carries twice; a
value of another type; an integer out of its type's range (a ``uint32`` past 32 bits, anything
past 64); a ``bool``, or a 1.0 list's ``int32``/``uint32`` item, whose varint nanopb's
``pb_decode_varint32`` refuses; a string or bytes value over its capacity; a string that is not
UTF-8; a 2.0 string without its terminating NUL or with bytes after it; a 1.0 bytes value or list
of another size; a signal before the bundle id it belongs to (the C core reads each signal
against the id given before it; 1.0's ``PROTON_DecodeId`` reads the id from the message's first
field only); a string, bytes or list value after another value of the same signal (the C library
reads one only first: an earlier value has used or overwritten its buffer), or, in 1.0, in a
signal of another type (protonc has no buffer for it).

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

from erc_schema import (
    I32,
    I64,
    LEN,
    VARINT,
    WIRE_TYPE_NAMES,
    DecodeError,
    EncodeError,
    FieldSpan,
    WireError,
    encode_varint,
    next_field,
    read_varint,
)

from ._config import BundleConfig, Config, ProtonConfigError, SignalConfig
from ._types import TYPES, Value, Version, check, element_of, field_number, is_list, needs_capacity

__all__ = ["SCRATCH_BUFFER_SIZE", "Bundle", "BundleCodec", "UnknownField"]

SCRATCH_BUFFER_SIZE = 512  # Proton 2.0's PROTON_SCRATCH_BUFFER_SIZE (proton_config.h)
_SIGNAL_ID = 19  # 2.0's Signal.id
_BUNDLE, _BUNDLE_ID, _BUNDLE_SIGNALS = 1, 1, 2
_HEARTBEAT = 0
_DOUBLE, _FLOAT = struct.Struct("<d"), struct.Struct("<f")
_WIRE = {"double": I64, "float": I32, "string": LEN, "bytes": LEN}  # others: VARINT
_UINT32_MAX, _UINT64 = (1 << 32) - 1, 1 << 64


class _Span(NamedTuple):
    tag: int  # offset of the field's tag
    value: int  # its content, after the length prefix
    end: int


class _Value(NamedTuple):
    number: int  # the oneof member
    wire_type: int
    start: int
    end: int


class UnknownField(NamedTuple):
    """A field a received message carried that Proton's .proto does not define, skipped as
    protobuf and Proton's C libraries skip it: the message it was in (``"Proton"``, ``"Bundle"``
    or ``"Signal"``), its number, and the offset of its tag."""

    message: str
    number: int
    offset: int


class Bundle(NamedTuple):
    """A decoded bundle: its name and id in the configuration, its signals' values by name in the
    configuration's order, and the fields it carried that Proton does not define (skipped)."""

    name: str
    id: int
    signals: dict[str, Value]
    unknown_fields: tuple[UnknownField, ...] = ()


class BundleCodec:
    """Encodes and decodes the bundles of one configuration in one protocol version."""

    def __init__(
        self,
        config: Config,
        version: Version = "2.0",
        scratch_buffer_size: int = SCRATCH_BUFFER_SIZE,
    ) -> None:
        """``scratch_buffer_size``: the ``PROTON_SCRATCH_BUFFER_SIZE`` the 2.0 peers' C core is
        built with (512 unless the board's build sets another, 1 to 65535): the core decodes
        every string and bytes value through a buffer of that size, so a configuration with a
        larger capacity is a ``ProtonConfigError`` for 2.0. 1.0 decodes into each signal's own
        buffer and has no such limit."""
        if version not in ("1.0", "2.0"):
            raise ValueError(f"version must be '1.0' or '2.0', not {version!r}")
        if (
            not isinstance(scratch_buffer_size, int)
            or isinstance(scratch_buffer_size, bool)
            or not 1 <= scratch_buffer_size <= 0xFFFF
        ):
            raise ValueError(
                "scratch_buffer_size must be 1..65535 bytes (a uint16_t), "
                f"not {scratch_buffer_size!r}"
            )
        for index, signal in enumerate(config.signals):
            if version == "2.0":
                _fits_the_core(config, index, signal, scratch_buffer_size)
        if version == "1.0":
            for index, bundle in enumerate(config.bundles):
                _is_a_heartbeat_if_zero(config, index, bundle)
        self.config = config
        self.version: Version = version
        self.scratch_buffer_size = scratch_buffer_size
        self._bundles = {bundle.name: bundle for bundle in config.bundles}
        self._by_id = {bundle.id: bundle for bundle in config.bundles}
        self._signals = {signal.name: signal for signal in config.signals}

    # -- values --------------------------------------------------------------------------------

    def check(self, name: str, value: object) -> Value:
        """``value`` as signal ``name`` holds and sends it; ``EncodeError`` naming the signal and
        what is wrong if it cannot be sent unchanged (``KeyError`` for a name the configuration
        does not have)."""
        signal = self._signal(name)
        try:
            return check(signal.type, signal.capacity, signal.length, value, self.version)
        except ValueError as error:
            raise EncodeError(f"signal {name!r} ({signal.type}): {error}") from None

    def _signal(self, name: str) -> SignalConfig:
        signal = self._signals.get(name)
        if signal is None:
            raise KeyError(f"no signal is called {name!r} in {self.config.source}")
        return signal

    def _bundle(self, name: str) -> BundleConfig:
        bundle = self._bundles.get(name)
        if bundle is None:
            known = ", ".join(self._bundles) or "none"
            raise KeyError(f"no bundle is called {name!r} (the configuration has {known})")
        return bundle

    # -- encoding ------------------------------------------------------------------------------

    def encode(self, bundle: str, values: Mapping[str, object]) -> bytes:
        """The message carrying bundle ``bundle`` with ``values``: one value for each of its
        signals, by name (``EncodeError`` for a missing, unknown or unsendable one; ``KeyError``
        for a bundle the configuration does not have)."""
        config = self._bundle(bundle)
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
        unknown: list[UnknownField] = []
        try:
            parts = self._operation(data, unknown) if self.version == "2.0" else [(0, len(data))]
            bundle_id, spans = self._bundle_fields(data, parts, unknown)
            bundle = self._by_id.get(bundle_id)
            if bundle is None:
                raise DecodeError(
                    f"bundle id {bundle_id:#x} is not in {self.config.source}", "unknown_bundle"
                )
            where = f"bundle {bundle.name!r} ({bundle.id:#x})"
            if self.version == "2.0":
                found = self._by_signal_id(data, bundle, spans, where, unknown)
            else:
                found = self._by_position(data, bundle, spans, where, unknown)
        except WireError as error:
            raise DecodeError(f"not protobuf: {error}") from None
        signals = {name: found[name] for name in bundle.signals}
        return Bundle(bundle.name, bundle.id, signals, tuple(unknown))

    def _operation(self, data: bytes, unknown: list[UnknownField]) -> list[tuple[int, int]]:
        """Where the bundle of a 2.0 ``Proton`` message lies: every ``bundle`` field's content
        (a submessage given twice is merged, by protobuf and by nanopb alike)."""
        pos = 0
        parts: list[tuple[int, int]] = []
        while pos < len(data):
            span = next_field(data, pos)
            if span.number == _BUNDLE:
                _expect(span.wire_type, LEN, f"the bundle at offset {pos}")
                parts.append((span.value, span.end))
            else:
                unknown.append(UnknownField("Proton", span.number, pos))
            pos = span.end
        if not parts and unknown:
            first = unknown[0]
            raise DecodeError(
                f"no bundle: field {first.number} at offset {first.offset} is an operation "
                "Proton 2.0 does not define (its Proton message holds only bundle = 1)",
                "unsupported_operation",
            )
        if not parts:
            raise DecodeError("no bundle: the message is empty", "empty")
        return parts

    def _bundle_fields(
        self, data: bytes, parts: list[tuple[int, int]], unknown: list[UnknownField]
    ) -> tuple[int, list[_Span]]:
        """The bundle's id (protobuf's: the last one given) and where each of its signals lies,
        in order; refused if a C library would read the signals against another id."""
        bundle_id = 0
        ids: list[tuple[int, int]] = []  # offset, id
        spans: list[tuple[_Span, int]] = []  # each signal, and the id given before it
        first_field: int | None = None
        for pos, end in parts:
            while pos < end:
                span = _field(data, pos, end, "bundle")
                if first_field is None:
                    first_field = span.number
                if span.number == _BUNDLE_ID:
                    _expect(span.wire_type, VARINT, f"the bundle id at offset {pos}")
                    bundle_id = _id(data, span.value, f"the bundle id at offset {pos}")
                    ids.append((pos, bundle_id))
                elif span.number == _BUNDLE_SIGNALS:
                    _expect(span.wire_type, LEN, f"the signal at offset {pos}")
                    spans.append((_Span(pos, span.value, span.end), bundle_id))
                else:
                    unknown.append(UnknownField("Bundle", span.number, pos))
                pos = span.end
        self._read_against(bundle_id, ids, spans, first_field)
        return bundle_id, [span for span, _ in spans]

    def _read_against(
        self,
        bundle_id: int,
        ids: list[tuple[int, int]],
        spans: list[tuple[_Span, int]],
        first_field: int | None,
    ) -> None:
        """Refuse a message whose signals the C library would read against another bundle id
        than ``bundle_id`` (protobuf's: the last given)."""
        if self.version == "2.0":
            for span, before in spans:
                if before != bundle_id:
                    raise DecodeError(
                        f"the signal at offset {span.tag} comes before bundle id {bundle_id:#x} "
                        f"(at offset {ids[-1][0]}): Proton's C core reads a signal against the "
                        f"bundle id given before it ({before:#x})"
                    )
        elif ids:
            offset, first_id = ids[0]
            if first_field != _BUNDLE_ID:
                raise DecodeError(
                    f"the bundle id at offset {offset} is not the message's first field: "
                    "protonc's PROTON_DecodeId, which picks the bundle to decode into, reads "
                    "only that"
                )
            for offset, other in ids[1:]:
                if other != first_id:
                    raise DecodeError(
                        f"the bundle id is {first_id:#x}, then {other:#x} at offset {offset}: "
                        "protonc decodes into the first one's bundle, protobuf reads the last"
                    )

    def _by_signal_id(
        self,
        data: bytes,
        bundle: BundleConfig,
        spans: list[_Span],
        where: str,
        unknown: list[UnknownField],
    ) -> dict[str, Value]:
        members = {self._signals[name].id: self._signals[name] for name in bundle.signals}
        found: dict[str, Value] = {}
        for start, content, end in spans:
            signal_id, values = self._signal_fields(data, start, content, end, unknown)
            signal = members.get(signal_id)
            if signal is None:
                raise DecodeError(
                    f"{where}: signal id {signal_id:#x} at offset {start} is not in it"
                )
            if signal.name in found:
                raise DecodeError(f"{where}: signal {signal.name!r} again at offset {start}")
            found[signal.name] = self._value(data, signal, values, where, start)
        missing = [name for name in bundle.signals if name not in found]
        if missing:
            raise DecodeError(f"{where}: lacks {', '.join(repr(n) for n in missing)}")
        return found

    def _by_position(
        self,
        data: bytes,
        bundle: BundleConfig,
        spans: list[_Span],
        where: str,
        unknown: list[UnknownField],
    ) -> dict[str, Value]:
        if len(spans) != len(bundle.signals):
            raise DecodeError(
                f"{where}: {len(spans)} signals; Proton 1.0 tells them by position and the "
                f"bundle has {len(bundle.signals)}"
            )
        found: dict[str, Value] = {}
        for name, (start, content, end) in zip(bundle.signals, spans, strict=True):
            _, values = self._signal_fields(data, start, content, end, unknown)
            found[name] = self._value(data, self._signals[name], values, where, start)
        return found

    def _signal_fields(
        self, data: bytes, start: int, pos: int, end: int, unknown: list[UnknownField]
    ) -> tuple[int, list[_Value]]:
        """A signal's id (the last given; 0 in 1.0) and its value fields, in order; its tag is
        at ``start``, its fields from ``pos`` to ``end``."""
        signal_id = 0
        values: list[_Value] = []
        members = 9 if self.version == "2.0" else 18
        skipped = len(unknown)
        while pos < end:
            span = _field(data, pos, end, "signal")
            if self.version == "2.0" and span.number == _SIGNAL_ID:
                _expect(span.wire_type, VARINT, f"the signal id at offset {pos}")
                signal_id = _id(data, span.value, f"the signal id at offset {pos}")
            elif 1 <= span.number <= members:
                values.append(_Value(span.number, span.wire_type, span.value, span.end))
            else:
                unknown.append(UnknownField("Signal", span.number, pos))
            pos = span.end
        if not values:
            hint = ""
            for field in unknown[skipped:]:
                if self.version == "2.0" and 10 <= field.number <= 18:
                    hint = f" (field {field.number}, 1.0's {TYPES[field.number - 1]}, is not 2.0's)"
                    break
            raise DecodeError(f"the signal at offset {start} carries no value{hint}")
        return signal_id, values

    def _value(
        self, data: bytes, signal: SignalConfig, values: list[_Value], where: str, offset: int
    ) -> Value:
        """The signal's value: its last value field, as protobuf and nanopb both keep a oneof,
        where the C library reads that one right."""
        what = f"{where}: signal {signal.name!r} at offset {offset}"
        own = field_number(signal.type)
        for index, given in enumerate(values):
            member = TYPES[given.number - 1]
            if not (needs_capacity(member) or is_list(member)):
                continue
            if index > 0:
                raise DecodeError(
                    f"{what} carries two values (fields {values[0].number} and {given.number}): "
                    f"Proton's C library reads a {member} only as a signal's first value (an "
                    "earlier one has used or overwritten its buffer)"
                )
            if self.version == "1.0" and given.number != own:
                raise DecodeError(
                    f"{what} carries a {member} value: protonc decodes one only into a "
                    f"{member} signal's buffer, and refuses it in a {signal.type}"
                )
        value = values[-1]
        if value.number != own:
            sent = TYPES[value.number - 1]
            raise DecodeError(f"{what} is sent as {sent}; the configuration says {signal.type}")
        try:
            return _decoded(data, signal, value, self.version)
        except WireError as error:
            raise DecodeError(f"{what}: not protobuf: {error}") from None
        except ValueError as error:
            raise DecodeError(f"{what}: {error}") from None


def _fits_the_core(config: Config, index: int, signal: SignalConfig, scratch: int) -> None:
    """A 2.0 signal the C core can decode: no list type, a string of at most ``scratch - 1``
    bytes with its NUL, bytes of at most ``scratch`` (proton_Signal_callback's checks)."""
    if is_list(signal.type):
        raise ProtonConfigError(
            config.source,
            signal.line,
            f"signals[{index}].type",
            f"{signal.type} (signal {signal.name!r}) is a Proton 1.0 type; 2.0 has no list types",
        )
    room = {"string": scratch - 1, "bytes": scratch}.get(signal.type)
    if room is not None and signal.capacity > room:
        raise ProtonConfigError(
            config.source,
            signal.line,
            f"signals[{index}].capacity",
            f"capacity {signal.capacity} (signal {signal.name!r}): Proton 2.0's C core decodes "
            f"a {signal.type} value through its {scratch}-byte scratch buffer "
            f"(PROTON_SCRATCH_BUFFER_SIZE) and refuses one over {room} bytes"
            f"{' with its NUL' if signal.type == 'string' else ''}: give capacity {room} or "
            "less, or the scratch buffer size the board's core is built with",
        )


def _is_a_heartbeat_if_zero(config: Config, index: int, bundle: BundleConfig) -> None:
    """Proton 1.0 reserves bundle id 0 for the heartbeat: one uint32 signal."""
    if bundle.id != _HEARTBEAT:
        return
    types = [signal.type for signal in config.signals if signal.name in bundle.signals]
    if types != ["uint32"]:
        raise ProtonConfigError(
            config.source,
            bundle.line,
            f"bundles[{index}].id",
            f"bundle {bundle.name!r}: Proton 1.0 reserves bundle id 0 for the heartbeat, "
            "exactly one uint32 signal",
        )


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


def _decoded(data: bytes, signal: SignalConfig, value: _Value, version: Version) -> Value:
    element = element_of(signal.type)
    if not is_list(signal.type):
        return _scalar(data, element, value, signal.capacity, version, listed=False)
    if value.wire_type != LEN:
        raise ValueError(
            f"its list has wire type {WIRE_TYPE_NAMES.get(value.wire_type, value.wire_type)}"
        )
    items: list[float | int | bool | str | bytes] = []
    pos = value.start
    while pos < value.end:
        item = _field(data, pos, value.end, "list")
        if item.number != 1:
            raise ValueError(f"field {item.number} at offset {pos} is not a field of its list")
        packed = item.wire_type == LEN and element not in ("string", "bytes")
        if packed:  # a packed run of numbers: protobuf's default spelling for repeated scalars
            items += _packed(data, element, item.value, item.end)
        else:
            one = _Value(1, item.wire_type, item.value, item.end)
            items.append(_scalar(data, element, one, signal.capacity, "1.0", listed=True))
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
            _, after = read_varint(data, pos)
            if after > end:
                raise WireError(f"the packed {element} at offset {pos} is cut off")
            values.append(_number(data, pos, element, True, f"the item at offset {pos}"))
            pos = after
    return values


def _scalar(
    data: bytes, element: str, value: _Value, capacity: int, version: Version, listed: bool
) -> float | int | bool | str | bytes:
    """One value (a 1.0 list's item when ``listed``: protonc's callbacks read those)."""
    wanted = _WIRE.get(element, VARINT)
    if value.wire_type != wanted:
        raise ValueError(
            f"its {element} has wire type "
            f"{WIRE_TYPE_NAMES.get(value.wire_type, value.wire_type)}, not "
            f"{WIRE_TYPE_NAMES[wanted]}"
        )
    if element in ("double", "float"):
        return _fixed(data, element, value.start)
    if element == "string":
        return _text(data[value.start : value.end], capacity, version, value.start)
    if element == "bytes":
        raw = data[value.start : value.end]
        if len(raw) > capacity or (version == "1.0" and len(raw) != capacity):
            exactly = "exactly " if version == "1.0" else "at most "
            raise ValueError(f"is {len(raw)} bytes; its capacity takes {exactly}{capacity}")
        return raw
    return _number(data, value.start, element, listed, "its value")


def _fixed(data: bytes, element: str, pos: int) -> float:
    layout = _DOUBLE if element == "double" else _FLOAT
    return float(layout.unpack_from(data, pos)[0])


def _number(data: bytes, pos: int, element: str, listed: bool, what: str) -> int | bool:
    """The varint at ``pos`` as both protobuf and Proton's C library read an ``element``, or a
    ``ValueError`` where they would not agree. nanopb reads every varint into 64 bits and an
    ``int32`` field's as its low 32 bits, as protobuf truncates it, but a ``uint32`` field's only
    below 2**32; a ``bool``, and a 1.0 list's ``int32``/``uint32`` item (protonc's callbacks),
    through ``pb_decode_varint32``, which refuses bits past 32 but for a sign extension."""
    value, _ = read_varint(data, pos)
    if value >= _UINT64:
        raise ValueError(f"{what} ({value}) does not fit 64 bits")
    if element == "bool" or (listed and element in ("int32", "uint32")):
        narrow = _varint32(data, pos)
        if narrow is None:
            raise ValueError(
                f"{what} ({value}) has bits past 32: Proton's C library reads a {element} "
                f"{'item ' if listed and element != 'bool' else ''}with pb_decode_varint32, "
                "which refuses it"
            )
        if element == "bool":
            return narrow != 0
        value = narrow
    if element == "uint32" and value > _UINT32_MAX:
        raise ValueError(f"{what} is {value}, out of uint32's range 0..{_UINT32_MAX}")
    if element == "int32":
        value &= _UINT32_MAX
        return value - (1 << 32) if value >> 31 else value
    if element == "int64":
        return value - _UINT64 if value >> 63 else value
    return value


def _varint32(data: bytes, pos: int) -> int | None:
    """The value nanopb's ``pb_decode_varint32`` reads from the varint at ``pos`` (which
    ``read_varint`` has found well-formed), or ``None`` where it reports "varint overflow":
    bits 32..34 must be clear, or bits 31..34 set, and every later byte zero or, after a set
    bit 31, a sign extension (0xff, the tenth 0x01)."""
    byte = data[pos]
    result, bitpos = byte & 0x7F, 7
    while byte & 0x80:
        pos += 1
        byte = data[pos]
        if bitpos >= 32:
            extension = 0xFF if bitpos < 63 else 0x01
            if (byte & 0x7F) != 0 and not (result >> 31 and byte == extension):
                return None
        elif bitpos == 28:
            if byte & 0x70 and byte & 0x78 != 0x78:
                return None
            result |= (byte & 0x0F) << 28
        else:
            result |= (byte & 0x7F) << bitpos
        bitpos += 7
    return result


def _id(data: bytes, pos: int, what: str) -> int:
    """A bundle's or signal's id: a ``uint32`` (nanopb refuses one past 32 bits)."""
    value, _ = read_varint(data, pos)
    if value > _UINT32_MAX:
        raise DecodeError(f"{what} is {value}, out of uint32's range 0..{_UINT32_MAX}")
    return value


def _text(raw: bytes, capacity: int, version: Version, offset: int) -> str:
    """A string's wire bytes as the C registry reads them: up to its NUL (2.0), all (1.0)."""
    if version == "2.0":
        if len(raw) > capacity:
            raise ValueError(f"is {len(raw)} bytes with its NUL, over its capacity of {capacity}")
        cut = raw.find(b"\0")
        if cut < 0:
            raise ValueError(
                "lacks its terminating NUL (Proton 2.0 sends strlen + 1 bytes; its C registry "
                "would hold this one unterminated)"
            )
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
