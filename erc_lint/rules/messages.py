"""Rules on whole messages and enums: deletions, renames, reservations, the envelope's size."""

from collections.abc import Iterator

from erc_codec.schema import Location

from .._model import Enum, Message
from .._pairing import Change
from ._registry import pair_rule

Report = Iterator[tuple[Location, str, bool]]


@pair_rule("MESSAGE_DELETED", "A message disappeared.", severity="warning")
def deleted(change: Change) -> Report:
    for message in change.deleted_messages:
        if message.map_entry:
            continue  # it went with its map field, which the field rules report
        yield message.location, f'Previously present message "{message.name}" was deleted.', True


@pair_rule(
    "MESSAGE_RENAMED",
    "A message changed its name but not its fields: harmless on the wire, breaks code.",
    severity="warning",
)
def renamed(change: Change) -> Report:
    for old, new in change.messages:
        if old.name == new.name or old.map_entry:  # a map entry follows its map field
            continue
        outer, _, inner = old.name.rpartition(".")
        if outer and change.renamed.get(outer) == new.name.removesuffix(f".{inner}"):
            continue  # declared inside a renamed message: that rename says it
        yield (
            new.location,
            f'Message "{old.name}" was renamed to "{new.name}"; its fields are unchanged.',
            False,
        )


@pair_rule("RESERVED_REMOVED", "A reserved number or name is no longer reserved.")
def reserved_removed(change: Change) -> Report:
    pairs: list[tuple[Message | Enum, Message | Enum, str]] = [
        *((old, new, "message") for old, new in change.messages),
        *((old, new, "enum") for old, new in change.enums),
    ]
    for old, new, kind in pairs:
        for low, high in old.reserved.ranges:
            free = new.reserved.first_free(low, high)
            if free is not None:
                span = f'"{low}"' if low == high else f'"{low} to {high}"'
                yield (
                    new.location,
                    f'Previously reserved range {span} on {kind} "{new.name}" is no longer '
                    f"reserved (first free number: {free}).",
                    False,
                )
        for name in sorted(old.reserved.names):
            if name not in new.reserved.names:
                yield (
                    new.location,
                    f'Previously reserved name "{name}" on {kind} "{new.name}" is no longer '
                    "reserved.",
                    False,
                )


@pair_rule(
    "ENVELOPE_SIZE_GROWN",
    "An embedded root's nanopb maximum size grew: receivers built with the old size drop more.",
    severity="warning",
)
def envelope_size_grown(change: Change) -> Report:
    for root in change.config.roots:
        message = change.new.messages.get(root)
        if message is None or root not in change.old.messages:
            continue
        # bench_lint's 30-file ratio: equal inputs spare two size computations (about 20 ms of a
        # 200 ms run); test_equal_size_inputs_mean_equal_sizes: the shortcut agrees with sizes.
        if change.old.size_inputs(root) == change.new.size_inputs(root):
            continue  # nothing nanopb sizes the root from has changed
        before, after = change.old.max_size(root), change.new.max_size(root)
        if before is not None and after is not None and after > before:
            yield (
                message.location,
                f'Maximum size of message "{root}" grew from {before} to {after} bytes: receivers '
                f"built with the old {root.replace('.', '_')}_size drop the longer datagrams.",
                False,
            )
