"""The fixed-size contract, checked on values just before they are sent.

A message can be valid protobuf and still be one a nanopb receiver drops or misreads: an enum value
the schema does not declare (proto3 enums are open in Python), a string or bytes value longer than
its ``max_size``, more repeated items than ``max_count``, an integer wider than its ``int_size``, a
string holding a NUL (nanopb stores strings NUL-terminated: it would arrive cut there; a map's
keys as much as its values),
``fixed_length`` bytes not exactly ``max_size`` long or a ``fixed_count`` field without exactly
``max_count`` items (nanopb: "incorrect fixed length bytes size", "wrong size for fixed count
field"), an unset proto2 ``required`` field (nanopb: "missing required field"), a set group
field nanopb leaves out (``FT_IGNORE``, ``discard_deprecated``): its decoder skips what it
ignores, but ``pb_skip_field`` cannot skip a group ("invalid wire_type"). Any other field nanopb
leaves out is sent as protobuf writes it, and nanopb's decoder skips it: the board drops its
value, and takes the rest.
``contract(sizes, descriptor)`` returns how to check a payload type: an exact check that raises
``EncodeError`` naming the field path, and a cheap screen deciding whether to run it.

It runs on every encode. A type whose exact check reads only a few fields has no screen. Larger
types get one: a regular expression over the serialized payload that matches wherever an enum
field's tag is followed by a value the enum does not declare. Every undeclared value makes it match
(a tag and its value are adjacent bytes, at any depth of nesting); float or integer bytes that
happen to look like an enum tag can too, and then the exact check merely runs for nothing.

The exact check is straight-line Python compiled once per message type (as dataclasses and
protobuf's own pure-Python runtime do): each submessage fetched once, all of its enum fields tested
in one ``if``, and it names the field that is wrong by its full path from the payload type:
``LimitsRecord.points[1].colour``, a map's value by its key as JSON writes it
(``LimitsRecord.palette[key=1]``). The path is only put together when something is wrong: a check
takes the path of the message it checks (``p``, the type's name by default), and an item that is
a message is checked with its own path. Strings, bytes, repeated fields and ``int_size`` leave no
trace the screen could see, so a type that has them has no screen.

Whether a screen pays is a matter of cost: scanning the bytes costs about as much as reading
four fields, and the scan finds tag-like bytes inside other values (a float's four bytes are any
four bytes) more often the more such bytes the type holds, each time running the check for
nothing. A type gets a screen only where the reads it expects to save outweigh the scan.

``sender`` puts the default form of encode for one payload type into one compiled function:
serialize, check (the exact check's lines inline, or screen then check), prepend the member's
tag-and-length header and strip the trailing zeros.

The tricks serve one target, the encode ratio of ``benchmarks/bench_codec.py`` (wrap, check and
serialize in at most twice the bare serialization); ``tests/codec/test_contract.py`` holds the
compiled check to a plain recursive reading of the same rules, the screen to never missing what that
plain check refuses, and the sender to the plain encode path.
"""

import keyword
import re
from collections.abc import Callable, Iterator, Mapping, Sequence
from operator import attrgetter
from typing import Any, NamedTuple

from google.protobuf.descriptor import Descriptor, FieldDescriptor
from google.protobuf.descriptor_pb2 import FieldDescriptorProto
from google.protobuf.message import Message

from erc_schema import EncodeError, SchemaError, Sizes, encode_varint, enum_of, message_of

from ._fieldpaths import entry_path

__all__ = ["Contract", "contract", "sender"]

Check = Callable[..., None]  # check(message, path=its type's full name)
_T = FieldDescriptor


class Contract(NamedTuple):
    """How to check one payload type: ``if screen is None or screen(body): check(message)``.
    ``lines`` and ``names`` are the exact check's body and the constants it refers to, for
    ``sender`` to compile inline."""

    screen: Callable[[bytes], object] | None
    check: Check
    lines: tuple[str, ...] = ()
    names: Mapping[str, Any] = {}


