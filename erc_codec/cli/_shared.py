"""What the erc-codec commands share: the schema options, loading, JSON in and out, hex, errors."""

import json
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import click
from google.protobuf import json_format
from google.protobuf.descriptor import Descriptor
from google.protobuf.message import Message

from .._codec import Codec, default_tree
from .._errors import CodecError
from ..schema import descriptor_of

__all__ = [
    "Fatal",
    "emit",
    "envelope_from_json",
    "load",
    "one_line",
    "plural",
    "schema_options",
    "to_dict",
    "unhex",
]

_Command = TypeVar("_Command", bound=Callable[..., Any])
_NOT_HEX = re.compile(r"[^0-9a-fA-F \t\n\r\v\f:]")
_SEPARATORS = re.compile(r"[ \t\n\r\v\f:]+")


class Fatal(click.ClickException):
    """The command could not run: one line on stderr, exit status 2."""

    exit_code = 2


def one_line(text: str) -> str:
    """``text`` with every run of whitespace, newlines included, one space."""
    return " ".join(text.split())


def plural(count: int, noun: str) -> str:
    return f"{count} {noun}{'' if count == 1 else 's'}"


def schema_options(command: _Command) -> _Command:
    """``--proto TREE`` and ``--root NAME``: the schema revision a command works with."""
    command = click.option(
        "--root",
        metavar="NAME",
        default="PBEnvelope",
        show_default=True,
        help="The envelope message.",
    )(command)
    return click.option(
        "--proto",
        "tree",
        type=click.Path(file_okay=False, path_type=Path),
        metavar="TREE",
        help="Proto tree to load (its import root). Default: the packaged rover schema.",
    )(command)


def load(tree: Path | None, root: str) -> Codec:
    """The codec ``--proto`` and ``--root`` name; a schema that does not load is exit 2."""
    try:
        return Codec.from_path(tree or default_tree(), root)
    except CodecError as error:
        raise Fatal(one_line(str(error))) from None


def unhex(text: str) -> bytes:
    """The bytes that hex text spells; spaces, tabs and colons between digits are allowed."""
    bad = _NOT_HEX.search(text)
    if bad:
        raise ValueError(f"{bad.group()!r} at column {bad.start() + 1} is not a hex digit")
    digits = _SEPARATORS.sub("", text)
    if len(digits) % 2:
        raise ValueError(f"odd number of hex digits ({len(digits)})")
    return bytes.fromhex(digits)


def emit(record: dict[str, object]) -> None:
    """One JSON object on its own line of standard output."""
    click.echo(json.dumps(record))


def to_dict(message: Message) -> dict[str, Any]:
    """A message as the commands print it: protobuf's JSON mapping, field names as in the
    .proto, every field shown (defaults too), keys in the order of the .proto."""
    document = json_format.MessageToDict(
        message, always_print_fields_with_no_presence=True, preserving_proto_field_name=True
    )
    return _in_field_order(document, descriptor_of(type(message)))


def _in_field_order(document: dict[str, Any], descriptor: Descriptor) -> dict[str, Any]:
    """``document`` with its keys in the order of the .proto, at every level.

    ``MessageToDict`` lists the fields that are set before the defaults it adds, so the same
    message would show its fields in a different order from one datagram to the next.
    """
    ordered: dict[str, Any] = {}
    for field in descriptor.fields:
        if field.name not in document:
            continue
        value = document[field.name]
        payload = field.message_type
        if payload is not None and not payload.GetOptions().map_entry:
            if isinstance(value, dict):
                value = _in_field_order(value, payload)
            elif isinstance(value, list):
                value = [_in_field_order(v, payload) if isinstance(v, dict) else v for v in value]
        ordered[field.name] = value
    return ordered


def _unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    """A JSON object, refusing a key given twice (json.loads would keep the last silently)."""
    document: dict[str, Any] = {}
    for key, value in pairs:
        if key in document:
            raise ValueError(f"key {key!r} appears twice")
        document[key] = value
    return document


def envelope_from_json(codec: Codec, kind: str, text: str) -> Message:
    """An envelope carrying, as member ``kind``, the payload that protobuf JSON ``text`` spells.

    Unknown kinds are a usage error (exit 2), bad JSON a bad-input error (exit 1), one line each.
    """
    members = list(codec.kinds().values())
    if not members and kind == codec.root:  # a plain-message root: the message itself
        envelope = message = codec.message_class(codec.root)()
    elif kind not in members:
        known = ", ".join(members) or f"no members: it is a plain message, KIND {codec.root}"
        raise Fatal(f"unknown kind {kind!r}: {codec.root} has {known}")
    else:
        envelope = codec.message_class(codec.root)()
        message = getattr(envelope, kind)
    try:
        document = json.loads(text, object_pairs_hook=_unique_keys)
    except (ValueError, RecursionError) as error:
        raise click.ClickException(f"JSON is not valid: {one_line(str(error))}") from None
    if not isinstance(document, dict):
        raise click.ClickException(
            f"JSON must be an object: the fields of {message.DESCRIPTOR.full_name}"
        )
    try:
        json_format.ParseDict(document, message)
    except (json_format.ParseError, RecursionError) as error:
        raise click.ClickException(one_line(str(error))) from None
    message.SetInParent()  # an all-default payload is still the one sent
    return envelope
