"""Rules over one revision: what the tree holds, graded by whether OLD held it too (and, with
a ledger, what the tree's history held)."""

import re
from collections.abc import Iterator
from typing import TYPE_CHECKING

from erc_codec.schema import Location

from .._loader import relative
from .._model import Revision
from .._pairing import Change, wire_compatible
from ._registry import tree_rule

if TYPE_CHECKING:
    from .._ledger import Entry, Key, Ledger

Report = Iterator[tuple[str, Location, str]]


@tree_rule("COMPILE", "A file does not compile (protoc's own diagnostic); the rest still load.")
def compile_errors(revision: Revision, change: Change) -> Report:
    for problem in revision.problems:
        if problem.kind == "COMPILE":
            yield problem.key, problem.location, problem.text


@tree_rule("IMPORT_AMBIGUOUS", "An import's spelling matches more than one file of the tree.")
def import_ambiguous(revision: Revision, change: Change) -> Report:
    for problem in revision.problems:
        if problem.kind == "IMPORT_AMBIGUOUS":
            yield problem.key, problem.location, problem.text


@tree_rule(
    "NAME_COLLISION",
    "Two definitions (message, enum or enum value) share a global name anywhere in the tree.",
)
def name_collision(revision: Revision, change: Change) -> Report:
    for name, definitions in sorted(revision.definitions.items()):
        if len(definitions) < 2:
            continue
        places = sorted(((d.kind, d.location) for d in definitions), key=lambda p: p[1])
        listed = " and ".join(f"{kind} at {where}" for kind, where in places)
        # Point at a definition the other revision lacks, if any: that is the one to look at.
        other = change.old if revision is change.new else change.new
        known = {
            (relative(other.root, d.location.path), d.location.line)
            for d in other.definitions.get(name, [])
        }
        fresh = [
            where
            for _, where in places
            if (relative(revision.root, where.path), where.line) not in known
        ]
        yield (
            name,
            (fresh or [places[-1][1]])[-1],
            f'Name "{name}" is defined {len(places)} times: {listed}.',
        )


@tree_rule(
    "EMBEDDED_ROOT_MISSING",
    "A configured embedded root is not a message of the tree, so nothing is checked for it.",
)
def embedded_root_missing(revision: Revision, change: Change) -> Report:
    config = change.config
    if not config.roots_chosen or not revision.tree.files:
        return
    where = Location(config.source or str(revision.root), max(config.roots_line, 1), 1)
    broken = [revision.tree.texts.get(name, "") for name in revision.tree.failed]
    for root in config.roots:
        defined = re.compile(rf"\bmessage\s+{re.escape(root.rsplit('.', 1)[-1])}\b")
        hidden = any(defined.search(text) for text in broken)  # in a file that failed?
        if root not in revision.messages and not hidden:
            yield (
                root,
                where,
                f'Embedded root "{root}" is not a message of the tree: no fixed-size rule or '
                "size check covers what it was meant to reach.",
            )


@tree_rule(
    "EMBEDDED_REPEATED",
    "A repeated field in a message an embedded root reaches: embedded boards need fixed sizes.",
)
def embedded_repeated(revision: Revision, change: Change) -> Report:
    for root in change.config.roots:
        for path, field in revision.reach(root):
            if field.cardinality == "repeated":
                yield (
                    f"{root}:{change.old_name(revision, field.owner)}.{field.name}",
                    field.location,
                    f'Field "{field.number}" with name "{field.name}" on message "{field.owner}" '
                    f'is repeated, and embedded root "{root}" reaches it as {path}.',
                )


@tree_rule(
    "EMBEDDED_UNBOUNDED",
    "A string or bytes field without nanopb max_size in a message an embedded root reaches.",
)
def embedded_unbounded(revision: Revision, change: Change) -> Report:
    for root in change.config.roots:
        for path, field in revision.reach(root):
            if field.type not in ("string", "bytes") or revision.bounded(field):
                continue
            yield (
                f"{root}:{change.old_name(revision, field.owner)}.{field.name}",
                field.location,
                f'Field "{field.number}" with name "{field.name}" on message "{field.owner}" is '
                f'{field.type} without nanopb max_size, and embedded root "{root}" reaches it as '
                f"{path}.",
            )


@tree_rule(
    "LEDGER_NUMBER_REUSED",
    "A number the ledger says once carried another name or an incompatible type is used again.",
)
def ledger_number_reused(revision: Revision, change: Change) -> Report:
    ledger = change.ledger
    if ledger is None:
        return
    from .._ledger import Key  # loaded already: the ledger was read

    for message in sorted(revision.messages.values(), key=lambda m: m.name):
        for entry in sorted(message.fields.values(), key=lambda f: f.number):
            key = Key("message", message.name, entry.number, entry.name, entry.type)
            clashes = [
                past
                for past in ledger.at("message", message.name, entry.number)
                if past.key.name != entry.name or not _same_kind(change, past.key.type, entry.type)
            ]
            if clashes and not _acknowledged(change, ledger, key):
                yield (
                    _id(key),
                    entry.location,
                    f'Field "{entry.number}" with name "{entry.name}" on message "{message.name}" '
                    f"reuses a number that carried {_history(ledger, clashes)}.",
                )
    for enum in sorted(revision.enums.values(), key=lambda e: e.name):
        for value in sorted(enum.values.values(), key=lambda v: v.number):
            live = {v.name for v in enum.by_name.values() if v.number == value.number}
            keys = [Key("enum", enum.name, value.number, name, "-") for name in sorted(live)]
            clashes = [
                past
                for past in ledger.at("enum", enum.name, value.number)
                if past.key.name not in live
            ]
            if clashes and not any(_acknowledged(change, ledger, key) for key in keys):
                yield (
                    _id(keys[0]),
                    value.location,
                    f'Enum value "{value.number}" with name "{value.name}" on enum "{enum.name}" '
                    f"reuses a number that carried {_history(ledger, clashes)}.",
                )


def _same_kind(change: Change, past: str, now: str) -> bool:
    """Whether a field of type ``now`` reads what type ``past`` wrote (a message or enum type
    renamed with an identical body in this change counts as itself)."""
    return wire_compatible(past, now) or change.renamed.get(past) == now


def _acknowledged(change: Change, ledger: "Ledger", key: "Key") -> bool:
    """Whether the ledger accepts this use of the number: an ``ack`` on an entry with this name
    and a type that reads the same bytes (an acknowledged ``sint32`` covers its widening to
    ``sint64``)."""
    return any(
        past.ack and past.key.name == key.name and _same_kind(change, past.key.type, key.type)
        for past in ledger.at(key.kind, key.container, key.number)
    )


def _history(ledger: "Ledger", clashes: "list[Entry]") -> str:
    def one(past: "Entry") -> str:
        kind = "" if past.key.type == "-" else f' ("{past.key.type}")'
        since = "" if past.since == "-" else f" since revision {past.since}"
        return f'"{past.key.name}"{kind}{since} ({ledger.where(past)})'

    return " and ".join(one(past) for past in clashes)


def _id(key: "Key") -> str:
    return f"{key.kind}:{key.container}:{key.number}:{key.name}:{key.type}"
