"""``erc-codec stubs OUT_DIR``: typing stubs (``.pyi``) for a schema's message classes.

One stub module, ``OUT_DIR/erc_messages.pyi`` (``--module`` names it otherwise), holds a class per
message (its fields with their Python types, a constructor with keyword arguments), a class per
enum (an ``int`` subclass with its values by name) and ``TypedCodec``, a ``Codec`` whose
``message_class`` is overloaded on every kind and message name. A user points mypy at OUT_DIR
(``mypy_path``, ``MYPYPATH``) and writes::

    if TYPE_CHECKING:
        from erc_messages import TypedCodec
    codec = cast("TypedCodec", erc_codec.Codec.default())

The module exists for mypy only: nothing imports it at run time. (mypy-protobuf writes stubs for
the ``_pb2`` modules protoc generates; erc_codec's classes come from a descriptor pool, never from
such modules, so those stubs would type no class a codec hands out.)
"""

import keyword
from pathlib import Path

import click
from google.protobuf.descriptor import Descriptor, EnumDescriptor, FieldDescriptor

from .._codec import Codec
from ._shared import Fatal, load, schema_options

__all__ = ["render_stubs", "stubs"]

_T = FieldDescriptor
# Qualified: a field named ``int`` would shadow the builtin in the annotations after it.
_SCALARS = {
    _T.CPPTYPE_INT32: "builtins.int",
    _T.CPPTYPE_INT64: "builtins.int",
    _T.CPPTYPE_UINT32: "builtins.int",
    _T.CPPTYPE_UINT64: "builtins.int",
    _T.CPPTYPE_DOUBLE: "builtins.float",
    _T.CPPTYPE_FLOAT: "builtins.float",
    _T.CPPTYPE_BOOL: "builtins.bool",
}


def _name(descriptor: Descriptor | EnumDescriptor) -> str:
    return descriptor.full_name.replace(".", "_")


def _value(field: FieldDescriptor) -> tuple[str, str]:
    """A field's type as an attribute, and what its constructor argument takes."""
    if field.message_type is not None:
        name = _name(field.message_type)
        return name, f"{name} | Mapping[builtins.str, Any]"
    if field.enum_type is not None:
        return "builtins.int", "builtins.int | builtins.str"
    if field.cpp_type == _T.CPPTYPE_STRING:
        kind = "builtins.bytes" if field.type == _T.TYPE_BYTES else "builtins.str"
        return kind, kind
    kind = _SCALARS[field.cpp_type]
    return kind, kind


def _field(field: FieldDescriptor) -> tuple[str, str]:
    """``(attribute annotation, constructor annotation)`` of a field, lists and maps too."""
    entry = field.message_type
    if entry is not None and entry.GetOptions().map_entry:
        key, _ = _value(entry.fields_by_name["key"])
        value, given = _value(entry.fields_by_name["value"])
        return f"MutableMapping[{key}, {value}]", f"Mapping[{key}, {given}] | None"
    value, given = _value(field)
    if field.is_repeated:
        container = "RepeatedCompositeFieldContainer" if entry else "RepeatedScalarFieldContainer"
        return f"{container}[{value}]", f"Iterable[{given}] | None"
    return value, f"{given} | None"


def _message(descriptor: Descriptor) -> list[str]:
    lines = [f"class {_name(descriptor)}(Message):"]
    fields = [f for f in descriptor.fields if not keyword.iskeyword(f.name)]
    for field in fields:
        lines.append(f"    {field.name}: {_field(field)[0]}")
    arguments = ", ".join(f"{f.name}: {_field(f)[1]} = ..." for f in fields)
    receiver = "self"  # positional-only, and named apart from every field (one may be ``self``)
    while receiver in descriptor.fields_by_name:
        receiver += "_"
    keywords = ", *, " + arguments if arguments else ""
    lines.append(f"    def __init__({receiver}, /{keywords}) -> None: ...")
    return lines


def _enum(descriptor: EnumDescriptor) -> list[str]:
    lines = [f"class {_name(descriptor)}(builtins.int):"]
    lines += [f"    {value.name}: ClassVar[builtins.int]" for value in descriptor.values]
    return lines or ["    pass"]


