"""Rules on whole messages and enums: deletions, renames, reservations, required fields, the
envelope's size. Each is handed one message or enum of OLD and its partner in NEW (or, for
deletions, none)."""

from typing import Any

from erc_schema import Location

from .._model import Message
from .._pairing import Change, Paired
from ._registry import Report, Reports, definition_rule, deleted_message_rule, message_rule


@deleted_message_rule("MESSAGE_DELETED", "A message disappeared.", severity="warning")
def deleted(message: Message, change: Change) -> Reports:
    """## What it does
    Reports a message of OLD that NEW no longer has, under its name or renamed (a message whose
    file no longer compiles is not deleted: `COMPILE` speaks of it).

    ## Why is this bad?
    No message name travels on the wire, so the deletion itself breaks no datagram: that is why
    this is a warning. The damage is in what still uses it: a field of its type elsewhere (then
    `FIELD_TYPE_CHANGED` or `COMPILE` reports an error), an envelope member a board still sends,
    and every program and generated header built against it.

    ## Example
    Before:
    ```proto
    message ArmBoardCalibration {
      float offset = 1;
    }
    ```
    After: the message is gone.

    ## Use instead
    Keep the message until nothing sends or uses it; when it goes, reserve the envelope member
    that carried it (`reserved 12; reserved "arm_calibration";`).
    """
    if not message.map_entry:  # a map entry goes with its map field, which the field rules report
        yield Report(
            message.location,
            f'Previously present message "{message.name}" was deleted.',
            in_old=True,
            container=_container_in_new(message, change),
        )


def _container_in_new(message: Message, change: Change) -> Location | None:
    """Where NEW has what held ``message``: its enclosing message, else its file (line 1)."""
    outer = message.name.rpartition(".")[0]
    while outer:
        if outer in change.new.messages:
            return change.new.messages[outer].location
        outer = outer.rpartition(".")[0]
    if message.file in change.new.tree.texts:
        return Location(str(change.new.root / message.file), 1, 1)
    return None


@message_rule(
    "MESSAGE_RENAMED",
    "A message was renamed (same fields) or moved to another scope: fine on the wire, breaks code.",
    severity="warning",
)
def renamed(pair: Paired[Message], change: Change) -> Reports:
    """## What it does
    Reports a message of OLD that NEW has under another name with an identical body (the same
    fields, numbers, names and types). What it declares is renamed with it and compared under
    the new names.

    ## Why is this bad?
    The wire carries no message names, so this is a warning. But the name is the C struct, the
    `<Name>_size` macro and the class every program uses, the pattern of nanopb `.options` lines
    (`OldName.label max_size:16` stops applying), the type URL of an `Any`, and perhaps an
    embedded root of `[tool.erc-lint]` (then `EMBEDDED_ROOT_MISSING` says so).

    ## Example
    Before:
    ```proto
    message RoverStatus {
      float battery = 1;
    }
    ```
    After:
    ```proto
    message BoardStatus {
      float battery = 1;
    }
    ```

    ## Use instead
    Keep the name, or rename it everywhere it is used at once: code, `.options` files and the
    configured embedded roots.
    """
    old, new = pair
    if old.name == new.name or old.map_entry:  # a map entry follows its map field
        return
    outer, _, inner = old.name.rpartition(".")
    if outer and change.renamed.get(outer) == new.name.removesuffix(f".{inner}"):
        return  # declared inside a renamed message: that rename says it
    if old.body() == new.body():
        text = f'Message "{old.name}" was renamed to "{new.name}"; its fields are unchanged.'
    else:  # moved to another scope: its fields are compared there
        text = f'Message "{old.name}" was moved to "{new.name}".'
    yield Report(new.location, text)


@definition_rule("RESERVED_REMOVED", "A reserved number or name is no longer reserved.")
def reserved_removed(pair: Paired[Any], change: Change) -> Reports:
    """## What it does
    Reports a reserved number range (or any part of it) or a reserved name of a message or enum
    that NEW no longer reserves, with the first number that became free.

    ## Why is this bad?
    A reservation is what keeps a retired number from being given to a new field or value while
    boards built before its retirement still send the old one. Without it the next change can
    reuse the number, those boards' bytes are read as the new field, and a comparison with the
    revision before sees only a field added (the ledger, `LEDGER_NUMBER_REUSED`, still knows).

    ## Example
    Before:
    ```proto
    message GPSInfo {
      reserved 3, 30 to 40;
      double latitude = 1;
    }
    ```
    After:
    ```proto
    message GPSInfo {
      reserved 3;
      double latitude = 1;
    }
    ```

    ## Use instead
    Keep the reservation (`reserved 3, 30 to 40;`); reservations only ever grow.
    """
    old, new = pair
    for low, high in old.reserved.ranges:
        free = new.reserved.first_free(low, high)
        if free is not None:
            span = f'"{low}"' if low == high else f'"{low} to {high}"'
            yield Report(
                new.location,
                f'Previously reserved range {span} on {new.kind} "{new.name}" is no longer '
                f"reserved (first free number: {free}).",
            )
    for name in sorted(old.reserved.names - new.reserved.names):
        yield Report(
            new.location,
            f'Previously reserved name "{name}" on {new.kind} "{new.name}" is no longer reserved.',
        )


