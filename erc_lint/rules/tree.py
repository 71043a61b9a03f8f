"""Rules over one revision: what the tree holds, graded by whether OLD held it too (and, with
a ledger, what the tree's history held). Each is handed one revision, OLD and then NEW, and names
every piece of damage by a key: a key OLD reports too is old damage (a warning), not new."""

from typing import TYPE_CHECKING

from erc_schema import Location

from .._model import Definition, Enum, EnumValue, Field, Message, Revision
from .._pairing import Change, wire_compatible
from ._registry import Report, Reports, field_prefix, tree_rule

if TYPE_CHECKING:
    from .._ledger import Entry, Key, Ledger


@tree_rule("COMPILE", "A file does not compile (protoc's own diagnostic); the rest still load.")
def compile_errors(revision: Revision, change: Change) -> Reports:
    """## What it does
    Reports each of protoc's diagnostics for a file that does not compile, at protoc's own
    location and in its words (an error inside an imported file once, naming the importer).
    Every other file is still loaded and checked. A file of OLD that does not compile while
    NEW's does is a warning too: its messages could not be compared.

    ## Why is this bad?
    Nothing in the file can be checked, and every build that runs protoc on it fails: nanopb's
    generator for the boards, the base station's code generation, erc_codec's schema.

    ## Example
    Before:
    ```proto
    message Diagnostics { float temperature = 1; }
    ```
    After:
    ```proto
    message Diagnostics { float temperature = 1 }
    ```

    ## Use instead
    Fix what protoc says (here: `Expected ";".`), or `exclude` a draft file in `[tool.erc-lint]`.
    """
    for problem in revision.problems:
        if problem.kind == "COMPILE":
            yield Report(problem.location, problem.text, key=problem.key)


@tree_rule("IMPORT_AMBIGUOUS", "An import's spelling matches more than one file of the tree.")
def import_ambiguous(revision: Revision, change: Change) -> Reports:
    """## What it does
    Reports an import whose spelling names no file as it stands and matches several once
    resolved the ways trees in the field spell imports (a bare file name found in two folders,
    a prefixed path whose tail is two files).

    ## Why is this bad?
    Which file protoc reads then depends on the include folders each build passes: the boards'
    firmware and the base station may compile different definitions from the same import, and
    send each other bytes the other side reads by another schema.

    ## Example
    Before: `a/shape.proto` and `b/shape.proto` both exist, and
    ```proto
    import "a/shape.proto";
    ```
    After:
    ```proto
    import "shape.proto";
    ```

    ## Use instead
    Spell the import from the tree's root: `import "a/shape.proto";`.
    """
    for problem in revision.problems:
        if problem.kind == "IMPORT_AMBIGUOUS":
            yield Report(problem.location, problem.text, key=problem.key)


@tree_rule(
    "NAME_COLLISION",
    "Two definitions (message, enum or enum value) share a global name anywhere in the tree.",
)
def name_collision(revision: Revision, change: Change) -> Reports:
    """## What it does
    Reports a global name that two or more definitions take anywhere in the tree, even in files
    never compiled together, with every location. Without a `package`, messages, enums and enum
    values share one namespace, and an enum value is a sibling of its enum (C++ scoping).

    ## Why is this bad?
    nanopb compiles one file at a time and never notices, so the collision waits for the first
    build that includes both files: protoc refuses the second definition ("already defined"),
    a Python descriptor pool raises "duplicate symbol", C code gets two structs of one name.
    Until then, two boards may mean different things by one name.

    ## Example
    Before:
    ```proto
    // gps.proto
    message SensorBoardGPSInfo { double latitude = 1; }
    ```
    After, beside it:
    ```proto
    // leftover/message_types.proto
    enum PBMessageType { SensorBoardGPSInfo = 0; }
    ```

    ## Use instead
    Rename one of them, with its component's prefix (`PB_MESSAGE_TYPE_GPS_INFO = 0;`), or delete
    the leftover file.
    """
    other = change.old if revision is change.new else change.new
    for name, definitions in sorted(revision.definitions.items()):
        if len(definitions) < 2 or len(_counted(revision, change, definitions)) < 2:
            continue  # no collision, or only with files ignore_only calls leftovers
        places = sorted(((d.kind, d.location) for d in definitions), key=lambda p: p[1])
        listed = " and ".join(f"{kind} at {where}" for kind, where in places)
        # Point at a definition the other revision lacks, if any: that is the one to look at.
        known = {other.place(d.location) for d in other.definitions.get(name, [])}
        fresh = [where for _, where in places if revision.place(where) not in known]
        yield Report(
            (fresh or [places[-1][1]])[-1],
            f'Name "{name}" is defined {len(places)} times: {listed}.',
            key=name,
        )


