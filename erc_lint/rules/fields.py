"""Rules on the fields of messages that exist in both revisions (or were renamed), one field
pair at a time: the OLD field and what NEW has at its number and under its name. An extension is
a field of the message it extends, and these rules judge it as buf does, in buf's words
(``Extension "100" with name "ext" on message "Host"``); its deletion is ``EXTENSION_DELETED``'s."""

from .._model import Field
from .._pairing import Change, FieldPair
from ._registry import Report, Reports, field_prefix, field_rule


@field_rule("FIELD_RENUMBERED", "A field kept its name but changed number.")
def renumbered(pair: FieldPair, change: Change) -> Reports:
    """## What it does
    Reports a field whose name is still there in NEW, under another number.

    ## Why is this bad?
    On the wire a field is its number; its name never travels. Senders built from OLD keep
    writing the value under the old number, which a receiver built from NEW does not know (it
    skips it and reads the field as its default, 0), and a receiver built from OLD skips what
    new senders write under the new number.

    ## Example
    Before:
    ```proto
    message MotorCommand {
      float speed = 1;
    }
    ```
    After:
    ```proto
    message MotorCommand {
      float speed = 2;
    }
    ```

    ## Use instead
    Keep the number (`float speed = 1;`). A field that needs another number is a new field:
    give it a new name too, and reserve the old number and name (`reserved 1; reserved "speed";`).
    """
    now = pair.by_name
    if now is not None and now.number != pair.old.number:
        yield Report(
            now.location,
            f'{now.noun} "{pair.old.name}" on message "{pair.new_owner.name}" changed number from '
            f'"{pair.old.number}" to "{now.number}".',
        )


@field_rule(
    "FIELD_NUMBER_REUSED",
    "A field number now carries another field: other name and type, or its old field moved.",
)
def number_reused(pair: FieldPair, change: Change) -> Reports:
    """## What it does
    Reports a field number that NEW gives to another field: one with another name and a type
    that reads other bytes, or any other field while the old one moved to a number of its own.

    ## Why is this bad?
    Senders built from OLD still write the old field under that number, and a receiver built
    from NEW reads those bytes as the new field: a wrong value where the wire types agree; where
    they do not, nanopb fails to decode the whole message ("wrong wire type") and Google protobuf
    drops the field. Receivers built from OLD misread new senders the same way.

    ## Example
    Before:
    ```proto
    message Diagnostics {
      float temperature = 2;
    }
    ```
    After:
    ```proto
    message Diagnostics {
      uint32 error_count = 2;
    }
    ```

    ## Use instead
    Give the new field a number never used before, and reserve the old one:
    `reserved 2; reserved "temperature"; uint32 error_count = 3;`.
    """
    taken = pair.by_number
    if taken is None or taken.name == pair.old.name:
        return
    if pair.by_name is not None or not change.compatible(pair.old, taken):
        yield Report(
            taken.location,
            f'{taken.noun} "{pair.old.number}" on message "{pair.new_owner.name}" changed from '
            f'"{pair.old.name}" ("{pair.old.type}") to "{taken.name}" ("{taken.type}").',
        )


@field_rule(
    "FIELD_TYPE_CHANGED", "A field kept its number and name but not a wire-compatible type."
)
def type_changed(pair: FieldPair, change: Change) -> Reports:
    """## What it does
    Reports a field that kept its number and name but changed to a type that does not read the
    bytes of the old one as the same kind of value.

    ## Why is this bad?
    Both sides decode the number with their own type. A `float` is four fixed bytes, an `sint32`
    a zigzag varint: between different wire types nanopb fails to decode the whole message
    ("wrong wire type") and Google protobuf drops the field; between varints of different
    encodings (`int32` and `sint32`) every value is silently misread (1 reads as -1). A message
    or enum type is compatible only with itself (or its rename).

    ## Example
    Before:
    ```proto
    message Wheel {
      float rpm = 1;
    }
    ```
    After:
    ```proto
    message Wheel {
      sint32 rpm = 1;
    }
    ```

    ## Use instead
    Keep the type, or change it within a group that shares a wire encoding: `int32`, `int64`,
    `uint32`, `uint64`, `bool`; `sint32`, `sint64`; `fixed32`, `sfixed32`; `fixed64`, `sfixed64`;
    `string` to `bytes`. Another type is a new field: `reserved 1; reserved "rpm";
    sint32 rpm_count = 2;`.
    """
    taken = pair.by_number
    if taken is not None and taken.name == pair.old.name and not change.compatible(pair.old, taken):
        yield Report(
            taken.location,
            f'{_field(taken, pair)} changed type from "{pair.old.type}" to "{taken.type}".',
        )