def _reachable(codec: Codec) -> tuple[dict[str, Descriptor], dict[str, EnumDescriptor]]:
    """Every message of the schema's own files and every one the root reaches, and every enum
    they use or the files declare, by full name."""
    messages: dict[str, Descriptor] = {}
    enums: dict[str, EnumDescriptor] = {}
    pending = [codec.schema.root, *codec.schema.messages()]
    while pending:
        descriptor = pending.pop()
        if descriptor.full_name in messages:
            continue
        messages[descriptor.full_name] = descriptor
        for field in descriptor.fields:
            if field.message_type is not None:
                pending.append(field.message_type)
            if field.enum_type is not None:
                enums[field.enum_type.full_name] = field.enum_type
        enums.update((enum.full_name, enum) for enum in descriptor.enum_types)
    for file in codec.schema.files:
        for declared in file.enum_type:
            name = f"{file.package}.{declared.name}" if file.package else declared.name
            enums[name] = codec.schema.pool.FindEnumTypeByName(name)
    return messages, enums


def render_stubs(codec: Codec) -> str:
    """The stub module's text for ``codec``'s schema."""
    messages, enums = _reachable(codec)
    out = [
        f"# Typing stubs for the messages of {codec.root}'s schema, by erc-codec stubs: for",
        "# mypy only (see erc_codec.cli._stubs); write them again when the schema changes.",
        "import builtins",
        "from collections.abc import Iterable, Mapping, MutableMapping",
        "from typing import Any, ClassVar, Literal, overload",
        "",
        "from google.protobuf.internal.containers import (",
        "    RepeatedCompositeFieldContainer,",
        "    RepeatedScalarFieldContainer,",
        ")",
        "from google.protobuf.message import Message",
        "",
        "import erc_codec",
        "",
    ]
    for enum in sorted(enums.values(), key=_name):
        out += [*_enum(enum), ""]
    for descriptor in sorted(messages.values(), key=_name):
        out += [*_message(descriptor), ""]
    names: dict[str, list[str]] = {name: [name] for name in messages}
    for member in codec.members():
        names[member.message].insert(0, member.kind)
    out.append("class TypedCodec(erc_codec.Codec):")
    for full_name, spelled in sorted(names.items()):
        literal = ", ".join(f'"{name}"' for name in spelled)
        out += [
            "    @overload",
            f"    def message_class(self, name: Literal[{literal}]) -> "
            f"type[{_name(messages[full_name])}]: ...",
        ]
    out += ["    @overload", "    def message_class(self, name: str) -> type[Message]: ...", ""]
    return "\n".join(out)


@click.command()
@click.argument("out_dir", metavar="OUT_DIR", type=click.Path(file_okay=False, path_type=Path))
@click.option(
    "--module",
    default="erc_messages",
    show_default=True,
    help="The stub module's name (OUT_DIR/MODULE.pyi).",
)
@schema_options
def stubs(out_dir: Path, module: str, tree: str | None, root: str | None) -> None:
    """Write typing stubs for the schema's messages to OUT_DIR/MODULE.pyi.

    Every message as a class with its fields typed and a constructor of
    keyword arguments, every enum as an int subclass with its values by name,
    and TypedCodec, a Codec whose message_class knows each kind and message
    name. Point mypy at OUT_DIR (mypy_path or MYPYPATH) and type a codec:

    \b
      if TYPE_CHECKING:
          from erc_messages import TypedCodec
      codec = cast("TypedCodec", erc_codec.Codec.default())
      GPSInfo = codec.message_class("gps_info")  # type[SensorBoardGPSInfo]

    Exit status: 0 written; 2 a schema that does not load, or OUT_DIR that
    cannot be written.
    """
    if not module.isidentifier() or keyword.iskeyword(module):
        raise click.BadParameter(f"{module!r} is not a module name", param_hint="--module")
    text = render_stubs(load(tree, root))
    target = out_dir / f"{module}.pyi"
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
        target.write_text(text, encoding="utf-8")
    except OSError as error:
        raise Fatal(f"cannot write {target}: {error.strerror or error}") from None
    click.echo(f"wrote {target}", err=True)