# The costs a screen is weighed by, in enum-field reads (about 45 ns each in upb): reading a
# submessage costs three, a regular-expression scan of a payload about four.
_SUBMESSAGE_READ = 3
_SCAN = 4
# The bytes of a value each scalar type can hold anything in (a varint at its longest).
_ANY_BYTES = {
    **dict.fromkeys((_T.TYPE_FLOAT, _T.TYPE_FIXED32, _T.TYPE_SFIXED32), 4),
    **dict.fromkeys((_T.TYPE_DOUBLE, _T.TYPE_FIXED64, _T.TYPE_SFIXED64), 8),
    **dict.fromkeys((_T.TYPE_UINT32, _T.TYPE_SINT32), 5),
    **dict.fromkeys((_T.TYPE_INT32, _T.TYPE_INT64, _T.TYPE_UINT64, _T.TYPE_SINT64), 10),
    _T.TYPE_BOOL: 1,
}


def contract(sizes: Sizes, descriptor: Descriptor) -> Contract | None:
    """The contract check of a payload type; ``None`` when no value of it can break the contract."""
    source = _Source(sizes)
    body = source.message(descriptor, "m", "")
    if not body:
        return None
    namespace = _namespace(descriptor, source)
    check = _compile(namespace, body)
    tags: dict[bytes, set[bytes]] = {}
    noise = _enum_tags(sizes, descriptor, tags)
    if noise is None or not _screen_pays(source.cost, len(tags), noise):
        return Contract(None, check, tuple(body), namespace)
    alternatives = [re.escape(tag) + _not_followed_by(valid) for tag, valid in sorted(tags.items())]
    return Contract(re.compile(b"|".join(alternatives)).search, check)


def _screen_pays(cost: int, tags: int, noise: int) -> bool:
    """Whether scanning first is cheaper on average than always running a check of ``cost``,
    for a type with ``tags`` enum tags and ``noise`` bytes where other values can look like
    them: the scan finds a tag by chance with a probability of 1 - (1 - tags/256)^noise."""
    chance = 1 - (1 - tags / 256) ** noise
    return _SCAN + chance * cost < cost


def _enum_tags(sizes: Sizes, descriptor: Descriptor, tags: dict[bytes, set[bytes]]) -> int | None:
    """Collect tag → declared value encodings of every enum field below ``descriptor``, and
    count the bytes where the values of other fields could hold anything.

    A tag shared by several enum fields keeps only the encodings all of them declare. Returns
    ``None`` when some field's validity cannot be seen in the bytes (see the module's docstring).
    """
    noise = 0
    for field in descriptor.fields:
        if sizes.ignored(field):
            if field.type == _T.TYPE_GROUP:
                return None  # a set one is refused: nothing of it the screen could see
            continue
        if (
            field.is_repeated
            or sizes.repeated(field)
            or field.type in (_T.TYPE_STRING, _T.TYPE_BYTES)
            or sizes.int_range(field) is not None
            or sizes.required(field)
        ):
            return None
        if field.type == _T.TYPE_ENUM:
            valid = {encode_varint(value.number) for value in enum_of(field).values}
            tag = encode_varint(field.number << 3)
            tags[tag] = tags[tag] & valid if tag in tags else valid
        elif field.type == _T.TYPE_MESSAGE:
            inner = _enum_tags(sizes, message_of(field), tags)
            if inner is None:
                return None
            noise += inner
        else:
            noise += _ANY_BYTES.get(field.type, 10)
    return noise


def _not_followed_by(valid: set[bytes]) -> bytes:
    """A pattern for one byte, or more, that cannot start any of the ``valid`` encodings."""
    if all(len(encoding) == 1 for encoding in valid):
        return b"[^" + b"".join(re.escape(encoding) for encoding in sorted(valid)) + b"]"
    return b"(?!" + b"|".join(map(re.escape, sorted(valid))) + b")"


