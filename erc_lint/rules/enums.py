"""Rules on the values of enums that exist in both revisions (or were renamed)."""

from collections.abc import Iterator
from typing import NamedTuple

from erc_codec.schema import Location

from .._model import Enum, EnumValue
from .._pairing import Change, MemberPair
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
    for number in _numbers(change):
        # Judged per number: a name the number had before (an alias) still names it, or none
        # of its names moved elsewhere (a rename), and the number means what it did.
        taken = number.pair.by_number
        if taken is None or set(number.after) & set(number.before) or not number.moved:
            continue
        now = ", ".join(f'"{name}" is now "{at}"' for name, at in number.moved.items())
        yield (
            taken.location,
            f'Enum value "{taken.number}" on enum "{number.pair.new_owner.name}" changed from '
            f"{_quoted(number.before)} to {_quoted(number.after)}, and {now}.",
            False,
        )


@pair_rule("ENUM_VALUE_DELETED", "An enum number disappeared without being reserved.")
def deleted(change: Change) -> Report:
    for number in _numbers(change):
        p = number.pair
        moved = any(name in p.new_owner.by_name for name in number.before)
        if p.by_number is None and not moved and not p.new_owner.reserved.covers(p.old.number):
            yield (
                p.old.location,
                f'Previously present enum value "{p.old.number}" with {_names(number.before)} on '
                f'enum "{p.new_owner.name}" was deleted without reserving its number.',
                True,
            )


@pair_rule(
    "ENUM_VALUE_RENAMED",
    "An enum number kept its meaning under a new name: harmless on the wire, breaks code.",
    severity="warning",
)
def renamed(change: Change) -> Report:
    for number in _numbers(change):
        taken, by_name = number.pair.by_number, number.pair.new_owner.by_name
        if taken is None or all(name in by_name for name in number.before):
            continue  # gone (ENUM_VALUE_DELETED), or every name is still there
        if number.moved and not set(number.after) & set(number.before):
            continue  # another value took the number: ENUM_VALUE_REUSED
        yield (
            taken.location,
            f'Enum value "{taken.number}" on enum "{number.pair.new_owner.name}" changed name '
            f"from {_quoted(number.before)} to {_quoted(number.after)}.",
            False,
        )


class _Number(NamedTuple):
    """One number of a paired enum: its first OLD value's pair, its names in OLD and in NEW (more
    than one with ``allow_alias``), and its OLD names that NEW has at another number."""

    pair: MemberPair[Enum, EnumValue]
    before: list[str]
    after: list[str]
    moved: dict[str, int]


def _numbers(change: Change) -> Iterator[_Number]:
    for p in change.values():
        if p.old != p.old_owner.values[p.old.number]:
            continue  # an alias: its number is judged once, with its first name
        before = p.old_owner.names(p.old.number)
        elsewhere = [p.new_owner.by_name.get(name) for name in before]
        moved = {v.name: v.number for v in elsewhere if v is not None and v.number != p.old.number}
        yield _Number(p, before, p.new_owner.names(p.old.number), moved)


def _quoted(names: list[str]) -> str:
    return ", ".join(f'"{name}"' for name in names)


def _names(names: list[str]) -> str:
    return f"name {_quoted(names)}" if len(names) == 1 else f"names {_quoted(names)}"
