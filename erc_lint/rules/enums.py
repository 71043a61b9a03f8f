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
        if taken is None or not moved:
            continue
        # An alias the number had before still names it: the number means what it did.
        if taken.name not in p.old_owner.names(p.old.number):
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
        if p.old != p.old_owner.values[p.old.number]:
            continue  # an alias: its number is judged once, with its first name
        names = p.old_owner.names(p.old.number)
        moved = any(name in p.new_owner.by_name for name in names)
        if p.by_number is None and not moved and not p.new_owner.reserved.covers(p.old.number):
            yield (
                p.old.location,
                f'Previously present enum value "{p.old.number}" with {_names(names)} on '
                f'enum "{p.new_owner.name}" was deleted without reserving its number.',
                True,
            )


@pair_rule(
    "ENUM_VALUE_RENAMED",
    "An enum number kept its meaning under a new name: harmless on the wire, breaks code.",
    severity="warning",
)
def renamed(change: Change) -> Report:
    seen: set[tuple[str, int]] = set()
    for p in change.values():
        taken = p.by_number
        if taken is None or p.by_name is not None or (p.new_owner.name, taken.number) in seen:
            continue
        seen.add((p.new_owner.name, taken.number))  # aliases: one finding per number
        before = p.old_owner.names(p.old.number)
        after = p.new_owner.names(taken.number)
        yield (
            taken.location,
            f'Enum value "{p.old.number}" on enum "{p.new_owner.name}" changed name from '
            f"{_quoted(before)} to {_quoted(after)}.",
            False,
        )


def _quoted(names: list[str]) -> str:
    return ", ".join(f'"{name}"' for name in names)


def _names(names: list[str]) -> str:
    return f"name {_quoted(names)}" if len(names) == 1 else f"names {_quoted(names)}"