def checker(sizes: Sizes, descriptor: Descriptor) -> Check | None:
    """A function raising ``EncodeError`` when a ``descriptor`` message breaks the contract."""
    source = _Source(sizes)
    body = source.message(descriptor, "m", "")
    return _compile(_namespace(descriptor, source), body) if body else None


def sender(
    rules: Contract | None, serialize: Callable[[Message], bytes], headers: Sequence[bytes]
) -> Callable[[Message], bytes]:
    """``send(message)``: the stripped datagram of a payload, ``headers[n]`` being the member's
    tag and length for an ``n``-byte payload. It raises what the check raises; ``IndexError``
    when the payload is too long for the datagram, ``google.protobuf.message.EncodeError`` when
    protobuf refuses to serialize it: the plain path of encode says those in its own words."""
    namespace: dict[str, Any] = {"serialize": serialize, "headers": headers}
    lines = ["def send(m):", " body = serialize(m)"]
    if rules is not None and rules.screen is None:  # the check's lines, whose path p is top
        namespace.update(rules.names)
        lines = ["def send(m, p=top):", lines[1], *rules.lines]
    elif rules is not None:
        namespace.update(screen=rules.screen, check=rules.check)
        lines.append(" if screen(body): check(m)")
    # in_form(datagram, "strip", ...) written inline: the one call a payload's encode makes
    # (bench_codec's encode target), held to the plain path by tests/codec/test_contract.py.
    lines.append(' return (headers[len(body)] + body).rstrip(b"\\0")')
    exec("\n".join(lines), namespace)  # our own generated code
    return namespace["send"]  # type: ignore[no-any-return]


def _required_check(sizes: Sizes, descriptor: Descriptor) -> Check | None:
    """A check that every field nanopb requires (proto2 ``required``, or ``label_override``
    ``LABEL_REQUIRED``) is sent, in the message and in each submessage it holds (a submessage
    that is absent is sent as nothing, so is not asked). A required field that protobuf
    repeats is the count check's (exactly one item)."""
    wanted: dict[str, list[FieldDescriptor]] = {}  # message full name -> its required fields
    pending, seen = [descriptor], {descriptor.full_name}
    while pending:
        message = pending.pop()
        for field in message.fields:
            if sizes.ignored(field):
                continue
            if sizes.required(field) and not field.is_repeated:
                wanted.setdefault(message.full_name, []).append(field)
            sub = field.message_type
            if sub is not None and sub.full_name not in seen:
                seen.add(sub.full_name)
                pending.append(sub)
    if not wanted:
        return None

    def check(root: Message, top: str) -> None:
        stack: list[tuple[Message, str]] = [(root, top)]
        while stack:
            message, path = stack.pop()
            for field in wanted.get(message.DESCRIPTOR.full_name, ()):
                if not _sent(message, field):
                    raise EncodeError(f"{path}.{field.name} is {_why_required(field)}")
            stack.extend(_submessages(message, path))

    return check


def _sent(message: Message, field: FieldDescriptor) -> bool:
    """Whether protobuf writes single field ``field`` of ``message``: set, if it has presence;
    else holding other than its default (proto3 sends no default)."""
    if field.has_presence:
        return message.HasField(field.name)
    return any(listed.number == field.number for listed, _ in message.ListFields())


def _why_required(field: FieldDescriptor) -> str:
    if field.is_required:
        return "required (proto2) but not set"
    if field.has_presence:
        return "required (nanopb label_override) but not set"
    return "required (nanopb label_override) but holds its default, which protobuf does not send"


def _submessages(message: Message, path: str) -> Iterator[tuple[Message, str]]:
    """The submessages ``message`` holds (repeated ones and map values too), with their paths."""
    for field, value in message.ListFields():
        if field.message_type is None:
            continue
        here = f"{path}.{field.name}"
        if field.message_type.GetOptions().map_entry:
            for key, item in value.items():
                if isinstance(item, Message):
                    yield item, entry_path(here, key)
        elif field.is_repeated:
            for j, item in enumerate(value):
                yield item, f"{here}[{j}]"
        else:
            yield value, here


