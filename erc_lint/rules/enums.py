"""Rules on enums that exist in both revisions (or were renamed or moved): their values one number
at a time (with ``allow_alias`` a number has several names, and what travels is the number), and
what the enum does with a number it does not declare."""

from .._model import Enum
from .._pairing import Change, NumberPair, Paired
from ._registry import Report, Reports, enum_number_rule, enum_rule


@enum_number_rule("ENUM_VALUE_RENUMBERED", "An enum value kept its name but changed number.")
def renumbered(number: NumberPair, change: Change) -> Reports:
    """## What it does
    Reports each name of an OLD enum number that NEW gives to another number.

    ## Why is this bad?
    An enum value travels as its number. Senders built from OLD keep sending the old number for
    this value, which a receiver built from NEW reads as another value, or as an undeclared one
    (nanopb and proto3 keep the bare number; erc_codec refuses to encode it); receivers built
    from OLD misread new senders the same way.

    ## Example
    Before:
    ```proto
    enum DriveMode {
      DRIVE_MODE_IDLE = 0;
      DRIVE_MODE_RUN = 1;
    }
    ```
    After:
    ```proto
    enum DriveMode {
      DRIVE_MODE_IDLE = 0;
      DRIVE_MODE_RUN = 2;
    }
    ```

    ## Use instead
    Keep the number (`DRIVE_MODE_RUN = 1;`); a value that needs another number is a new value
    with a new name.
    """
    for name, now in number.moved.items():
        yield Report(
            number.new_owner.by_name[name].location,
            f'Enum value "{name}" on enum "{number.new_owner.name}" changed number from '
            f'"{number.old.number}" to "{now}".',
        )


@enum_number_rule(
    "ENUM_VALUE_REUSED", "An enum number now names another value while its old one moved."
)
def reused(number: NumberPair, change: Change) -> Reports:
    """## What it does
    Reports an enum number that NEW gives to another value while the names it had in OLD moved
    to other numbers (or some moved and the rest are gone): the number means something else now.

    ## Why is this bad?
    Senders built from OLD still send the number for the old value, and a receiver built from
    NEW acts on it as the new value (a "run" read as "stop"), with nothing on the wire to tell
    the two apart.

    ## Example
    Before:
    ```proto
    enum DriveMode {
      DRIVE_MODE_IDLE = 0;
      DRIVE_MODE_RUN = 1;
    }
    ```
    After:
    ```proto
    enum DriveMode {
      DRIVE_MODE_IDLE = 0;
      DRIVE_MODE_STOP = 1;
      DRIVE_MODE_RUN = 2;
    }
    ```

    ## Use instead
    Keep every old value at its number and give the new one a number never used:
    `DRIVE_MODE_RUN = 1; DRIVE_MODE_STOP = 2;`.
    """
    # Judged per number: a name the number had before (an alias) still names it, or none of its
    # names moved elsewhere (a rename), and the number means what it did.
    taken = number.by_number
    if taken is None or set(number.after) & set(number.before) or not number.moved:
        return
    now = ", ".join(f'"{name}" is now "{at}"' for name, at in number.moved.items())
    yield Report(
        taken.location,
        f'Enum value "{taken.number}" on enum "{number.new_owner.name}" changed from '
        f"{_quoted(number.before)} to {_quoted(number.after)}, and {now}.",
    )


@enum_number_rule("ENUM_VALUE_DELETED", "An enum number disappeared without being reserved.")
def deleted(number: NumberPair, change: Change) -> Reports:
    """## What it does
    Reports an enum number that NEW no longer has, none of whose names moved to another number,
    while NEW does not reserve it.

    ## Why is this bad?
    Boards built from OLD keep sending the number, which receivers built from NEW hold as an
    undeclared value that no code handles (and erc_codec refuses to send). Once the number is
    free, the next change may give it to another value, and receivers then read those boards'
    number as that value.

    ## Example
    Before:
    ```proto
    enum DriveMode {
      DRIVE_MODE_IDLE = 0;
      DRIVE_MODE_RUN = 1;
    }
    ```
    After:
    ```proto
    enum DriveMode {
      DRIVE_MODE_IDLE = 0;
    }
    ```

    ## Use instead
    Reserve the number and its names: `reserved 1; reserved "DRIVE_MODE_RUN";`, or restore the
    value.
    """
    new = number.new_owner
    moved = any(name in new.by_name for name in number.before)
    if number.by_number is None and not moved and not new.reserved.covers(number.old.number):
        yield Report(
            number.old.location,
            f'Previously present enum value "{number.old.number}" with {_names(number.before)} '
            f'on enum "{new.name}" was deleted without reserving its number.',
            in_old=True,
            fix=f"reserve {number.old.number} or restore the value",
            container=new.location,
        )


