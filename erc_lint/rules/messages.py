"""Rules on whole messages and enums: deletions, renames, reservations, the envelope's size."""

from collections.abc import Iterator
from pathlib import Path

from google.protobuf import descriptor_pb2

from erc_codec import SchemaError
from erc_codec.schema import Declaration, Location, Schema, Sizes, declarations

from .._model import Enum, Message, Revision
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
        old_files, new_files = _files(change.old, root), _files(change.new, root)
        if _size_inputs(change.old, old_files, root) == _size_inputs(change.new, new_files, root):
            continue  # nothing nanopb sizes the root from has changed
        before = max_size(change.old, old_files, root)
        after = max_size(change.new, new_files, root)
        if before is not None and after is not None and after > before:
            yield (
                message.location,
                f'Maximum size of message "{root}" grew from {before} to {after} bytes: receivers '
                f"built with the old {root.replace('.', '_')}_size drop the longer datagrams.",
                False,
            )


def _files(revision: Revision, root: str) -> dict[str, descriptor_pb2.FileDescriptorProto]:
    """The file defining message ``root`` and every file it imports, each after its imports:
    what protoc resolved the root's types in (the tree may define a name twice elsewhere)."""
    files = revision.tree.imported
    order: dict[str, descriptor_pb2.FileDescriptorProto] = {}

    def visit(name: str) -> None:
        if name in files and name not in order:
            for dependency in files[name].dependency:
                visit(dependency)
            order[name] = files[name]

    if root in revision.messages:
        visit(revision.messages[root].file)
    return order


def _size_inputs(
    revision: Revision, files: dict[str, descriptor_pb2.FileDescriptorProto], root: str
) -> dict[tuple[str, str], object]:
    """What nanopb computes ``root``'s size from: the descriptor of every message and enum it
    reaches (without source locations, so comments and layout don't count) and, for each file
    holding one, its package, syntax, edition, file options and ``.options`` text."""
    index: dict[str, tuple[descriptor_pb2.FileDescriptorProto, Declaration]] = {}
    for file in files.values():
        for declared in declarations(file):
            index.setdefault(declared.name, (file, declared))
    found: dict[tuple[str, str], object] = {}
    pending = [root]
    while pending:
        name = pending.pop()
        if ("type", name) in found or name not in index:
            continue
        file, declared = index[name]
        proto = declared.proto
        found["type", name] = proto.SerializeToString(deterministic=True)
        if isinstance(proto, descriptor_pb2.DescriptorProto):
            pending.extend(f.type_name.lstrip(".") for f in proto.field if f.type_name)
        if ("file", file.name) not in found:
            options = revision.root / Path(file.name).with_suffix(".options")
            text = options.read_bytes() if options.is_file() else None
            settings = file.options.SerializeToString(deterministic=True)
            found["file", file.name] = (file.package, file.syntax, file.edition, settings, text)
    return found


def max_size(
    revision: Revision, files: dict[str, descriptor_pb2.FileDescriptorProto], root: str
) -> int | None:
    """nanopb's ``<root>_size`` in this revision, compiled from ``files`` (``_files``), ``None``
    where it has none (or no such root)."""
    if not files:
        return None
    try:
        schema = Schema(revision.root, root, descriptor_pb2.FileDescriptorSet(file=files.values()))
        return Sizes(schema).max_size(root)
    except SchemaError:
        return None