def _compile(namespace: Mapping[str, Any], body: list[str]) -> Check:
    """The check function of ``body``, lines a ``_Source`` emitted, whose constants
    ``namespace`` holds: ``check(m, p)``, ``p`` the path of ``m`` (by default its type's full
    name)."""
    scope = dict(namespace)
    exec("\n".join(["def check(m, p=top):", *body]), scope)  # our own generated code
    return scope["check"]  # type: ignore[no-any-return]


def _namespace(descriptor: Descriptor, source: "_Source") -> dict[str, Any]:
    """The constants the lines ``source`` emitted refer to, with the function naming a wrong
    enum value and the default path."""
    enums = source.enums

    def fail(message: Message, prefix: str) -> None:
        for path, allowed, enum_name in enums:
            value = attrgetter(path)(message)
            if value not in allowed:
                raise EncodeError(
                    f"{prefix}.{path} = {value} is not a declared value of {enum_name}"
                )

    return {"fail": fail, "top": descriptor.full_name, **source.names}


class _Source:
    """Emits the lines of a check function, and the constants those lines refer to."""

    def __init__(self, sizes: Sizes) -> None:
        self._sizes = sizes
        self.names: dict[str, Any] = {}
        self.enums: list[tuple[str, frozenset[int], str]] = []
        self.cost = 0  # what the emitted check's reads cost, in enum-field reads
        self._variables = 0

    def message(self, descriptor: Descriptor, var: str, prefix: str) -> list[str]:
        lines: list[str] = []
        if not prefix:  # the top: one walk checks required fields at every depth
            required = _required_check(self._sizes, descriptor)
            if required is not None:
                lines.append(f" {self._name(required)}({var}, p)")
                self.cost += 1
        tests: list[str] = []
        for field in descriptor.fields:
            if self._sizes.ignored(field):
                lines += self._unskippable(field, var, prefix)
                continue
            mismatch = self._sizes.wire_mismatch(field)
            if mismatch is not None:
                raise SchemaError(
                    f"{field.full_name}: {mismatch}; erc-codec cannot send it as nanopb reads it"
                )
            path = prefix + field.name
            read = (
                f"getattr({var}, {field.name!r})"
                if keyword.iskeyword(field.name)
                else f"{var}.{field.name}"
            )
            if (
                field.is_repeated
                or field.type in (_T.TYPE_STRING, _T.TYPE_BYTES)
                or self._sizes.int_range(field) is not None
            ):
                check = _field_check(self._sizes, field, path)
                call = f"{self._name(check)}({read}, p)"
                sent = _sent_when(self._sizes, field, var, read)
                lines.append(f" if {sent}: {call}" if sent else f" {call}")
                self.cost += 1
            elif field.type == _T.TYPE_ENUM:
                allowed = frozenset(value.number for value in enum_of(field).values)
                self.enums.append((path, allowed, enum_of(field).full_name))
                tests.append(f"{read} not in {self._name(allowed)}")
                self.cost += 1
            elif field.type == _T.TYPE_MESSAGE:
                self._variables += 1
                inner = f"v{self._variables}"
                nested = self.message(message_of(field), inner, path + ".")
                if nested:
                    lines += [f" {inner} = {read}", *nested]
                    self.cost += _SUBMESSAGE_READ
        if tests:
            lines.insert(0, f" if {' or '.join(tests)}: fail(m, p)")
        return lines

    def _unskippable(self, field: FieldDescriptor, var: str, prefix: str) -> list[str]:
        """For a field nanopb leaves out, the line refusing it set if it is a group (nanopb's
        decoder skips what it ignores with ``pb_skip_field``, which answers a group "invalid
        wire_type"); none for any other, which the board drops."""
        if field.type != _T.TYPE_GROUP:
            return []
        deprecated = self._sizes.options(field).discard_deprecated and field.GetOptions().deprecated
        why = "discard_deprecated" if deprecated else "FT_IGNORE"  # on it, or on its oneof
        path = prefix + field.name

        def refuse(top: str) -> None:
            raise EncodeError(
                f"{top}.{path} is set, but it is a group nanopb leaves out ({why}), which its "
                "decoder cannot skip: it refuses the whole message (invalid wire_type)"
            )

        self.cost += 1
        present = f"{var}.{field.name}" if field.is_repeated else f"{var}.HasField({field.name!r})"
        return [f" if {present}: {self._name(refuse)}(p)"]

    def _name(self, value: object) -> str:
        name = f"c{len(self.names)}"
        self.names[name] = value
        return name