def _counted(revision: Revision, change: Change, definitions: list[Definition]) -> list[Definition]:
    """The definitions of one name that count: those outside the files ``ignore_only`` names
    for NAME_COLLISION (leftovers), but every one when all are there."""
    config = change.config
    kept = [d for d in definitions if not config.ignored_at("NAME_COLLISION", _file(revision, d))]
    return kept or definitions


def _file(revision: Revision, definition: Definition) -> str:
    return revision.place(definition.location)[0]


@tree_rule(
    "EMBEDDED_ROOT_MISSING",
    "A configured embedded root is not a message of the tree, so nothing is checked for it.",
)
def embedded_root_missing(revision: Revision, change: Change) -> Reports:
    """## What it does
    Reports an embedded root named in `[tool.erc-lint] roots` (or given a `budget`) that is no
    message of the tree (nor declared in a file that does not compile, which `COMPILE` reports),
    located at the configuration's `roots` line (or `budget` line).

    ## Why is this bad?
    The embedded rules (`EMBEDDED_REPEATED`, `EMBEDDED_UNBOUNDED`, `ENVELOPE_SIZE_GROWN`,
    `ENVELOPE_OVER_BUDGET`) start from the roots: a root that names nothing, a typo or a
    message renamed since, turns them off in silence, and an unbounded field or a grown
    envelope then reaches the boards unseen.

    ## Example
    Before: `roots = ["RoverEnvelope"]`, and
    ```proto
    message RoverEnvelope { oneof payload { PHInfo ph_info = 1; } }
    ```
    After, with the same configuration:
    ```proto
    message PBEnvelope { oneof payload { PHInfo ph_info = 1; } }
    ```

    ## Use instead
    Name the message as the tree does: `roots = ["PBEnvelope"]`.
    """
    config = change.config
    if not config.roots_chosen or not revision.tree.files:
        return
    where = Location(config.source or str(revision.root), max(config.roots_where, 1), 1)
    for root in config.roots:
        if root not in revision.messages and not revision.declared_in_failed_file(root):
            yield Report(
                where,
                f'Embedded root "{root}" is not a message of the tree: no fixed-size rule or '
                "size check covers what it was meant to reach.",
                key=root,
            )


@tree_rule(
    "EMBEDDED_REPEATED",
    "A repeated field in a message an embedded root reaches: embedded boards need fixed sizes.",
    categories=("TREE", "NANOPB"),
)
def embedded_repeated(revision: Revision, change: Change) -> Reports:
    """## What it does
    Reports a `repeated` field (a map too) of any message an embedded root reaches, with the
    path from the root (`PBEnvelope.status.readings`).

    ## Why is this bad?
    The boards decode into fixed-size C structs and drop datagrams longer than the root's
    `<Root>_size`. nanopb gives a repeated field without `max_count` no storage but a callback,
    and the root no size at all; with `max_count` it is an array and a count, and every buffer
    is sized for the full array. The fleet's contract is that nothing an embedded root reaches
    is repeated, so that `PBEnvelope_size` stays a small constant.

    ## Example
    Before:
    ```proto
    message PBEnvelope { oneof payload { ArmStatus arm_status = 1; } }
    message ArmStatus { float angle = 1; }
    ```
    After:
    ```proto
    message PBEnvelope { oneof payload { ArmStatus arm_status = 1; } }
    message ArmStatus { repeated float angles = 1; }
    ```

    ## Use instead
    A fixed set of singular fields (`float shoulder = 1; float elbow = 2;`), or the list in a
    message no embedded root reaches.
    """
    for root in change.config.roots:
        for path, field in revision.reach(root):
            if field.cardinality == "repeated":
                yield Report(
                    field,
                    f'{field_prefix(field, field.owner)} is repeated, and embedded root "{root}" '
                    f"reaches it as {path}.",
                    key=_reached(revision, change, root, field),
                )