@enum_number_rule(
    "ENUM_VALUE_RENAMED",
    "An enum number kept its meaning under a new name: harmless on the wire, breaks code.",
    severity="warning",
    errors_in=("WIRE_JSON",),
)
def renamed(number: NumberPair, change: Change) -> Reports:
    """## What it does
    Reports an enum number that kept its meaning while one or more of its OLD names are gone
    (renamed, or an alias dropped).

    ## Why is this bad?
    The binary wire is unchanged, so this is a warning. But protobuf JSON sends enum values by
    name, so a JSON reader built from one revision rejects the other's name, and every program
    and generated header that uses the old name stops compiling.

    ## Example
    Before:
    ```proto
    enum DriveMode {
      DRIVE_MODE_IDLE = 0;
      DRIVE_MODE_RUN = 1;
    }
    ```
    After:
    ```proto
    enum DriveMode {
      DRIVE_MODE_IDLE = 0;
      DRIVE_MODE_DRIVE = 1;
    }
    ```

    ## Use instead
    Keep the old name beside the new one as an alias:
    `option allow_alias = true; DRIVE_MODE_RUN = 1; DRIVE_MODE_DRIVE = 1;`. With `WIRE_JSON` in
    `use` it is an error.
    """
    taken, by_name = number.by_number, number.new_owner.by_name
    if taken is None or all(name in by_name for name in number.before):
        return  # gone (ENUM_VALUE_DELETED), or every name is still there
    if number.moved and not set(number.after) & set(number.before):
        return  # another value took the number: ENUM_VALUE_REUSED
    yield Report(
        taken.location,
        f'Enum value "{taken.number}" on enum "{number.new_owner.name}" changed name from '
        f"{_quoted(number.before)} to {_quoted(number.after)}.",
    )


@enum_rule("ENUM_OPENNESS_CHANGED", "An enum changed between open and closed.")
def openness_changed(pair: Paired[Enum], change: Change) -> Reports:
    """## What it does
    Reports an enum that changed between open and closed: proto2 enums are closed, proto3 enums
    open, and editions choose with `features.enum_type` (moving a file between syntaxes moves
    its enums too).

    ## Why is this bad?
    The two read a number the enum does not declare differently. An open enum keeps it as the
    field's value; a closed one puts the whole field among the message's unknown fields, so the
    field reads as absent (its default) and, repeated, loses that element. Once a sender built
    with a newer enum sends a value this one lacks, receivers built from OLD and from NEW act on
    different values.

    ## Example
    Before:
    ```proto
    edition = "2023";
    enum Gear {
      GEAR_NEUTRAL = 0;
      GEAR_LOW = 1;
    }
    ```
    After:
    ```proto
    edition = "2023";
    enum Gear {
      option features.enum_type = CLOSED;
      GEAR_NEUTRAL = 0;
      GEAR_LOW = 1;
    }
    ```

    ## Use instead
    Keep the enum's openness: in an editions file, set `features.enum_type` to what the enum had
    (`CLOSED` for an enum from proto2, `OPEN` from proto3).
    """
    old, new = pair
    if old.closed != new.closed:
        yield Report(
            new.location, f'Enum "{new.name}" changed from {_openness(old)} to {_openness(new)}.'
        )


def _openness(enum: Enum) -> str:
    return "closed" if enum.closed else "open"


def _quoted(names: list[str]) -> str:
    return ", ".join(f'"{name}"' for name in names)


def _names(names: list[str]) -> str:
    return f"name {_quoted(names)}" if len(names) == 1 else f"names {_quoted(names)}"