def _sent_when(sizes: Sizes, field: FieldDescriptor, var: str, read: str) -> str | None:
    """The condition a single field's value is checked under, where it is checked only when
    sent (``None``: always): ``fixed_length`` bytes with presence, whose unset value (``b""``)
    is sent as nothing; a string or bytes field with no room for any value (``_no_room``),
    when set or, without presence, when not empty (protobuf sends no empty value)."""
    if field.is_repeated or field.type not in (_T.TYPE_STRING, _T.TYPE_BYTES):
        return None
    limit = sizes.max_bytes(field)
    fixed = sizes.field_type(field) == _T.TYPE_BYTES and bool(sizes.options(field).fixed_length)
    if field.has_presence and (fixed or (limit is not None and limit < 0)):
        return f"{var}.HasField({field.name!r})"
    return read if limit is not None and limit < 0 else None


def _field_check(sizes: Sizes, field: FieldDescriptor, path: str) -> Callable[[Any, str], None]:
    """Check the value of one repeated, string, bytes or int_size field at ``path`` below the
    message whose path a call gives."""
    element = _element_check(sizes, field)
    if not field.is_repeated:
        return lambda value, prefix: element(value, f"{prefix}.{path}")
    if sizes.repeated(field):
        count = sizes.max_count(field)
        fixed = count is not None and bool(sizes.options(field).fixed_count)
        limit, need = f"its max_count {count}", "fixed_count needs"
    else:  # label_override: nanopb holds one value (a required one exactly one)
        count, fixed = 1, sizes.required(field)
        limit, need = "the one nanopb holds (label_override)", "label_override REQUIRED needs"
    key = _key_check(sizes, field)

    def check(value: Any, prefix: str) -> None:
        where = f"{prefix}.{path}"
        if count is not None and len(value) > count:
            raise EncodeError(f"{where} holds {len(value)} items, more than {limit}")
        if fixed and len(value) != count:
            raise EncodeError(f"{where} holds {len(value)} items; {need} exactly {count}")
        if isinstance(value, Mapping):
            for name, item in value.items():
                if key is not None:
                    key(name, f"{where} key {name!r}")
                element(item, entry_path(where, name))
        else:
            for index, item in enumerate(value):
                element(item, f"{where}[{index}]")

    return check


def _key_check(sizes: Sizes, field: FieldDescriptor) -> Callable[[Any, str], None] | None:
    """The check of a map's keys, ``None`` where no key can break the contract. A key is a
    nanopb field of its own: a string key has its ``max_size`` or ``max_length`` (nanopb's
    decoder: "string overflow") and no NUL (it would arrive cut there), an integer key its
    ``int_size``."""
    entry = field.message_type
    if entry is None or not entry.GetOptions().map_entry:
        return None
    key = entry.fields_by_name["key"]
    if key.type != _T.TYPE_STRING and sizes.int_range(key) is None:
        return None
    return _element_check(sizes, key)