@field_rule("FIELD_DELETED", "A field number disappeared without being reserved.")
def deleted(pair: FieldPair, change: Change) -> Reports:
    """## What it does
    Reports a field that is gone from NEW, by number and by name, while NEW does not reserve its
    number.

    ## Why is this bad?
    Receivers built from OLD read the missing field as its default (a speed of 0, a brake
    released), and boards still running OLD keep sending it. Worse, nothing stops the next
    change from giving the free number to another field, which would then read those boards'
    bytes as its own value (`FIELD_NUMBER_REUSED`, across revisions `LEDGER_NUMBER_REUSED`).

    ## Example
    Before:
    ```proto
    message GPSInfo {
      double latitude = 1;
      uint32 satellites = 3;
    }
    ```
    After:
    ```proto
    message GPSInfo {
      double latitude = 1;
    }
    ```

    ## Use instead
    Reserve the number and the name: `reserved 3; reserved "satellites";`, or restore the field.
    """
    gone = pair.by_number is None and pair.by_name is None
    if pair.old.extension:
        return  # EXTENSION_DELETED: an extension's number is not reserved this way
    if gone and not pair.new_owner.reserved.covers(pair.old.number):
        yield Report(
            pair.old.location,
            f'Previously present field "{pair.old.number}" with name "{pair.old.name}" on '
            f'message "{pair.new_owner.name}" was deleted without reserving its number.',
            in_old=True,
            fix=f"reserve {pair.old.number} or restore the field",
            container=pair.new_owner.location,
        )


@field_rule("FIELD_CARDINALITY_CHANGED", "A field changed between singular and repeated.")
def cardinality_changed(pair: FieldPair, change: Change) -> Reports:
    """## What it does
    Reports a field that kept its number and a compatible type but changed between singular
    (`optional`, proto3's implicit presence, or `required`) and `repeated` (a change between
    `optional` and `required` is `REQUIRED_FIELD_ADDED`'s or `REQUIRED_FIELD_REMOVED`'s).

    ## Why is this bad?
    Senders and receivers disagree on how many values the number carries. A repeated scalar of
    proto3 is sent packed, one length-delimited record, which a receiver built with the singular
    field cannot read (a wrong wire type: nanopb fails the whole message, Google protobuf drops
    the field); several values where one is expected keep only the last.

    ## Example
    Before:
    ```proto
    message ArmJoints {
      float angle = 1;
    }
    ```
    After:
    ```proto
    message ArmJoints {
      repeated float angle = 1;
    }
    ```

    ## Use instead
    Keep the cardinality. A list is a new field: `reserved 1; reserved "angle";
    repeated float angles = 2;`.
    """
    taken = pair.by_number
    if taken is None or not change.compatible(pair.old, taken):
        return
    if (taken.cardinality == "repeated") != (pair.old.cardinality == "repeated"):
        yield Report(
            taken.location,
            f"{_field(taken, pair, taken.name)} changed cardinality from "
            f'"{pair.old.cardinality}" to "{taken.cardinality}".',
        )


@field_rule("FIELD_ONEOF_CHANGED", "A field moved into, out of, or between oneofs.")
def oneof_changed(pair: FieldPair, change: Change) -> Reports:
    """## What it does
    Reports a field that kept its number and a compatible type but moved into a oneof, out of
    one, or from one oneof to another (renaming a oneof whose members stay the same is fine).

    ## Why is this bad?
    The bytes stay the same; what a receiver keeps of them does not. The members of a oneof
    share one slot (a C union in nanopb, with its `which_` tag), so a receiver that holds the
    field in a oneof keeps only the last member to arrive, while a sender that holds the fields
    apart may set several at once: whichever way the field moved, values a sender set together
    are lost in the receiver.

    ## Example
    Before:
    ```proto
    message Setpoint {
      int32 steps = 1;
      float angle = 2;
    }
    ```
    After:
    ```proto
    message Setpoint {
      oneof target {
        int32 steps = 1;
        float angle = 2;
      }
    }
    ```

    ## Use instead
    Leave the field where it was. To group fields in a oneof, add the oneof with new fields and
    numbers, and reserve the old ones (`reserved 1, 2;`).
    """
    taken = pair.by_number
    old = pair.old
    if taken is None or not change.compatible(old, taken) or taken.oneof == old.oneof:
        return
    old_members, new_members = pair.old_owner.oneof(old.oneof), pair.new_owner.oneof(taken.oneof)
    if old_members and old_members == new_members:
        return  # the oneof was renamed: same members, same wire
    if old.oneof is None:
        move = f'moved into oneof "{taken.oneof}"'
    elif taken.oneof is None:
        move = f'moved out of oneof "{old.oneof}"'
    else:
        move = f'moved from oneof "{old.oneof}" to oneof "{taken.oneof}"'
    yield Report(taken.location, f"{_field(taken, pair, taken.name)} {move}.")


