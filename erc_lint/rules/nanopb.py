"""Rules on what nanopb makes of a change, which no other tool checks: the limits and the C layout
its options (``.options`` files beside each .proto, ``(nanopb)`` annotations, resolved as the
generator resolves them) give each field, and the size budget of each embedded root.

A field's options are compared only while it keeps its number and its type (a type change is the
field rules' to report), and only when either revision sets a nanopb option at all: without one,
every field has nanopb's defaults on both sides.
"""

from erc_codec.schema import Options

from .._model import Field, Message, Revision
from .._pairing import Change, FieldPair, Paired
from ._registry import Report, Reports, field_rule, message_rule, tree_rule

_NANOPB = ("NANOPB",)
# The width a varint field has with int_size IS_DEFAULT (an enum's is its C enum's, 32 bits).
_WIDTHS = {"int32": 32, "uint32": 32, "sint32": 32, "int64": 64, "uint64": 64, "sint64": 64}
_INT_SIZES = {0: "IS_DEFAULT", 8: "IS_8", 16: "IS_16", 32: "IS_32", 64: "IS_64"}
# nanopb's FieldType, as its generator settles FT_DEFAULT (see _allocation).
_TYPES = {1: "callback", 2: "static", 3: "ignore", 4: "pointer", 5: "static"}
# What a receiver meets when a sender's value exceeds a narrowed limit.
_EXCEEDS = {"bytes": "a longer value", "count": "more elements", "int": "a wider value"}


@field_rule(
    "NANOPB_LIMIT_NARROWED",
    "A nanopb limit shrank (max_size, max_length, max_count, int_size): receivers reject more.",
    categories=_NANOPB,
)
def limit_narrowed(pair: FieldPair, change: Change) -> Reports:
    """## What it does
    Reports a field that kept its number and type whose nanopb limit is smaller in NEW: the
    bytes a string or bytes value may hold (`max_size`, `max_length`), the elements of a
    repeated field (`max_count`), the width of an integer or enum (`int_size`).

    ## Why is this bad?
    Senders built from OLD may send values up to the old limit. A board built from NEW decodes
    into the smaller struct and fails the whole message when a value does not fit (nanopb:
    "string overflow", "bytes overflow", "array overflow", "integer too large"): the datagram
    is lost, not cut.

    ## Example
    Before:
    ```proto
    import "nanopb.proto";
    message Label {
      string text = 1 [(nanopb).max_size = 40];
    }
    ```
    After:
    ```proto
    import "nanopb.proto";
    message Label {
      string text = 1 [(nanopb).max_size = 25];
    }
    ```

    ## Use instead
    Keep the limit until every sender is built from NEW and never sends more, or keep it for
    good and cut values where they are made.
    """
    for what, before, after in _limit_changes(pair, change):
        if after[0] < before[0]:
            yield Report(
                _now(pair).location,
                f'{_field(pair)} changed nanopb limit from "{before[1]}" to "{after[1]}": '
                f"receivers built from NEW fail to decode {_EXCEEDS[what]} that OLD's senders "
                "may send.",
            )


@field_rule(
    "NANOPB_LIMIT_WIDENED",
    "A nanopb limit grew: the struct and the message's maximum size grow with it.",
    severity="warning",
    categories=_NANOPB,
)
def limit_widened(pair: FieldPair, change: Change) -> Reports:
    """## What it does
    Reports a field that kept its number and type whose nanopb limit is larger in NEW
    (`max_size`, `max_length`, `max_count`, `int_size`), with how its message's nanopb size
    changes.

    ## Why is this bad?
    It breaks nothing at once, so it is a warning. But the C struct grows on every board that
    holds the message, and so does `<Message>_size`: a sender built from NEW may send values
    that receivers built from OLD fail to decode (the narrowing, seen from the other side), and
    datagrams longer than their buffers (`ENVELOPE_SIZE_GROWN`, `ENVELOPE_OVER_BUDGET`).

    ## Example
    Before:
    ```proto
    import "nanopb.proto";
    message Label {
      string text = 1 [(nanopb).max_size = 25];
    }
    ```
    After:
    ```proto
    import "nanopb.proto";
    message Label {
      string text = 1 [(nanopb).max_size = 40];
    }
    ```

    ## Use instead
    Rebuild every receiver from NEW before any sender sends the longer values, and check the
    envelope's budget.
    """
    for _, before, after in _limit_changes(pair, change):
        if after[0] > before[0]:
            old_size = change.old.max_size(pair.old_owner.name)
            new_size = change.new.max_size(pair.new_owner.name)
            c_name = pair.new_owner.name.replace(".", "_")
            if old_size is None or new_size is None:
                grows = f"the struct grows ({c_name} has no fixed size)"
            else:
                grows = f"the struct grows, and {c_name}_size from {old_size} to {new_size} bytes"
            yield Report(
                _now(pair).location,
                f'{_field(pair)} changed nanopb limit from "{before[1]}" to "{after[1]}": {grows}.',
            )


