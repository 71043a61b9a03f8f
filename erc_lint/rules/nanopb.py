"""Rules on what nanopb makes of a change, which no other tool checks: the limits and the C layout
its options (``.options`` files beside each .proto, ``(nanopb)`` annotations, resolved as the
generator resolves them) give each field, and the size budget of each embedded root.

A field's options are compared only while it keeps its number and a wire-compatible type (another
type is the field rules' to report), and only when either revision sets a nanopb option at all:
without one, every field has nanopb's defaults on both sides, and only a type change within a wire
group (``int64`` to ``int32``) can change what the C struct holds.
"""

import functools
import weakref

from google.protobuf import descriptor_pb2

from erc_schema import Options, options_class

from .._model import Field, Message, Revision, allocation
from .._pairing import Change, FieldPair, Paired, wire_compatible
from ._registry import Report, Reports, field_prefix, field_rule, message_rule, tree_rule

_NANOPB = ("NANOPB",)
_FD = descriptor_pb2.FieldDescriptorProto
# The bits of a varint field's C member with int_size IS_DEFAULT.
_WIDTHS = {"int32": 32, "uint32": 32, "sint32": 32, "int64": 64, "uint64": 64, "sint64": 64}
_SIGNED = {"int32", "sint32", "int64", "sint64"}
_INT_SIZES = {0: "IS_DEFAULT", 8: "IS_8", 16: "IS_16", 32: "IS_32", 64: "IS_64"}
# What a receiver meets when a sender's value exceeds a narrowed limit.
_EXCEEDS = {"bytes": "a longer value", "count": "more elements"}


@field_rule(
    "NANOPB_LIMIT_NARROWED",
    "A nanopb limit shrank (max_size, max_count, int_size, a narrower int type): receivers reject"
    " or misread more.",
    categories=_NANOPB,
)
def limit_narrowed(pair: FieldPair, change: Change) -> Reports:
    """## What it does
    Reports a field that kept its number and a wire-compatible type whose nanopb limit is
    smaller in NEW: the bytes a static string or bytes value may hold (`max_size`,
    `max_length`), the elements of a static repeated field (`max_count`; a callback or pointer
    field has no such limit), the values an integer holds (its `int_size`, or its type: `int64`
    to `int32`, `uint64` to `uint32`, `sint64` to `sint32`, `int32` to `uint32` and back,
    anything to `bool`), and an enum's (its `enum_intsize`, from `nanopb_enumopt` or a
    `.options` line; `int_size` on an enum field is ignored by the generator). Without any
    nanopb option in the tree, a narrower integer type is still reported.

    ## Why is this bad?
    Senders built from OLD may send values up to the old limit. A board built from NEW decodes
    into the smaller struct and fails the whole message when a value does not fit (nanopb:
    "string overflow", "bytes overflow", "array overflow", "integer too large"): the datagram
    is lost, not cut. Worse, nanopb's decoder first cuts a plain signed varint stored in 32
    bits or fewer (`int32`, an enum) to its low 32 bits: an `int64` value read as `int32`, or a
    `uint32` above 2^31, arrives misread and nothing fails; a `bool` reads every value but 0 as
    true.

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
    for what, before, after in limit_changes(pair, change):
        if _narrowed(before, after):
            if what == "int":
                now = _now(pair)
                damage = _damage(_wire_type(now, _options(change.new, now)), before, after)
            else:
                damage = f"fail to decode {_EXCEEDS[what]} that OLD's senders may send"
            yield Report(
                _now(pair).location,
                f'{_field(pair)} changed nanopb limit from "{before[2]}" to "{after[2]}": '
                f"receivers built from NEW {damage}.",
            )


@field_rule(
    "NANOPB_LIMIT_WIDENED",
    "A nanopb limit grew: the struct and the message's maximum size grow with it.",
    severity="warning",
    categories=_NANOPB,
)
def limit_widened(pair: FieldPair, change: Change) -> Reports:
    """## What it does
    Reports a field that kept its number and a wire-compatible type whose nanopb limit is
    larger in NEW and holds every value the old one did (`max_size`, `max_length`,
    `max_count`, `int_size`, `enum_intsize`), with how its message's nanopb size changed (the
    whole message's, where it did: an `int32`'s `int_size` grows the struct, not the encoding;
    an extension's storage is no part of `<Message>_size`). A wider integer type (`int32` to
    `int64`) is no option that grew and is not reported.

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
    for what, before, after in limit_changes(pair, change):
        # A wider type (int32 to int64) is no option that grew: the field rules hold it
        # compatible, and any growth of the root's size is ENVELOPE_SIZE_GROWN's.
        retyped = what == "int" and not before[2].startswith(("int_size:", "enum_intsize:"))
        if not retyped and not _narrowed(before, after):
            yield Report(
                _now(pair).location,
                f'{_field(pair)} changed nanopb limit from "{before[2]}" to "{after[2]}": '
                f"{_grows(pair, change)}.",
            )