@field_rule(
    "FIELD_RENAMED",
    "A field kept its number and type under a new name: fine on the wire, breaks JSON and code.",
    severity="warning",
    errors_in=("WIRE_JSON",),
)
def renamed(pair: FieldPair, change: Change) -> Reports:
    """## What it does
    Reports a field that kept its number and a compatible type under a new name, while the old
    name is gone.

    ## Why is this bad?
    The binary wire is unchanged, so this is a warning. But the name is everywhere else: it is
    the key of the field in protobuf JSON, the member of nanopb's C struct and of every
    generated class, and the pattern a nanopb `.options` line matches (`Msg.name max_size:32`
    stops applying, and the message's size changes with it).

    ## Example
    Before:
    ```proto
    message BatteryInfo {
      float voltage = 1;
    }
    ```
    After:
    ```proto
    message BatteryInfo {
      float volts = 1;
    }
    ```

    ## Use instead
    Keep the name, or rename it everywhere it is used at once: code, JSON readers and `.options`
    files. Add `FIELD_RENAMED` to `except` if names do not matter to any user of the tree; with
    `WIRE_JSON` in `use` it is an error.
    """
    taken = pair.by_number
    if taken is None or taken.name == pair.old.name or pair.by_name is not None:
        return
    if change.compatible(pair.old, taken):
        yield Report(
            taken.location,
            f'{taken.noun} "{pair.old.number}" on message "{pair.new_owner.name}" changed name '
            f'from "{pair.old.name}" to "{taken.name}".',
        )


@field_rule(
    "FIELD_DEFAULT_CHANGED",
    "A field with presence reads as another value while absent: its default changed.",
)
def default_changed(pair: FieldPair, change: Change) -> Reports:
    """## What it does
    Reports a singular scalar or enum field that kept its number and type while the value a
    reader holds for it when it is absent changed: its `default` (proto2 and editions fields
    with explicit presence), or for an enum without one, the first value the enum declares.
    An enum value that kept its name but took another number is shown with both numbers.

    ## Why is this bad?
    The bytes are identical: a default is never sent. A sender leaves the field out when it
    holds no value (or, in proto2 code, one it never set), and each receiver fills in its own
    default. A board built from OLD that omits the field means 5; a receiver built from NEW
    reads 6, with nothing on the wire to tell it otherwise.

    ## Example
    Before:
    ```proto
    syntax = "proto2";
    message Heater {
      optional int32 target_celsius = 1 [default = 5];
    }
    ```
    After:
    ```proto
    syntax = "proto2";
    message Heater {
      optional int32 target_celsius = 1 [default = 6];
    }
    ```

    ## Use instead
    Keep the default. Another default is another field: `reserved 1; reserved
    "target_celsius"; optional int32 target_celsius_v2 = 2 [default = 6];`, or send the value
    always (make the senders set it).
    """
    taken, old = pair.by_number, pair.old
    if taken is None or taken.cardinality == "repeated" or old.cardinality == "repeated":
        return
    if old.default is None and taken.default is None and old.kind == "scalar":
        # Types that read each other's bytes have equal zero values (0, false, "").
        # test_implicit_defaults_of_compatible_types_agree holds it.
        return
    if taken.kind == "message" or not change.compatible(old, taken):
        return
    before, shown_before = change.old.default(old)
    after, shown_after = change.new.default(taken)
    if before != after:
        if shown_before == shown_after:  # an enum value that kept its name, not its number
            shown_before, shown_after = f"{shown_before} ({before})", f"{shown_after} ({after})"
        yield Report(
            taken.location,
            f"{_field(taken, pair)} changed default value from {shown_before} to {shown_after}.",
        )