@message_rule(
    "NANOPB_LAYOUT_CHANGED",
    "nanopb lays a field or oneof out otherwise: type, fixed_length, fixed_count, unions.",
    categories=_NANOPB,
)
def layout_changed(pair: Paired[Message], change: Change) -> Reports:
    """## What it does
    Reports, in a message of both revisions, a field that kept its number and type whose
    nanopb storage changed (its `type`: static, callback, pointer or ignore, as the generator
    settles `FT_DEFAULT`; `fixed_length`; `fixed_count`), and a oneof whose `no_unions` or
    `anonymous_oneof` changed.

    ## Why is this bad?
    The boards compile against the generated struct. A field that becomes a callback or
    pointer leaves the fixed-size struct (code reading `msg.field` no longer compiles, and a
    receiver without a callback drops the value), an ignored one is skipped on decode. A
    `fixed_length` bytes field must arrive exactly `max_size` long and a `fixed_count` array
    exactly `max_count` long: toggled on, receivers fail to decode what OLD's senders send
    ("incorrect fixed length bytes size"). `no_unions` and `anonymous_oneof` change the C layout
    of a oneof (a union or separate members; `msg.which_x` and `msg.x.member` or `msg.member`).

    ## Example
    Before:
    ```proto
    import "nanopb.proto";
    message Key {
      bytes id = 1 [(nanopb).max_size = 16];
    }
    ```
    After:
    ```proto
    import "nanopb.proto";
    message Key {
      bytes id = 1 [(nanopb).max_size = 16, (nanopb).fixed_length = true];
    }
    ```

    ## Use instead
    Keep the layout; a field stored another way is a new field with a new number.
    """
    if not change.compares_nanopb:
        return
    old, new = pair
    for number, before in old.fields.items():
        after = new.fields.get(number)
        if after is None or not _same_type(change, before, after):
            continue
        was = _layout(before, change.old.field_options(before))
        now = _layout(after, change.new.field_options(after))
        for what, a in was.items():
            b = now.get(what, a)
            if a != b:
                yield Report(
                    after.location,
                    f'{after.noun} "{number}" with name "{after.name}" on message "{new.name}" '
                    f'changed nanopb {what} from "{a}" to "{b}".',
                )
    for oneof, at in new.oneofs.items():
        if oneof not in old.oneofs:
            continue
        was = change.old.oneof_options(old.name, oneof)
        now = change.new.oneof_options(new.name, oneof)
        for option in ("no_unions", "anonymous_oneof"):
            a, b = _flag(getattr(was, option)), _flag(getattr(now, option))
            if a != b:
                yield Report(
                    new.source.where(at),
                    f'Oneof "{oneof}" on message "{new.name}" changed nanopb option "{option}" '
                    f'from "{a}" to "{b}".',
                )