def _grows(pair: FieldPair, change: Change) -> str:
    """What a widened limit grows: an extension's own storage (no ``<Message>_size`` counts
    extensions), else the message's struct, with the message's size where it changed (the sum
    of every change to the message, not this field's share)."""
    if _now(pair).extension:
        return "the extension's C storage grows"
    old_size = change.old.max_size(pair.old_owner.name)
    new_size = change.new.max_size(pair.new_owner.name)
    c_name = pair.new_owner.name.replace(".", "_")
    if new_size is None:
        return f"the struct grows ({c_name} has no fixed size)"
    if old_size is None:
        return f"the struct grows, and the message's {c_name}_size is {new_size} bytes"
    if old_size == new_size:
        return "the struct grows"
    return (
        f"the struct grows, and the message's {c_name}_size went from {old_size} to "
        f"{new_size} bytes"
    )


@message_rule(
    "NANOPB_LAYOUT_CHANGED",
    "nanopb lays out or encodes a field or oneof otherwise: type, type_override, fixed_length,"
    " fixed_count, unions.",
    categories=_NANOPB,
)
def layout_changed(pair: Paired[Message], change: Change) -> Reports:
    """## What it does
    Reports, in a message of both revisions, a field (or extension) that kept its number and
    type whose nanopb storage changed (its `type`: static, callback, pointer or ignore, as the
    generator settles `FT_DEFAULT` and its `fallback_type`; `fixed_length`; `fixed_count`), a
    field whose
    `type_override` makes nanopb encode it as a type that does not read the old one's bytes
    (the test `FIELD_TYPE_CHANGED` applies to the declared types: `int32` overridden to
    `sint32`), and a oneof whose `no_unions` or `anonymous_oneof` changed.

    ## Why is this bad?
    The boards compile against the generated struct. A field that becomes a callback or
    pointer leaves the fixed-size struct (code reading `msg.field` no longer compiles, and a
    receiver without a callback drops the value), an ignored one is skipped on decode. A
    `fixed_length` bytes field must arrive exactly `max_size` long and a `fixed_count` array
    exactly `max_count` long: toggled on, receivers fail to decode what OLD's senders send
    ("incorrect fixed length bytes size"). `no_unions` and `anonymous_oneof` change the C layout
    of a oneof (a union or separate members; `msg.which_x` and `msg.x.member` or `msg.member`).
    A `type_override` changes the bytes themselves: an `int32` written as `sint32` is a zigzag
    varint, and every value is misread (1 reads as -1) by a receiver built from the other side.

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
    yield from layout_changes(pair, change)


def layout_changes(pair: Paired[Message], change: Change, alike: bool = True) -> Reports:
    """NANOPB_LAYOUT_CHANGED's reports on a message pair (``alike=False``: no shortcut for a
    field ``_alike`` in both, for the tests)."""
    if not change.compares_nanopb:
        return
    old, new = pair
    for number, before in [*old.fields.items(), *old.extensions.items()]:
        after = (new.extensions if before.extension else new.fields).get(number)
        if after is not None and change.compatible(before, after):  # else FIELD_TYPE_CHANGED's
            yield from _field_layout(change, new, before, after, alike)
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


def _field_layout(
    change: Change, new: Message, before: Field, after: Field, alike: bool
) -> Reports:
    """NANOPB_LAYOUT_CHANGED's word on a field that kept its number and a compatible type."""
    old_options, new_options = change.old.field_options(before), change.new.field_options(after)
    if alike and _alike(before, after, old_options, new_options):
        return  # the same encoding and layout
    wire = _wire_type(before, old_options), _wire_type(after, new_options)
    if not _compatible(change, *wire):
        yield Report(
            after.location,
            f"{field_prefix(after, new.name)} changed type as nanopb encodes it "
            f'(type_override) from "{wire[0]}" to "{wire[1]}".',
        )
        return
    if not _same_type(change, before, after):
        return
    was, now = _layout(before, old_options), _layout(after, new_options)
    for what, a in was.items():
        b = now.get(what, a)
        if a != b:
            yield Report(
                after.location,
                f'{field_prefix(after, new.name)} changed nanopb {what} from "{a}" to "{b}".',
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
    bytes: the size, the budget and the headroom (negative). A root nanopb gives no size at
    all (a string without `max_size`, a callback or pointer field on the way, a type that holds
    itself, a proto2 group the generator refuses) is reported too: no budget holds it.
    `erc-lint check` reports it too. Comparing OLD and NEW, a root OLD had over its budget by
    as much (or without a size) is a warning; one that grew past OLD's size, or lost its size,
    is an error.

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
        if message is None:
            continue  # EMBEDDED_ROOT_MISSING's
        size = revision.max_size(root)
        if size is not None and size <= budget:
            continue
        # Old damage (a warning) only where NEW is over by no more than OLD was, or OLD had no
        # size either: a root that grew past OLD's overage, or lost its size, is new damage.
        key = root
        if revision is change.new and not _no_worse(change, root, size):
            key = f"{root}:worse"
        if size is None:
            refusal = revision.refusal(root)
            why = (
                refusal
                or f"nanopb writes {root.replace('.', '_')}_size depends on runtime parameters"
            )
            yield Report(
                message,
                f'Message "{root}" has no fixed size: its budget of {budget} bytes cannot hold '
                f"({why}).",
                key=key,
            )
        else:
            yield Report(
                message,
                f'Maximum size of message "{root}" is {size} bytes, over its budget of {budget} '
                f"bytes: headroom {budget - size} bytes.",
                key=key,
            )


def _no_worse(change: Change, root: str, size: int | None) -> bool:
    """Whether NEW's ``size`` of ``root`` (over its budget, or none) is no worse than OLD's:
    OLD had no size, or a size at least as large (then OLD was over the budget too)."""
    if root not in change.old.messages:
        return False
    before = change.old.max_size(root)
    return before is None or (size is not None and size <= before)


# What a limit allows (the lowest and highest value, or 0 and the most bytes or elements) and
# how it is written.
Limit = tuple[int, int, str]


_Changes = list[tuple[str, Limit, Limit]]
# Both limit rules ask for every field pair: the limits are computed once per pair, not twice.
# test_limit_changes_once_per_pair holds the memo to the plain computation.
_MEMO: "weakref.WeakKeyDictionary[Change, dict[int, _Changes]]" = weakref.WeakKeyDictionary()


def limit_changes(pair: FieldPair, change: Change) -> _Changes:
    """``limit_changes_of(pair, change)``, computed once per pair of a change."""
    memo = _MEMO.setdefault(change, {})
    key = id(pair)  # the change holds its pairs for as long as it lives
    found = memo.get(key)
    if found is None:
        found = memo[key] = limit_changes_of(pair, change)
    return found


def limit_changes_of(pair: FieldPair, change: Change, alike: bool = True) -> _Changes:
    """Each limit (``bytes``, ``count``, ``int``) that both revisions give the field and that
    differs between them. A field that changed its type within a group that shares a wire
    encoding (``int64`` to ``int32``) changed its ``int`` limit: the values its C member holds.
    (``alike=False``: no shortcut for a field ``_alike`` in both, for the tests.)"""
    old, now = pair.old, pair.by_number
    if now is None or now.cardinality != old.cardinality:
        return []
    if now.extension and now.cardinality == "repeated":
        return []  # nanopb's generator skips it: "only optional type of extension fields"
    if not change.compares_nanopb and (old.kind != "scalar" or old.type == now.type):
        return []  # nanopb's defaults on both sides, the same type: nothing can differ
    if not change.compatible(old, now):
        return []  # FIELD_TYPE_CHANGED's
    old_options, new_options = _options(change.old, old), _options(change.new, now)
    if alike and old.kind != "enum" and _alike(old, now, old_options, new_options):
        return []  # the same limits (an enum field's come from its enum's options)
    was, is_ = _wire_type(old, old_options), _wire_type(now, new_options)
    if not _compatible(change, was, is_):
        return []  # NANOPB_LAYOUT_CHANGED's (type_override)
    before = _limits(change.old, old, was, old_options)
    after = _limits(change.new, now, is_, new_options)
    if was != is_ and "int" in before and "int" in after:  # name the types that differ
        before["int"], after["int"] = _typed(before["int"], was), _typed(after["int"], is_)
    return [
        (what, before[what], after[what])
        for what in sorted(before.keys() & after.keys())
        if before[what][:2] != after[what][:2]
    ]


def _narrowed(before: Limit, after: Limit) -> bool:
    """Whether a value ``before`` allows may be one ``after`` does not."""
    return before[0] < after[0] or before[1] > after[1]


def _limits(revision: Revision, field: Field, wire: str, options: Options) -> dict[str, Limit]:
    """The limits nanopb's options put on a field whose values travel as ``wire`` (its type, or
    its ``type_override``). ``max_size``, ``max_length`` and ``max_count`` bound only a static
    field (a callback or pointer field has no storage of that size); ``int_size`` sets an
    integer's width, never an enum's (the generator ignores it there): an enum's is its
    ``enum_intsize`` (``nanopb_enumopt``)."""
    found: dict[str, Limit] = {}
    static = allocation(field, options) == "static"
    if static and field.cardinality == "repeated" and options.HasField("max_count"):
        found["count"] = (0, int(options.max_count), f"max_count:{options.max_count}")
    if static and field.type == "string" and options.HasField("max_length"):
        found["bytes"] = (0, int(options.max_length), f"max_length:{options.max_length}")
    elif static and field.type == "string" and options.HasField("max_size"):  # and the NUL
        found["bytes"] = (0, int(options.max_size) - 1, f"max_size:{options.max_size}")
    elif static and field.type == "bytes" and options.HasField("max_size"):
        found["bytes"] = (0, int(options.max_size), f"max_size:{options.max_size}")
    if wire in _WIDTHS:
        size = int(options.int_size)
        low, high = _range(wire in _SIGNED, size or _WIDTHS[wire])
        found["int"] = (low, high, f"int_size:{_INT_SIZES.get(size, size)}")
    elif wire == "bool":
        found["int"] = (0, 1, "bool")
    elif field.kind == "enum" and wire == field.type:
        enum = revision.enum_options(field.type) if revision.has_nanopb_options() else None
        size = int(enum.enum_intsize) if enum is not None else 0
        low, high = _range(True, size or 32)  # pb_decode reads an enum as a signed varint
        found["int"] = (low, high, f"enum_intsize:{_INT_SIZES.get(size, size)}")
    return found


def _range(signed: bool, bits: int) -> tuple[int, int]:
    """The values a C integer of ``bits`` holds."""
    return (-(2 ** (bits - 1)), 2 ** (bits - 1) - 1) if signed else (0, 2**bits - 1)


def _typed(limit: Limit, wire: str) -> Limit:
    """``limit`` written with its type: ``int64``, ``int32 int_size:IS_8``."""
    shown = wire if limit[2] in ("int_size:IS_DEFAULT", "bool") else f"{wire} {limit[2]}"
    return limit[0], limit[1], shown


def _damage(wire: str, before: Limit, after: Limit) -> str:
    """What a receiver of type ``wire``, holding the values ``after`` allows, makes of one only
    ``before`` allows, as nanopb's pb_dec_varint does: a bool reads any value but 0 as true; a
    plain signed varint (int32, int64, an enum) stored in 32 bits or fewer first keeps the low 32
    bits of the value, silently; what is still out of range fails the message."""
    if wire == "bool":
        return "read every value but 0 that OLD's senders may send as true"
    low, high = -(2**31), 2**31 - 1
    plain = (wire in ("int32", "int64") or wire not in _WIDTHS) and after[1] <= high
    cut = plain and (before[0] < low or before[1] > high)  # values past 32 bits
    fails = not plain or after[1] < high or not cut
    misread = "misread (nanopb keeps its low 32 bits)"
    rejected = 'fail to decode ("integer too large")'
    verbs = " or ".join(text for text, applies in ((misread, cut), (rejected, fails)) if applies)
    return f"{verbs} a wider value that OLD's senders may send"


def _layout(field: Field, options: Options) -> dict[str, str]:
    """What decides a field's place in nanopb's struct, as a message names each part."""
    found = {"type": allocation(field, options)}
    if field.type == "bytes":
        found['option "fixed_length"'] = _flag(options.fixed_length)
    if field.cardinality == "repeated":
        found['option "fixed_count"'] = _flag(options.fixed_count)
    return found


def _alike(old: Field, new: Field, old_options: Options, new_options: Options) -> bool:
    """Whether a field has the same type, cardinality and nanopb options in both revisions: then
    nanopb encodes, stores and limits it alike (but an enum's ``enum_intsize``, its enum's), and
    neither the limit rules nor the layout rule need look further. The shortcut matters where an
    options file makes every field pair compared. test_nanopb_shortcut_agrees_with_the_plain_rules
    holds it to the rules without it."""
    return (
        old.type == new.type and old.cardinality == new.cardinality and old_options == new_options
    )


def _options(revision: Revision, field: Field) -> Options:
    """nanopb's options for ``field``; its defaults where the tree sets none (resolving them
    compiles nanopb's vocabulary, which a tree without options never needs)."""
    return revision.field_options(field) if revision.has_nanopb_options() else _defaults()


@functools.cache
def _defaults() -> Options:
    return options_class()()


def _wire_type(field: Field, options: Options) -> str:
    """The type nanopb encodes ``field`` as: its ``type_override``, else its own."""
    if options.HasField("type_override"):
        return _FD.Type.Name(options.type_override).removeprefix("TYPE_").lower()
    return field.type


def _compatible(change: Change, old: str, new: str) -> bool:
    """FIELD_TYPE_CHANGED's test on the types nanopb encodes: the same scalar group, the same
    (or renamed) message or enum."""
    return wire_compatible(old, new) or change.same_type(old, new)


def _same_type(change: Change, old: Field, new: Field) -> bool:
    """Whether NEW's field has OLD's type: the same keyword, or the same (or renamed) type."""
    return old.type == new.type if old.kind == "scalar" else change.same_type(old.type, new.type)


def _flag(value: bool) -> str:
    return "true" if value else "false"


def _now(pair: FieldPair) -> Field:
    assert pair.by_number is not None  # limit_changes found changes
    return pair.by_number


def _field(pair: FieldPair) -> str:
    return field_prefix(_now(pair), pair.new_owner.name)
