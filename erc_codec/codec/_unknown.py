"""The fields a decoded message carried that its schema does not know: numbers it lacks, and
numbers it knows arriving with another wire type (protobuf keeps both as unknown fields). A
sender and a receiver of different schemas show here, instead of in silently dropped values.

Found on demand, never by ``decode`` itself (its speed target, benchmarks/bench_codec.py): one
walk over the message's set fields, nested messages, lists and maps included. What keeps payloads
only counts the fields beside them by number, in a table of bounded size (``UnkeptFields``).
"""

from collections.abc import Iterable
from typing import NamedTuple

from google.protobuf import unknown_fields as _protobuf_unknown
from google.protobuf.message import Message

__all__ = [
    "MAX_UNKEPT_NUMBERS",
    "UnkeptFields",
    "UnknownField",
    "own_unknown_fields",
    "unknown_fields",
]

# Distinct field numbers an unkept table lists: a schema grows by a handful of fields, while a
# sender of random numbers would otherwise grow the table by every datagram it sends.
MAX_UNKEPT_NUMBERS = 256


class UnknownField(NamedTuple):
    """A field the schema does not know: where (``path``: the field path of the message holding
    it, ``""`` for the payload itself, and the envelope's name as the schema spells it,
    ``codec.root``, e.g. ``"PBEnvelope"``, for a field beside the payload, on the envelope
    itself), its field ``number`` and its ``wire_type`` (0 varint, 1 64-bit, 2 length-delimited,
    3/4 group, 5 32-bit)."""

    path: str
    number: int
    wire_type: int


class UnkeptFields:
    """Datagrams by the number of each field, unknown to the schema, that their envelope carried
    beside the payload, where only the payload is kept (``Dispatcher``, ``McapWriter``).

    ``counts`` lists the first ``MAX_UNKEPT_NUMBERS`` distinct numbers, in the order they came;
    a field of any other number is counted in ``unlisted``, once per datagram and number. So the
    sum of ``counts`` and ``unlisted`` is every (datagram, number) pair seen, in bounded memory.
    """

    __slots__ = ("counts", "unlisted")

    def __init__(self) -> None:
        self.counts: dict[int, int] = {}
        self.unlisted = 0

    def count(self, numbers: Iterable[int]) -> None:
        """Count one datagram that carried fields ``numbers`` (a number given twice counts once)."""
        counts = self.counts
        for number in dict.fromkeys(numbers):  # first come, first listed
            if number in counts:
                counts[number] += 1
            elif len(counts) < MAX_UNKEPT_NUMBERS:
                counts[number] = 1
            else:
                self.unlisted += 1


def unknown_fields(message: Message) -> tuple[UnknownField, ...]:
    """Every unknown field in ``message`` and the messages inside it, in field order."""
    found: list[UnknownField] = []
    _walk(message, "", found)
    return tuple(found)


def own_unknown_fields(message: Message, path: str) -> tuple[UnknownField, ...]:
    """The unknown fields of ``message`` itself, not of the messages inside it, at ``path``."""
    unknown = _protobuf_unknown.UnknownFieldSet(message)
    return tuple(
        UnknownField(path, unknown[i].field_number, unknown[i].wire_type)
        for i in range(len(unknown))
    )


def _walk(message: Message, path: str, found: list[UnknownField]) -> None:
    found += own_unknown_fields(message, path)
    for field, value in message.ListFields():
        if field.message_type is None:
            continue
        where = f"{path}.{field.name}" if path else field.name
        if field.message_type.GetOptions().map_entry:
            if field.message_type.fields_by_name["value"].message_type is not None:
                for key, item in value.items():
                    _walk(item, f"{where}[{key}]", found)
        elif field.is_repeated:
            for index, item in enumerate(value):
                _walk(item, f"{where}[{index}]", found)
        else:
            _walk(value, where, found)