def _element_check(sizes: Sizes, field: FieldDescriptor) -> Callable[[Any, str], None]:
    """Check one item of a repeated field (a map's value), or the value of a single field."""
    if field.message_type is not None and field.message_type.GetOptions().map_entry:
        field = field.message_type.fields_by_name["value"]
    if field.type == _T.TYPE_ENUM:
        return _enum_item(field)
    if field.type in (_T.TYPE_STRING, _T.TYPE_BYTES):
        limit = sizes.max_bytes(field)
        kind = sizes.field_type(field)  # as nanopb types it: a type_override decides
        # fixed_length bytes without presence too: protobuf sends b"" as nothing, which nanopb
        # reads as max_size zeros (and sends as such), not as the b"" that was meant.
        exact = kind == _T.TYPE_BYTES and bool(sizes.options(field).fixed_length)
        return _sized_item(limit, kind == _T.TYPE_STRING, exact)
    bounds = sizes.int_range(field)
    if bounds is not None:
        reason = (
            "nanopb int_size"
            if sizes.options(field).int_size
            else "nanopb's type_override " + FieldDescriptorProto.Type.Name(sizes.field_type(field))  # type: ignore[arg-type]
        )
        return _ranged_item(*bounds, reason)
    if field.type == _T.TYPE_MESSAGE:
        nested = checker(sizes, message_of(field))
        if nested is not None:
            return nested  # nested(item, its path)
    return lambda value, path: None


def _enum_item(field: FieldDescriptor) -> Callable[[Any, str], None]:
    allowed = frozenset(value.number for value in enum_of(field).values)
    enum_name = enum_of(field).full_name

    def enum_item(value: Any, path: str) -> None:
        if value not in allowed:
            raise EncodeError(f"{path} = {value} is not a declared value of {enum_name}")

    return enum_item


def _sized_item(limit: int | None, text: bool, exact: bool = False) -> Callable[[Any, str], None]:
    """Check a string or bytes value (a ``str`` or ``bytes`` in Python, as declared) that nanopb
    holds as a string (``text``: NUL-terminated) or as bytes. A ``limit`` below zero leaves no
    room for any value sent (``_no_room``)."""
    if limit is not None and limit < 0:
        return _no_room(limit, text)

    def sized_item(value: Any, path: str) -> None:
        length = len(value.encode("utf-8")) if isinstance(value, str) else len(value)
        if limit is not None and length > limit:
            raise EncodeError(f"{path} is {length} bytes long, more than the {limit} allowed")
        if exact and length != limit:
            raise EncodeError(f"{path} is {length} bytes long; fixed_length needs exactly {limit}")
        nul = "\0" if isinstance(value, str) else b"\0"
        if text and nul in value:
            unit = "character" if isinstance(value, str) else "byte"
            raise EncodeError(
                f"{path} holds a NUL at {unit} {value.index(nul)}: nanopb stores strings "
                "NUL-terminated, so it would arrive cut there"
            )

    return sized_item


def _no_room(limit: int, text: bool) -> Callable[[Any, str], None]:
    """The check of a value sent where nanopb has no room for any: a string whose ``max_size``
    is 0 or less (``max_length`` -1 or less), bytes whose ``max_size`` is below 0. nanopb's
    generator takes the option and sizes the field from it; its C array then holds not even a
    string's NUL (``char a[0]``: nanopb's encoder answers "zero-length string", its decoder
    "string overflow" to any value, an empty one too) or has a negative size, which no C
    compiler takes."""
    size = limit + 1 if text else limit  # the max_size nanopb's generator uses
    why = (
        "nanopb: zero-length string"
        if text and size == 0
        else f"its C array, of {size} bytes, compiles nowhere"
    )

    def no_room(value: Any, path: str) -> None:
        raise EncodeError(
            f"{path} cannot be sent: nanopb's max_size {size} leaves no room for any value, "
            f"not even an empty one ({why})"
        )

    return no_room


def _ranged_item(low: int, high: int, reason: str) -> Callable[[Any, str], None]:
    def ranged_item(value: Any, path: str) -> None:
        if not low <= value <= high:
            raise EncodeError(f"{path} = {value} does not fit {reason} ({low}..{high})")

    return ranged_item