@tree_rule(
    "EMBEDDED_UNBOUNDED",
    "A field nanopb gives no fixed size (a string or bytes without max_size, a callback or"
    " pointer, a proto2 group) in a message an embedded root reaches.",
    categories=("TREE", "NANOPB"),
)
def embedded_unbounded(revision: Revision, change: Change) -> Reports:
    """## What it does
    Reports a `string` or `bytes` field without nanopb's `max_size` (or `max_length`), from a
    `.options` file or an annotation, and any field set to `FT_CALLBACK` or `FT_POINTER`
    (whatever its `max_size`: nanopb bounds only static fields), in any message an embedded root
    reaches. A repeated field without `max_count` is `EMBEDDED_REPEATED`'s. A proto2 group it
    reaches is reported too, and a root whose file nanopb's generator refuses for a group it
    does not reach (elsewhere in its file, or in a file it imports): the generator has no
    groups, and writes no code for the file at all (`NotImplementedError`).

    ## Why is this bad?
    nanopb turns an unbounded string or bytes field into a callback with no storage, and every
    message that holds it, up to the root, loses its `<Name>_size` ("depends on runtime
    parameters"): the boards can no longer size their buffers, and erc_codec refuses to load
    the schema for that root.

    ## Example
    Before:
    ```proto
    message PBEnvelope { oneof payload { Reading reading = 1; } }
    message Reading { uint32 code = 1; }
    ```
    After:
    ```proto
    message PBEnvelope { oneof payload { Reading reading = 1; } }
    message Reading { uint32 code = 1; string label = 2; }
    ```

    ## Use instead
    Bound it: a line `Reading.label max_size:16` in the `.options` file beside the `.proto`, or
    `string label = 2 [(nanopb).max_size = 16];`.
    """
    for root in change.config.roots:
        grouped = False
        for path, field in revision.reach(root):
            why = _unbounded(revision, field)
            if why is not None:
                grouped = grouped or why.startswith(_GROUP)
                yield Report(
                    field,
                    f'{field_prefix(field, field.owner)} is {why}, and embedded root "{root}" '
                    f"reaches it as {path}.",
                    key=_reached(revision, change, root, field),
                )
        message = revision.messages.get(root)
        refusal = revision.refusal(root) if message is not None and not grouped else None
        if message is not None and refusal is not None:
            yield Report(
                message,
                f'Embedded root "{root}" has no fixed size: {refusal}.',
                key=f"{root}:refused",
            )


_GROUP = "a proto2 group"


def _unbounded(revision: Revision, field: Field) -> str | None:
    """Why nanopb gives ``field`` no fixed size, if it gives it none: a string or bytes field
    without a limit, any field set to be a callback or pointer (``max_size`` or not), a proto2
    group (the generator refuses its file) unless nanopb leaves it out or encodes it as another
    type. A repeated field without ``max_count`` is EMBEDDED_REPEATED's."""
    if field.encoding == "group":
        if revision.has_nanopb_options() and (
            revision.allocation(field) == "ignore"
            or revision.field_options(field).HasField("type_override")
        ):
            return None  # left out, or not written as a group: the generator takes the file
        return f"{_GROUP}, which nanopb's generator does not implement (it refuses the file)"
    text = field.type in ("string", "bytes")
    if not text and not revision.has_nanopb_options():
        return None  # nanopb's defaults: every other field is static
    stored = revision.allocation(field)
    if stored in ("static", "ignore"):
        return None
    if int(revision.field_options(field).type):  # FT_CALLBACK or FT_POINTER, set on purpose
        return f"a nanopb {stored} field"
    return f"{field.type} without nanopb max_size" if text else None


def _reached(revision: Revision, change: Change, root: str, field: Field) -> str:
    """The key of damage a root reaches: by the names OLD used, so a rename keeps it old."""
    return f"{root}:{change.old_name(revision, field.owner)}.{field.name}"


@tree_rule(
    "LEDGER_NUMBER_REUSED",
    "A number the ledger says once carried another name or an incompatible type is used again.",
)
def ledger_number_reused(revision: Revision, change: Change) -> Reports:
    """## What it does
    With a ledger (`erc-lint.lock`), reports a field or enum number that the ledger says once
    carried another name, or a type that reads other bytes, naming that first use's revision
    and ledger line. Reserving the number, or an `ack` on the new use's ledger line, silences it.

    ## Why is this bad?
    It is `FIELD_NUMBER_REUSED` across the whole history: a board still running firmware from
    the revision that first used the number sends the old field under it, and a receiver built
    from NEW reads those bytes as the new one (a wrong value; with another wire type, a message
    nanopb cannot decode). Two revisions cannot show it once the old field is a few changes back.

    ## Example
    Ledger: `message Diagnostics 2 temperature float 8b460ccd5c8c`, and now:
    ```proto
    message Diagnostics {
      uint32 error_count = 2;
    }
    ```

    ## Use instead
    Give the field a number the ledger does not know and reserve the old one (`reserved 2;`). A
    deliberate reuse, when no board sends the old field any more, ends the new use's ledger line
    with `ack  # why`.
    """
    ledger = change.ledger
    if ledger is None:
        return
    # A name two files define (NAME_COLLISION) is checked in every definition that counts
    # (not in a leftover ignore_only names): a build may compile any of them.
    for definitions in revision.definitions.values():
        for definition in _counted(revision, change, definitions):
            if isinstance(definition, Message):
                for field in definition.fields.values():
                    yield from _field_reuse(revision, change, ledger, field, definition)
            elif isinstance(definition, Enum):
                for value in definition.values.values():
                    names = sorted(definition.names(value.number))
                    yield from _value_reuse(revision, change, ledger, value, names, definition)


