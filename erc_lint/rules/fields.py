"""Rules on the fields of messages that exist in both revisions (or were renamed)."""

from collections.abc import Iterator

from erc_codec.schema import Location

from .._pairing import Change
from ._registry import pair_rule

Report = Iterator[tuple[Location, str, bool]]


@pair_rule("FIELD_RENUMBERED", "A field kept its name but changed number.")
def renumbered(change: Change) -> Report:
    for p in change.fields():
        if p.by_name is not None and p.by_name.number != p.old.number:
            yield (
                p.by_name.location,
                f'Field "{p.old.name}" on message "{p.new_owner.name}" changed number from '
                f'"{p.old.number}" to "{p.by_name.number}".',
                False,
            )


@pair_rule(
    "FIELD_NUMBER_REUSED",
    "A field number now carries another field: other name and type, or its old field moved.",
)
def number_reused(change: Change) -> Report:
    for p in change.fields():
        taken = p.by_number
        if taken is None or taken.name == p.old.name:
            continue
        if p.by_name is not None or not change.compatible(p.old, taken):
            yield (
                taken.location,
                f'Field "{p.old.number}" on message "{p.new_owner.name}" changed from '
                f'"{p.old.name}" ("{p.old.type}") to "{taken.name}" ("{taken.type}").',
                False,
            )


@pair_rule("FIELD_TYPE_CHANGED", "A field kept its number and name but not a wire-compatible type.")
def type_changed(change: Change) -> Report:
    for p in change.fields():
        taken = p.by_number
        if taken is not None and taken.name == p.old.name and not change.compatible(p.old, taken):
            yield (
                taken.location,
                f'Field "{p.old.number}" with name "{p.old.name}" on message "{p.new_owner.name}" '
                f'changed type from "{p.old.type}" to "{taken.type}".',
                False,
            )


@pair_rule("FIELD_DELETED", "A field number disappeared without being reserved.")
def deleted(change: Change) -> Report:
    for p in change.fields():
        gone = p.by_number is None and p.by_name is None
        if gone and not p.new_owner.reserved.covers(p.old.number):
            yield (
                p.old.location,
                f'Previously present field "{p.old.number}" with name "{p.old.name}" on '
                f'message "{p.new_owner.name}" was deleted without reserving its number.',
                True,
            )


@pair_rule("FIELD_CARDINALITY_CHANGED", "A field changed between singular, repeated and required.")
def cardinality_changed(change: Change) -> Report:
    for p in change.fields():
        taken = p.by_number
        if taken is None or not change.compatible(p.old, taken):
            continue
        if taken.cardinality != p.old.cardinality:
            yield (
                taken.location,
                f'Field "{p.old.number}" with name "{taken.name}" on message "{p.new_owner.name}" '
                f'changed cardinality from "{p.old.cardinality}" to "{taken.cardinality}".',
                False,
            )


@pair_rule("FIELD_ONEOF_CHANGED", "A field moved into, out of, or between oneofs.")
def oneof_changed(change: Change) -> Report:
    for p in change.fields():
        taken = p.by_number
        if taken is None or not change.compatible(p.old, taken) or taken.oneof == p.old.oneof:
            continue
        old_members, new_members = p.old_owner.oneof(p.old.oneof), p.new_owner.oneof(taken.oneof)
        if old_members and old_members == new_members:
            continue  # the oneof was renamed: same members, same wire
        if p.old.oneof is None:
            move = f'moved into oneof "{taken.oneof}"'
        elif taken.oneof is None:
            move = f'moved out of oneof "{p.old.oneof}"'
        else:
            move = f'moved from oneof "{p.old.oneof}" to oneof "{taken.oneof}"'
        yield (
            taken.location,
            f'Field "{p.old.number}" with name "{taken.name}" on message "{p.new_owner.name}" '
            f"{move}.",
            False,
        )


@pair_rule(
    "FIELD_RENAMED",
    "A field kept its number and type under a new name: fine on the wire, breaks JSON and code.",
    severity="warning",
)
def renamed(change: Change) -> Report:
    for p in change.fields():
        taken = p.by_number
        if taken is None or taken.name == p.old.name or p.by_name is not None:
            continue
        if change.compatible(p.old, taken):
            yield (
                taken.location,
                f'Field "{p.old.number}" on message "{p.new_owner.name}" changed name from '
                f'"{p.old.name}" to "{taken.name}".',
                False,
            )
