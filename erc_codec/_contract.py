"""The fixed-size contract, checked on values just before they are sent.

A message can be valid protobuf and still be one a nanopb receiver drops or misreads: an enum value
the schema does not declare (proto3 enums are open in Python), a string or bytes value longer than
its ``max_size``, more repeated items than ``max_count``, an integer wider than its ``int_size``, a
string holding a NUL (nanopb stores strings NUL-terminated: it would arrive cut there; a map's
keys as much as its values),
``fixed_length`` bytes not exactly ``max_size`` long or a ``fixed_count`` field without exactly
``max_count`` items (nanopb: "incorrect fixed length bytes size", "wrong size for fixed count
field"), an unset proto2 ``required`` field (nanopb: "missing required field").
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

Both tricks serve one target, the encode ratio of ``benchmarks/bench_codec.py`` (wrap, check and
serialize in at most twice the bare serialization); ``tests/test_contract.py`` holds the compiled
check to a plain recursive reading of the same rules, and the screen to never missing what that
plain check refuses.
"""

import keyword
import re
from collections.abc import Callable, Iterator, Mapping
from operator import attrgetter
from typing import Any, NamedTuple

from google.protobuf.descriptor import Descriptor, FieldDescriptor
from google.protobuf.descriptor_pb2 import FieldDescriptorProto
from google.protobuf.message import Message

from ._errors import EncodeError, SchemaError
from ._paths import entry_path
from .schema import Sizes, encode_varint, enum_of, message_of

__all__ = ["Contract", "contract"]

Check = Callable[..., None]  # check(message, path=its type's full name)
_T = FieldDescriptor


class Contract(NamedTuple):
    """How to check one payload type: ``if screen is None or screen(body): check(message)``."""

    screen: Callable[[bytes], object] | None
    check: Check


# Above this many attribute reads, screening the bytes first is cheaper than the exact check.
_SCREEN_ABOVE = 6


def contract(sizes: Sizes, descriptor: Descriptor) -> Contract | None:
    """The contract check of a payload type; ``None`` when no value of it can break the contract."""
    source = _Source(sizes)
    body = source.message(descriptor, "m", "")
    if not body:
        return None
    check = _compile(descriptor, source, body)
    tags: dict[bytes, set[bytes]] = {}
    if source.reads <= _SCREEN_ABOVE or not _enum_tags(sizes, descriptor, tags):
        return Contract(None, check)
    alternatives = [re.escape(tag) + _not_followed_by(valid) for tag, valid in sorted(tags.items())]
    return Contract(re.compile(b"|".join(alternatives)).search, check)


def _enum_tags(sizes: Sizes, descriptor: Descriptor, tags: dict[bytes, set[bytes]]) -> bool:
    """Collect tag → declared value encodings of every enum field below ``descriptor``.

    A tag shared by several enum fields keeps only the encodings all of them declare. Returns
    ``False`` when some field's validity cannot be seen in the bytes (see the module's docstring).
    """
    for field in descriptor.fields:
        if sizes.ignored(field):
            continue
        if (
            field.is_repeated
            or sizes.repeated(field)
            or field.type in (_T.TYPE_STRING, _T.TYPE_BYTES)
            or sizes.int_range(field) is not None
            or sizes.required(field)
        ):
            return False
        if field.type == _T.TYPE_ENUM:
            valid = {encode_varint(value.number) for value in enum_of(field).values}
            tag = encode_varint(field.number << 3)
            tags[tag] = tags[tag] & valid if tag in tags else valid
        elif field.type == _T.TYPE_MESSAGE and not _enum_tags(sizes, message_of(field), tags):
            return False
    return True


def _not_followed_by(valid: set[bytes]) -> bytes:
    """A pattern for one byte, or more, that cannot start any of the ``valid`` encodings."""
    if all(len(encoding) == 1 for encoding in valid):
        return b"[^" + b"".join(re.escape(encoding) for encoding in sorted(valid)) + b"]"
    return b"(?!" + b"|".join(map(re.escape, sorted(valid))) + b")"


def checker(sizes: Sizes, descriptor: Descriptor) -> Check | None:
    """A function raising ``EncodeError`` when a ``descriptor`` message breaks the contract."""
    source = _Source(sizes)
    body = source.message(descriptor, "m", "")
    return _compile(descriptor, source, body) if body else None


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


def _compile(descriptor: Descriptor, source: "_Source", body: list[str]) -> Check:
    """The check function whose lines ``source`` emitted as ``body``: ``check(m, p)``, ``p``
    the path of ``m`` (by default its type's full name)."""
    enums = source.enums

    def fail(message: Message, prefix: str) -> None:
        for path, allowed, enum_name in enums:
            value = attrgetter(path)(message)
            if value not in allowed:
                raise EncodeError(
                    f"{prefix}.{path} = {value} is not a declared value of {enum_name}"
                )

    namespace: dict[str, Any] = {"fail": fail, "top": descriptor.full_name, **source.names}
    exec("\n".join(["def check(m, p=top):", *body]), namespace)  # our own generated code
    return namespace["check"]  # type: ignore[no-any-return]


class _Source:
    """Emits the lines of a check function, and the constants those lines refer to."""

    def __init__(self, sizes: Sizes) -> None:
        self._sizes = sizes
        self.names: dict[str, Any] = {}
        self.enums: list[tuple[str, frozenset[int], str]] = []
        self.reads = 0  # attribute reads the emitted check makes
        self._variables = 0

    def message(self, descriptor: Descriptor, var: str, prefix: str) -> list[str]:
        lines: list[str] = []
        if not prefix:  # the top: one walk checks required fields at every depth
            required = _required_check(self._sizes, descriptor)
            if required is not None:
                lines.append(f" {self._name(required)}({var}, p)")
                self.reads += 1
        tests: list[str] = []
        for field in descriptor.fields:
            if self._sizes.ignored(field):
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
                if _checked_when_set(self._sizes, field):
                    lines.append(f" if {var}.HasField({field.name!r}): {call}")
                else:
                    lines.append(f" {call}")
                self.reads += 1
            elif field.type == _T.TYPE_ENUM:
                allowed = frozenset(value.number for value in enum_of(field).values)
                self.enums.append((path, allowed, enum_of(field).full_name))
                tests.append(f"{read} not in {self._name(allowed)}")
                self.reads += 1
            elif field.type == _T.TYPE_MESSAGE:
                self._variables += 1
                inner = f"v{self._variables}"
                nested = self.message(message_of(field), inner, path + ".")
                if nested:
                    lines += [f" {inner} = {read}", *nested]
                    self.reads += 1
        if tests:
            lines.insert(0, f" if {' or '.join(tests)}: fail(m, p)")
        return lines

    def _name(self, value: object) -> str:
        name = f"c{len(self.names)}"
        self.names[name] = value
        return name


def _checked_when_set(sizes: Sizes, field: FieldDescriptor) -> bool:
    """Whether a field's value is checked only when set: ``fixed_length`` bytes with presence,
    whose unset value (``b""``) is sent as nothing."""
    return (
        sizes.field_type(field) == _T.TYPE_BYTES
        and not field.is_repeated
        and field.has_presence
        and bool(sizes.options(field).fixed_length)
    )


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
    holds as a string (``text``: NUL-terminated) or as bytes."""

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


def _ranged_item(low: int, high: int, reason: str) -> Callable[[Any, str], None]:
    def ranged_item(value: Any, path: str) -> None:
        if not low <= value <= high:
            raise EncodeError(f"{path} = {value} does not fit {reason} ({low}..{high})")

    return ranged_item
