"""Rules on the values of enums that exist in both revisions (or were renamed)."""

from collections.abc import Iterator

from erc_codec._schema import Location

from .._pairing import Change
from ._registry import pair_rule

Report = Iterator[tuple[Location, str, bool]]


@pair_rule("ENUM_VALUE_RENUMBERED", "An enum value kept its name but changed number.")
def renumbered(change: Change) -> Report:
    for p in change.values():
        if p.by_name is not None and p.by_name.number != p.old.number:
            yield (
                p.by_name.location,
                f'Enum value "{p.old.name}" on enum "{p.new_owner.name}" changed number from '
                f'"{p.old.number}" to "{p.by_name.number}".',
                False,
            )


@pair_rule("ENUM_VALUE_REUSED", "An enum number now names another value while its old one moved.")
def reused(change: Change) -> Report:
    for p in change.values():
        taken = p.by_number
        moved = p.by_name is not None and p.by_name.number != p.old.number
        if taken is not None and taken.name != p.old.name and moved:
            yield (
                taken.location,
                f'Enum value "{p.old.number}" on enum "{p.new_owner.name}" changed from '
                f'"{p.old.name}" to "{taken.name}", and "{p.old.name}" is now '
                f'"{p.by_name.number if p.by_name else "gone"}".',
                False,
            )


@pair_rule("ENUM_VALUE_DELETED", "An enum number disappeared without being reserved.")
def deleted(change: Change) -> Report:
    for p in change.values():
        gone = p.by_number is None and p.by_name is None
        if gone and not p.new_owner.reserved.covers(p.old.number):
            yield (
                p.old.location,
                f'Previously present enum value "{p.old.number}" with name "{p.old.name}" on '
                f'enum "{p.new_owner.name}" was deleted without reserving its number.',
                True,
            )


@pair_rule(
    "ENUM_VALUE_RENAMED",
    "An enum number kept its meaning under a new name: harmless on the wire, breaks code.",
    severity="warning",
)
def renamed(change: Change) -> Report:
    for p in change.values():
        taken = p.by_number
        if taken is not None and taken.name != p.old.name and p.by_name is None:
            yield (
                taken.location,
                f'Enum value "{p.old.number}" on enum "{p.new_owner.name}" changed name from '
                f'"{p.old.name}" to "{taken.name}".',
                False,
            )
