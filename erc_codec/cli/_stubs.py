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

A field or enum value named like a Python keyword (``from``, ``None``) or like a name Python
reserves for itself, any that begins and ends with two underscores (``__init__``, ``__slots__``,
``__class__``, ``__getattr__``, ``__eq__``), is left out of the stub. As an attribute it would be
a syntax error, or redefine what ``object``, ``int`` or protobuf's ``Message`` means by that name
(the constructor, the slots, attribute look-up, equality). A comment in its class names each one
left out. ``getattr(message, name)`` reaches such a field, and a constructor takes it through
``**``. A field named like a method of ``Message`` (``Clear``), or an enum value like one of
``int`` (``to_bytes``), stays, the override mypy would refuse silenced. A message or enum named
like a reserved name (``__doc__``) is the class ``Message__doc__`` or ``Enum__doc__``.
"""

import functools
import keyword
from pathlib import Path

import click
from google.protobuf.descriptor import Descriptor, EnumDescriptor, FieldDescriptor
from google.protobuf.descriptor_pb2 import EnumDescriptorProto
from google.protobuf.message import Message

from erc_schema import declarations

from ..codec import Codec
from ._shared import Fatal, load, schema_options

__all__ = ["render_stubs", "stubs"]

_T = FieldDescriptor
_SCALARS = {
    _T.CPPTYPE_INT32: "int",
    _T.CPPTYPE_INT64: "int",
    _T.CPPTYPE_UINT32: "int",
    _T.CPPTYPE_UINT64: "int",
    _T.CPPTYPE_DOUBLE: "float",
    _T.CPPTYPE_FLOAT: "float",
    _T.CPPTYPE_BOOL: "bool",
}
# The modules the stub refers to, each imported under an alias no name of the schema has: a
# field, enum value or message named ``Mapping``, ``Any``, ``builtins`` or ``int`` shadows
# nothing the annotations use.
_MODULES = {
    "_builtins": "builtins",
    "_abc": "collections.abc",
    "_typing": "typing",
    "_containers": "google.protobuf.internal.containers",
    "_message": "google.protobuf.message",
    "_erc_codec": "erc_codec",
}
# What protobuf's Message has (its methods, DESCRIPTOR, and Extensions in types-protobuf): a
# field so named replaces it on the class, which mypy calls an incompatible override.
_MESSAGE_NAMES = frozenset(
    {name for name in dir(Message) if not name.startswith("_")} | {"Extensions"}
)
# What ``int`` has: an enum value so named replaces it on the enum's class, which mypy calls an
# incompatible override where it is a method (``to_bytes``). ``is_integer`` is Python 3.12's.
_INT_NAMES = frozenset({name for name in dir(int) if not name.startswith("_")} | {"is_integer"})
_CODEC = "TypedCodec"  # the documented name: a message so named gives way
_Described = Descriptor | EnumDescriptor


def _reserved(name: str) -> bool:
    """Whether ``name`` cannot be an attribute in the stub: a keyword, or a name Python reserves
    (``__*__``)."""
    return keyword.iskeyword(name) or name[:2] == name[-2:] == "__"


def _left_out(names: list[str], reach: str = "") -> list[str]:
    """The comment naming a class's fields or values that have no attribute in the stub."""
    if not names:
        return []
    return [f"    # Left out (a keyword, or a name Python reserves){reach}: {', '.join(names)}"]


class _Names:
    """Every name the stub module defines, chosen so that none hides another.

    Class-body names (fields, enum values, ``message_class``) hide module names in the
    annotations after them, so an annotation never spells a name any class body defines: the
    modules go by aliases no class body uses, and a class whose name some class body uses is
    referred to by such an alias of it. Each message and enum class is named by its full name
    (``Outer.Ping`` as ``Outer_Ping``); where two would meet, or meet ``TypedCodec`` or a
    keyword, the one nested deeper (else later in name order) takes a trailing ``_``. A name
    Python reserves (``__init__``) is prefixed with ``Message`` or ``Enum`` first, as no
    trailing ``_`` makes it another."""

    def __init__(self, described: list[_Described]) -> None:
        self.members = {"message_class"}  # what class bodies define
        for descriptor in described:
            if isinstance(descriptor, Descriptor):
                self.members.update(field.name for field in descriptor.fields)
            else:
                self.members.update(value.name for value in descriptor.values)
        self.classes: dict[str, str] = {}  # full name -> class name
        taken = {_CODEC}
        for descriptor in sorted(described, key=lambda d: (d.full_name.count("."), d.full_name)):
            name = descriptor.full_name.replace(".", "_")
            if _reserved(name):
                name = ("Message" if isinstance(descriptor, Descriptor) else "Enum") + name
            name = self._free(name, taken)
            self.classes[descriptor.full_name] = name
            taken.add(name)
        taken |= self.members
        self.modules = {}  # alias in _MODULES -> alias in this stub
        for alias in _MODULES:
            self.modules[alias] = self._free(alias, taken)
            taken.add(self.modules[alias])
        self.aliases: dict[str, str] = {}  # class name -> the alias annotations spell
        for name in sorted(set(self.classes.values()) & self.members):
            self.aliases[name] = self._free(f"_{name}", taken)
            taken.add(self.aliases[name])

    @staticmethod
    def _free(name: str, taken: set[str]) -> str:
        while name in taken or keyword.iskeyword(name):
            name += "_"
        return name

    def of(self, module: str, name: str) -> str:
        """``name`` of one of ``_MODULES`` (by its alias there), as the stub spells it."""
        return f"{self.modules[module]}.{name}"

    def type_of(self, descriptor: _Described) -> str:
        """The class of ``descriptor`` as an annotation spells it."""
        name = self.classes[descriptor.full_name]
        return self.aliases.get(name, name)