@field_rule(
    "FIELD_ENCODING_CHANGED",
    "A message field changed between a group (delimited) and a length-prefixed message.",
)
def encoding_changed(pair: FieldPair, change: Change) -> Reports:
    """## What it does
    Reports a message field that kept its number and type but changed how its message travels:
    between start- and end-group tags (a proto2 `group`, or an editions field with
    `features.message_encoding = DELIMITED`) and a length-prefixed record (a plain message
    field). A proto2 group and a `DELIMITED` field are the same bytes, and are not reported.
    (Packing, `repeated_field_encoding`, is not reported: every reader, nanopb's and Google's,
    accepts a repeated scalar packed or not.)

    ## Why is this bad?
    The field's wire type changes, from 3 (start group) to 2 (length-delimited) or back. A
    receiver built with the other encoding meets a wire type it does not expect: nanopb fails
    to decode the whole message ("wrong wire type"), Google protobuf keeps the field as unknown
    bytes and the message reads as if it were absent.

    ## Example
    Before:
    ```proto
    syntax = "proto2";
    message Survey {
      optional group Sample = 1 {
        optional float depth = 2;
      }
    }
    ```
    After:
    ```proto
    syntax = "proto2";
    message Survey {
      message Sample {
        optional float depth = 2;
      }
      optional Sample sample = 1;
    }
    ```

    ## Use instead
    Keep the encoding: in an editions file, write the field with
    `[features.message_encoding = DELIMITED]`. A length-prefixed message is a new field:
    `reserved 1; reserved "sample"; optional Sample sample_v2 = 3;`.
    """
    taken, old = pair.by_number, pair.old
    if taken is None or old.kind != "message" or not change.compatible(old, taken):
        return
    if taken.delimited != old.delimited:
        yield Report(
            taken.location,
            f'{_field(taken, pair)} changed type from "{old.encoding}" to "{taken.encoding}".',
        )


@field_rule(
    "FIELD_UTF8_VALIDATION_CHANGED",
    "A string field's readers now reject, or no longer reject, what is not UTF-8.",
    severity="warning",
)
def utf8_validation_changed(pair: FieldPair, change: Change) -> Reports:
    """## What it does
    Reports a string field that kept its number whose UTF-8 validation changed: proto3 and
    editions strings are `VERIFY` by default, proto2 strings `NONE`, and editions set it with
    `features.utf8_validation`. A `bytes` field validates nothing: a verifying string that
    became `bytes` (or the reverse), which the type rules accept as wire-compatible, is
    reported too. It is a warning: only a value that is not UTF-8 breaks.

    ## Why is this bad?
    A reader that verifies fails to parse the whole message when the string holds bytes that
    are not UTF-8 (Google protobuf raises a decode error). Senders built with `NONE` may send
    such bytes, so turning validation on rejects what OLD's senders send; turning it off lets
    NEW's senders write what OLD's verifying readers reject. nanopb does not validate unless
    built with `PB_VALIDATE_UTF8`.

    ## Example
    Before:
    ```proto
    edition = "2023";
    message Label {
      string text = 1;
    }
    ```
    After:
    ```proto
    edition = "2023";
    message Label {
      string text = 1 [features.utf8_validation = NONE];
    }
    ```

    ## Use instead
    Keep the validation (moving a file from proto2 to proto3 or editions, set
    `features.utf8_validation = NONE` where proto2 had it); arbitrary bytes belong in a `bytes`
    field.
    """
    taken, old = pair.by_number, pair.old
    if (
        taken is None
        or {taken.type, old.type} - {"string", "bytes"}
        or taken.type == "bytes" == old.type
    ):
        return
    if taken.utf8 != old.utf8:
        retyped = f" ({old.type} to {taken.type})" if taken.type != old.type else ""
        yield Report(
            taken.location,
            f"{_field(taken, pair)} changed UTF8 validation from {_utf8(old)} to "
            f"{_utf8(taken)}{retyped}.",
        )


@field_rule(
    "FIELD_JSON_NAME_CHANGED",
    "A field kept its name but not its JSON name (json_name): protobuf JSON breaks.",
    categories=("WIRE_JSON",),
)
def json_name_changed(pair: FieldPair, change: Change) -> Reports:
    """## What it does
    Reports a field that kept its number and name while its JSON name changed (a `json_name`
    option added, changed or dropped). Only in category `WIRE_JSON`: the binary wire is
    unchanged.

    ## Why is this bad?
    Protobuf JSON names each field by its JSON name. A JSON reader built from one revision
    does not know the other's key: it rejects the document (or, ignoring unknown fields, drops
    the value), so the base station's JSON logs and bridges stop reading each other.

    ## Example
    Before:
    ```proto
    message Fix {
      double lat = 1 [json_name = "latitude"];
    }
    ```
    After:
    ```proto
    message Fix {
      double lat = 1 [json_name = "lat"];
    }
    ```

    ## Use instead
    Keep the JSON name (`[json_name = "latitude"]`).
    """
    taken, old = pair.by_number, pair.old
    if taken is not None and taken.name == old.name and taken.json_name != old.json_name:
        yield Report(
            taken.location,
            f'{_field(taken, pair)} changed option "json_name" from "{old.json_name}" to '
            f'"{taken.json_name}".',
        )


def _field(now: Field, pair: FieldPair, name: str | None = None) -> str:
    """``Field "2" with name "x" on message "M"``: how buf starts a message about a field."""
    return field_prefix(now, pair.new_owner.name, pair.old.number, name or pair.old.name)


def _utf8(field: Field) -> str:
    return "VERIFY" if field.utf8 else "NONE"