@tree_rule(
    "ENVELOPE_OVER_BUDGET",
    "An embedded root's nanopb maximum size exceeds the budget configured for it.",
    categories=("TREE", "NANOPB"),
)
def envelope_over_budget(revision: Revision, change: Change) -> Reports:
    """## What it does
    Reports an embedded root given a `budget` in `[tool.erc-lint]` (`budget = { PBEnvelope =
    305 }`) whose maximum encoded size, as nanopb's generator computes it, exceeds that many
    bytes: the size, the budget and the headroom (negative). `erc-lint check` reports it too.

    ## Why is this bad?
    The budget is what the link or the receivers' buffers allow: a radio's MTU, a UART frame, a
    board's receive buffer. A datagram longer than that is dropped or cut on the way, and once
    any message can reach the size, nothing guarantees it never will.

    ## Example
    Before (`budget = { PBEnvelope = 12 }`, `PBEnvelope_size` 11):
    ```proto
    message PBEnvelope { oneof payload { Status status = 1; } }
    message Status { fixed64 uptime = 1; }
    ```
    After (`PBEnvelope_size` 20):
    ```proto
    message PBEnvelope { oneof payload { Status status = 1; } }
    message Status { fixed64 uptime = 1; fixed64 errors = 2; }
    ```

    ## Use instead
    Bring the size back under the budget (a smaller `max_size`, a narrower `int_size`, the data
    in a message of its own), or raise the budget once the link and every receiver allow it.
    """
    for root, budget in sorted(change.config.budget.items()):
        message = revision.messages.get(root)
        size = revision.max_size(root) if message is not None else None
        if message is not None and size is not None and size > budget:
            yield Report(
                message.location,
                f'Maximum size of message "{root}" is {size} bytes, over its budget of {budget} '
                f"bytes: headroom {budget - size} bytes.",
                key=root,
            )


Limit = tuple[int, str]  # what a limit allows (bytes, elements, bits) and how it is written


def _limit_changes(pair: FieldPair, change: Change) -> list[tuple[str, Limit, Limit]]:
    """Each limit (``bytes``, ``count``, ``int``) that both revisions give the field and that
    differs between them."""
    old, now = pair.old, pair.by_number
    if not change.compares_nanopb or now is None or now.extension:
        return []
    if not _same_type(change, old, now) or now.cardinality != old.cardinality:
        return []
    before = _limits(old, change.old.field_options(old))
    after = _limits(now, change.new.field_options(now))
    return [
        (what, before[what], after[what])
        for what in before.keys() & after.keys()
        if before[what][0] != after[what][0]
    ]


def _limits(field: Field, options: Options) -> dict[str, Limit]:
    """The limits nanopb's options put on a field."""
    found: dict[str, Limit] = {}
    if field.cardinality == "repeated" and options.HasField("max_count"):
        found["count"] = (int(options.max_count), f"max_count:{options.max_count}")
    if field.type == "string" and options.HasField("max_length"):
        found["bytes"] = (int(options.max_length), f"max_length:{options.max_length}")
    elif field.type == "string" and options.HasField("max_size"):  # with the C string's NUL
        found["bytes"] = (int(options.max_size) - 1, f"max_size:{options.max_size}")
    elif field.type == "bytes" and options.HasField("max_size"):
        found["bytes"] = (int(options.max_size), f"max_size:{options.max_size}")
    width = _WIDTHS.get(field.type, 32 if field.kind == "enum" else 0)
    if width:
        size = int(options.int_size)
        found["int"] = (size or width, f"int_size:{_INT_SIZES.get(size, size)}")
    return found


def _layout(field: Field, options: Options) -> dict[str, str]:
    """What decides a field's place in nanopb's struct, as a message names each part."""
    found = {"type": _allocation(field, options)}
    if field.type == "bytes":
        found['option "fixed_length"'] = _flag(options.fixed_length)
    if field.cardinality == "repeated":
        found['option "fixed_count"'] = _flag(options.fixed_count)
    return found


def _allocation(field: Field, options: Options) -> str:
    """How nanopb stores a field: ``FT_DEFAULT`` is static where a limit allows it (a string or
    bytes value needs ``max_size`` or ``max_length``, a repeated field ``max_count``), else a
    callback."""
    kind = int(options.type)
    if kind:
        return _TYPES.get(kind, str(kind))
    if field.cardinality == "repeated" and not options.HasField("max_count"):
        return "callback"
    if field.type in ("string", "bytes"):
        bounded = options.HasField("max_size") or options.HasField("max_length")
        return "static" if bounded else "callback"
    return "static"


def _same_type(change: Change, old: Field, new: Field) -> bool:
    """Whether NEW's field has OLD's type: the same keyword, or the same (or renamed) type."""
    return old.type == new.type if old.kind == "scalar" else change.same_type(old.type, new.type)


def _flag(value: bool) -> str:
    return "true" if value else "false"


def _now(pair: FieldPair) -> Field:
    assert pair.by_number is not None  # _limit_changes found changes
    return pair.by_number


def _field(pair: FieldPair) -> str:
    now = _now(pair)
    return f'Field "{now.number}" with name "{now.name}" on message "{pair.new_owner.name}"'