def _field_reuse(
    revision: Revision, change: Change, ledger: "Ledger", field: Field, message: Message
) -> Reports:
    # Loaded already (the ledger was read): linting without a ledger never imports it.
    from .._ledger import Key

    key = Key("message", field.owner, field.number, field.name, field.type)
    clashes = [
        past
        for past in ledger.at("message", field.owner, field.number)
        if past.key.name != field.name
        or not _same_kind(revision, change, ledger, past.key.type, field.type)
    ]
    if clashes and not _acknowledged(revision, change, ledger, key):
        names = {f.name for f in message.fields.values()}
        renamed = all(
            p.key.name not in names and _same_kind(revision, change, ledger, p.key.type, field.type)
            for p in clashes
        )
        yield Report(
            field,
            f"{field_prefix(field, field.owner)} reuses a number that carried "
            f"{_history(ledger, clashes)}.",
            key=_id(key),
            fix="restore the old name"
            if renamed
            else f"use {_free(ledger, message)} and reserve {field.number}",
            like="FIELD_RENAMED" if renamed else "",
        )


def _value_reuse(
    revision: Revision,
    change: Change,
    ledger: "Ledger",
    value: EnumValue,
    live: list[str],
    enum: Enum,
) -> Reports:
    """``value``, the first name of its number, with ``live``, every name of the number. On the
    wire an enum value is its number: another name for it is a rename, graded as diff grades
    one (``ENUM_VALUE_RENAMED``)."""
    from .._ledger import Key  # loaded already: see _field_reuse

    keys = [Key("enum", value.owner, value.number, name, "-") for name in live]
    clashes = [
        past for past in ledger.at("enum", value.owner, value.number) if past.key.name not in live
    ]
    if clashes and not any(_acknowledged(revision, change, ledger, key) for key in keys):
        # a pure rename, unless an old name of the number lives on under another number
        renamed = not any(p.key.name in enum.by_name for p in clashes)
        yield Report(
            value,
            f'Enum value "{value.number}" with name "{value.name}" on enum "{value.owner}" '
            f"reuses a number that carried {_history(ledger, clashes)}.",
            key=_id(keys[0]),
            fix="restore the old name, or add it as an alias"
            if renamed
            else f"use {_free_value(ledger, enum)} and reserve {value.number}",
            like="ENUM_VALUE_RENAMED" if renamed else "",
        )


def _same_kind(revision: Revision, change: Change, ledger: "Ledger", past: str, now: str) -> bool:
    """Whether a field of type ``now`` reads what type ``past`` wrote: a message or enum type
    renamed with an identical body counts as itself, in this change or in the ledger's history
    (every number the ledger has for ``past``, with its name and type, is ``now``'s body)."""
    if wire_compatible(past, now) or change.renamed.get(past) == now:
        return True
    if past in revision.messages or past in revision.enums:
        return False  # both types exist: two types, not one renamed
    if now in revision.messages:
        body = {(f.number, f.name, f.type) for f in revision.messages[now].fields.values()}
        return bool(body) and ledger.body("message", past) == body
    if now in revision.enums:
        values = {(v.number, v.name, "-") for v in revision.enums[now].by_name.values()}
        return bool(values) and ledger.body("enum", past) == values
    return False


def _acknowledged(revision: Revision, change: Change, ledger: "Ledger", key: "Key") -> bool:
    """Whether the ledger accepts this use of the number: an ``ack`` on an entry with this name
    and a type that reads the same bytes (an acknowledged ``sint32`` covers its widening to
    ``sint64``)."""
    return any(
        past.ack
        and past.key.name == key.name
        and _same_kind(revision, change, ledger, past.key.type, key.type)
        for past in ledger.at(key.kind, key.container, key.number)
    )


def _free_value(ledger: "Ledger", enum: Enum) -> str:
    """The next enum number neither the ledger nor NEW's enum has used, nor reserved."""
    used = {number for number, _, _ in ledger.body("enum", enum.name)} | set(enum.values)
    number = max(used, default=0) + 1
    while enum.reserved.covers(number):
        number += 1
    return f"number {number} (the next free one)"


def _free(ledger: "Ledger", message: Message) -> str:
    """The next number neither the ledger nor NEW's message has used, nor reserved."""
    used = {number for number, _, _ in ledger.body("message", message.name)} | set(message.fields)
    number = max(used, default=0) + 1
    while message.reserved.covers(number):
        number += 1
    return f"number {number} (the next free one)"


def _history(ledger: "Ledger", clashes: "list[Entry]") -> str:
    def one(past: "Entry") -> str:
        kind = "" if past.key.type == "-" else f' ("{past.key.type}")'
        since = "" if past.since == "-" else f" since revision {past.since}"
        return f'"{past.key.name}"{kind}{since} ({ledger.where(past)})'

    return " and ".join(one(past) for past in clashes)


def _id(key: "Key") -> str:
    return f"{key.kind}:{key.container}:{key.number}:{key.name}:{key.type}"