@message_rule(
    "ENVELOPE_SIZE_GROWN",
    "An embedded root's nanopb maximum size grew (or is none now): receivers built with the old"
    " size drop more.",
    severity="warning",
    categories=("NANOPB",),
)
def envelope_size_grown(pair: Paired[Message], change: Change) -> Reports:
    """## What it does
    Reports an embedded root (`roots` of `[tool.erc-lint]`, `PBEnvelope` by default) whose
    maximum encoded size, as nanopb's generator computes it, is larger in NEW than in OLD, or
    that had one in OLD and has none in NEW (with why: a field nanopb cannot bound, or a proto2
    group for which the generator refuses the file).

    ## Why is this bad?
    Receivers size their buffer with the `<Root>_size` of the header they were built with, and
    the fleet's receivers drop any datagram longer than that. Once a sender built from NEW sends
    one of the larger messages, every receiver still built from OLD drops it; in a mixed fleet
    the warning is the reminder to rebuild them first.

    ## Example
    Before (`PBEnvelope_size` 11):
    ```proto
    message PBEnvelope {
      oneof payload { Status status = 1; }
    }
    message Status { fixed64 uptime = 1; }
    ```
    After (`PBEnvelope_size` 20):
    ```proto
    message PBEnvelope {
      oneof payload { Status status = 1; }
    }
    message Status { fixed64 uptime = 1; fixed64 errors = 2; }
    ```

    ## Use instead
    Rebuild every receiver with the new header before anything sends the larger messages, or
    keep the size: a smaller `max_size`, a narrower `int_size`, the data in a message of its own.
    """
    root = pair.new.name
    if root != pair.old.name or root not in change.config.roots:
        return
    # Equal inputs spare two size computations. test_equal_size_inputs_mean_equal_sizes holds
    # the shortcut to the sizes.
    if change.old.same_size_inputs(change.new, root):
        return  # nothing nanopb sizes the root from has changed
    before = change.old.max_size(root)
    if before is None:
        return  # no size in OLD: none to grow from or to lose (EMBEDDED_UNBOUNDED says why)
    after = change.new.max_size(root)
    c_name = root.replace(".", "_")
    if after is None:
        refusal = change.new.refusal(root)
        why = refusal or f"nanopb writes {c_name}_size depends on runtime parameters"
        damage = (
            "no board's code can be generated from NEW"
            if refusal
            else f"receivers built with the old {c_name}_size drop the longer datagrams"
        )
        yield Report(
            pair.new.location,
            f'Maximum size of message "{root}" was {before} bytes and is none in NEW ({why}): '
            f"{damage}.",
        )
    if after is not None and after > before:
        budget = change.config.budget.get(root)
        room = f" (budget {budget} bytes: headroom {budget - after} bytes)" if budget else ""
        yield Report(
            pair.new.location,
            f'Maximum size of message "{root}" grew from {before} to {after} bytes{room}: '
            f"receivers built with the old {c_name}_size drop the longer datagrams.",
        )


@message_rule("REQUIRED_FIELD_ADDED", "A message has a required field it did not have before.")
def required_field_added(pair: Paired[Message], change: Change) -> Reports:
    """## What it does
    Reports a field NEW holds `required` (proto2's label, or editions'
    `features.field_presence = LEGACY_REQUIRED`) whose number OLD had not, or had but not
    required.

    ## Why is this bad?
    A reader built from NEW refuses a message without every required field: nanopb fails to
    decode it ("missing required field"), Google protobuf's C++ and Java parsers reject it
    (Python's raises once the message is serialized again). Senders built from OLD never send
    the new field, so every message they send is refused.

    ## Example
    Before:
    ```proto
    syntax = "proto2";
    message Battery {
      optional float volts = 1;
    }
    ```
    After:
    ```proto
    syntax = "proto2";
    message Battery {
      optional float volts = 1;
      required float amps = 2;
    }
    ```

    ## Use instead
    Add the field as `optional` (in editions, with explicit presence, the default), and treat
    its absence in the receivers.
    """
    old, new = pair
    for number, field in sorted(new.fields.items()):
        before = old.fields.get(number)
        if field.cardinality == "required" and (before is None or before.cardinality != "required"):
            yield Report(field.location, _required(new, number, "added"))


@message_rule("REQUIRED_FIELD_REMOVED", "A required field was deleted or is no longer required.")
def required_field_removed(pair: Paired[Message], change: Change) -> Reports:
    """## What it does
    Reports a field OLD holds `required` (proto2's label, or editions'
    `features.field_presence = LEGACY_REQUIRED`) that NEW deleted or no longer requires.

    ## Why is this bad?
    Readers built from OLD refuse a message without every field they hold required (nanopb:
    "missing required field"; Google protobuf's C++ and Java parsers: "missing required
    fields"). Senders built from NEW may leave the field out, so receivers still running OLD
    refuse what they send.

    ## Example
    Before:
    ```proto
    syntax = "proto2";
    message Battery {
      required float volts = 1;
    }
    ```
    After:
    ```proto
    syntax = "proto2";
    message Battery {
      optional float volts = 1;
    }
    ```

    ## Use instead
    Keep the field required until no receiver built from OLD is left, or have NEW's senders
    always set it.
    """
    old, new = pair
    for number, field in sorted(old.fields.items()):
        now = new.fields.get(number)
        if field.cardinality == "required" and (now is None or now.cardinality != "required"):
            yield Report(now.location if now else new.location, _required(new, number, "deleted"))


def _required(message: Message, number: int, what: str) -> str:
    return (
        f'Message "{message.name}" had required field "{number}" {what}. Required fields must '
        "always be sent, so if one side does not know about the required field, this will "
        "result in a breakage."
    )
