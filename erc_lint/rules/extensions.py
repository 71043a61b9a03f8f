"""Rules on extensions and extension ranges: what the field rules cannot say of them (an extension's
type, cardinality, number and name are judged by the field rules, as buf judges them)."""

from .._loader import relative
from .._model import Message
from .._pairing import Change, FieldPair, Paired
from ._registry import Report, Reports, field_rule, message_rule


@field_rule("EXTENSION_DELETED", "An extension disappeared without its number being reserved.")
def deleted(pair: FieldPair, change: Change) -> Reports:
    """## What it does
    Reports an extension of OLD that NEW no longer has, by number and by name, on the message
    it extended, while NEW does not declare the number reserved in its extension range. Not
    reported: an extension that became an ordinary field of the message with the same number,
    cardinality and a wire-compatible type (its bytes read as before), a custom option (an
    extension of `google.protobuf.FieldOptions` or another `*Options`: it annotates the
    descriptors, no datagram carries it; buf's WIRE rules pass it too), and an extension whose
    file no longer compiles (`COMPILE` reports it: what it declares is unknown, not gone).

    ## Why is this bad?
    Boards built from OLD keep setting the extension, and receivers built from NEW keep its
    bytes as unknown fields: the value is lost, as a deleted field's is. Worse, the number is
    free: the next change may declare another extension under it, of another type, and read
    those boards' bytes as its value.

    ## Example
    Before:
    ```proto
    syntax = "proto2";
    message Telemetry {
      extensions 100 to 199;
    }
    extend Telemetry {
      optional float coolant = 100;
    }
    ```
    After:
    ```proto
    syntax = "proto2";
    message Telemetry {
      extensions 100 to 199;
    }
    ```

    ## Use instead
    Keep the extension, or reserve its number in the range's declarations:
    `extensions 100 to 199 [declaration = { number: 100, reserved: true }];`.
    """
    old = pair.old
    if not old.extension or pair.by_number is not None or pair.by_name is not None:
        return
    if old.owner.startswith("google.protobuf.") and old.owner.endswith("Options"):
        return  # a custom option: it annotates descriptors, no message on the wire carries it
    if relative(change.old.root, old.source.path) in change.new.tree.failed:
        return  # its file no longer compiles: unknown in NEW, not gone (COMPILE says so)
    plain = pair.new_owner.fields.get(old.number)
    if plain is not None and plain.cardinality == old.cardinality and change.compatible(old, plain):
        return  # now an ordinary field with the same number and type: the same bytes
    if old.number not in pair.new_owner.reserved_extensions:
        yield Report(
            old.location,
            f'Previously present extension "{old.number}" with name "{old.name}" on message '
            f'"{pair.new_owner.name}" was deleted without reserving its number.',
            in_old=True,
            fix=f"reserve {old.number} in the extension range's declarations, or restore it",
            container=pair.new_owner.location,
        )


@message_rule("EXTENSION_RANGE_REMOVED", "An extension range, or part of it, was removed.")
def range_removed(pair: Paired[Message], change: Change) -> Reports:
    """## What it does
    Reports an extension range of a message (or any numbers of it) that NEW no longer declares,
    with the numbers that left it.

    ## Why is this bad?
    Extensions declared elsewhere (another board's files, another team's) may use those
    numbers: they no longer compile against NEW, and senders built with them keep sending
    values NEW's receivers cannot name. Once the numbers are out of the range, the next change
    may give them to ordinary fields, and those senders' bytes read as the new fields' values.

    ## Example
    Before:
    ```proto
    syntax = "proto2";
    message Telemetry {
      extensions 100 to 199;
    }
    ```
    After:
    ```proto
    syntax = "proto2";
    message Telemetry {
      extensions 100 to 149;
    }
    ```

    ## Use instead
    Keep the range (`extensions 100 to 199;`); extension ranges only ever grow.
    """
    old, new = pair
    for low, high in old.extension_ranges:
        missing = _uncovered(low, high, new.extension_ranges)
        if missing:
            removed = ",".join(f"[{a},{b}]" for a, b in missing)
            yield Report(
                new.location,
                f'Previously present extension range "[{low},{high}]" on message "{new.name}" is '
                f"missing values: {removed} were removed.",
            )


def _uncovered(low: int, high: int, ranges: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """The parts of ``low`` to ``high`` (inclusive) that no range of ``ranges`` covers."""
    missing, number = [], low
    for start, end in sorted(ranges):
        if end < number:
            continue
        if start > high:
            break
        if start > number:
            missing.append((number, start - 1))
        number = end + 1
        if number > high:
            return missing
    missing.append((number, high))
    return missing