def _value(field: FieldDescriptor, names: _Names) -> tuple[str, str]:
    """A field's type as an attribute, and what its constructor argument takes."""
    builtin = functools.partial(names.of, "_builtins")
    if field.message_type is not None:
        name = names.type_of(field.message_type)
        mapping = f"{names.of('_abc', 'Mapping')}[{builtin('str')}, {names.of('_typing', 'Any')}]"
        return name, f"{name} | {mapping}"
    if field.enum_type is not None:
        return builtin("int"), f"{builtin('int')} | {builtin('str')}"
    if field.cpp_type == _T.CPPTYPE_STRING:
        kind = builtin("bytes" if field.type == _T.TYPE_BYTES else "str")
        return kind, kind
    kind = builtin(_SCALARS[field.cpp_type])
    return kind, kind


def _field(field: FieldDescriptor, names: _Names) -> tuple[str, str]:
    """``(attribute annotation, constructor annotation)`` of a field, lists and maps too."""
    entry = field.message_type
    if entry is not None and entry.GetOptions().map_entry:
        key, _ = _value(entry.fields_by_name["key"], names)
        value, given = _value(entry.fields_by_name["value"], names)
        return (
            f"{names.of('_abc', 'MutableMapping')}[{key}, {value}]",
            f"{names.of('_abc', 'Mapping')}[{key}, {given}] | None",
        )
    value, given = _value(field, names)
    if field.is_repeated:
        container = "RepeatedCompositeFieldContainer" if entry else "RepeatedScalarFieldContainer"
        return (
            f"{names.of('_containers', container)}[{value}]",
            f"{names.of('_abc', 'Iterable')}[{given}] | None",
        )
    return value, f"{given} | None"


def _message(descriptor: Descriptor, names: _Names) -> list[str]:
    base = names.of("_message", "Message")
    lines = [f"class {names.classes[descriptor.full_name]}({base}):"]
    fields = [f for f in descriptor.fields if not _reserved(f.name)]
    left_out = [f.name for f in descriptor.fields if _reserved(f.name)]
    lines += _left_out(left_out, ", getattr reaches them")
    for field in fields:
        line = f"    {field.name}: {_field(field, names)[0]}"
        if field.name in _MESSAGE_NAMES:  # the field is what protobuf's class has by that name
            line += "  # type: ignore[assignment, unused-ignore]"
        lines.append(line)
    arguments = ", ".join(f"{f.name}: {_field(f, names)[1]} = ..." for f in fields)
    receiver = "self"  # positional-only, and named apart from every field (one may be ``self``)
    while receiver in descriptor.fields_by_name:
        receiver += "_"
    keywords = ", *, " + arguments if arguments else ""
    lines.append(f"    def __init__({receiver}, /{keywords}) -> None: ...")
    return lines


def _enum(descriptor: EnumDescriptor, names: _Names) -> list[str]:
    integer = names.of("_builtins", "int")
    lines = [f"class {names.classes[descriptor.full_name]}({integer}):"]
    annotation = f"{names.of('_typing', 'ClassVar')}[{integer}]"
    values = [value.name for value in descriptor.values if not _reserved(value.name)]
    lines += _left_out([value.name for value in descriptor.values if _reserved(value.name)])
    for value in values:
        line = f"    {value}: {annotation}"
        if value in _INT_NAMES:  # the value is what int has by that name
            line += "  # type: ignore[assignment, unused-ignore]"
        lines.append(line)
    return lines if values else [*lines, "    pass"]


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
        for declared in declarations(file):
            if declared.parent is None and isinstance(declared.proto, EnumDescriptorProto):
                enums[declared.name] = codec.schema.pool.FindEnumTypeByName(declared.name)
    return messages, enums


def render_stubs(codec: Codec) -> str:
    """The stub module's text for ``codec``'s schema."""
    messages, enums = _reachable(codec)
    names = _Names([*messages.values(), *enums.values()])
    out = [
        f"# Typing stubs for the messages of {codec.root}'s schema, by erc-codec stubs: for",
        "# mypy only (see erc_codec.cli._stubs); write them again when the schema changes.",
        "# Modules go by aliases no name of the schema has.",
        *(f"import {module} as {names.modules[alias]}" for alias, module in _MODULES.items()),
        "",
    ]
    for enum in sorted(enums.values(), key=lambda d: names.classes[d.full_name]):
        out += [*_enum(enum, names), ""]
    for descriptor in sorted(messages.values(), key=lambda d: names.classes[d.full_name]):
        out += [*_message(descriptor, names), ""]
    for name, alias in names.aliases.items():  # classes some class body names otherwise
        out.append(f"{alias} = {name}")
    if names.aliases:
        out.append("")
    spellings: dict[str, list[str]] = {name: [name] for name in messages}
    for member in codec.members():
        if member.kind != member.message:
            spellings[member.message].insert(0, member.kind)
    overload = f"    @{names.of('_typing', 'overload')}"
    literal_type = names.of("_typing", "Literal")
    out.append(f"class {_CODEC}({names.of('_erc_codec', 'Codec')}):")
    for full_name, spelled in sorted(spellings.items()):
        literal = ", ".join(f'"{name}"' for name in spelled)
        out += [
            overload,
            f"    def message_class(self, name: {literal_type}[{literal}]) -> "
            f"type[{names.type_of(messages[full_name])}]: ...",
        ]
    out += [
        overload,
        f"    def message_class(self, name: {names.of('_builtins', 'str')}) -> "
        f"type[{names.of('_message', 'Message')}]: ...",
        "",
    ]
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
