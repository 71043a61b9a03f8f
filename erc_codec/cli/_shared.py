"""What the erc-codec commands share: the schema options, loading, JSON in and out, hex, errors."""

import json
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import click
from google.protobuf.message import Message

from .._codec import Codec, default_tree
from .._errors import CodecError, EncodeError
from .._json import load_json
from .._json import to_dict as _to_dict

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
    """A message as the commands print it: ``Codec.to_dict``, protobuf's JSON mapping with field
    names as in the .proto, every field shown (defaults too), keys in the order of the .proto."""
    return _to_dict(message)


def envelope_from_json(codec: Codec, kind: str, text: str) -> Message:
    """An envelope carrying, as member ``kind``, the payload that protobuf JSON ``text`` spells:
    the payload's fields, or a line ``erc-codec decode`` printed (its ``message``, when its
    ``kind`` is ``kind``).

    Unknown kinds are a usage error (exit 2), bad JSON or values a bad-input error (exit 1), one
    line each.
    """
    members = list(codec.kinds().values())
    plain = not members and kind == codec.root  # a plain-message root: the message itself
    if not plain and kind not in members:
        known = ", ".join(members) or f"no members: it is a plain message, KIND {codec.root}"
        raise Fatal(f"unknown kind {kind!r}: {codec.root} has {known}")
    try:
        document = _payload_of(codec, kind, load_json(text))
        payload = codec.from_dict(kind, document)
    except EncodeError as error:
        raise click.ClickException(one_line(str(error))) from None
    if plain:
        return payload
    envelope = codec.message_class(codec.root)()
    getattr(envelope, kind).CopyFrom(payload)
    getattr(envelope, kind).SetInParent()  # an all-default payload is still the one sent
    return envelope


def _payload_of(codec: Codec, kind: str, document: Any) -> Any:
    """The payload's fields in ``document``: itself, or the ``message`` of a decoded line."""
    if not isinstance(document, dict):
        name = codec.payload_class(kind).DESCRIPTOR.full_name
        raise EncodeError(f"JSON must be an object: the fields of {name}, or a decoded line")
    if not isinstance(document.get("message"), dict) or not isinstance(document.get("kind"), str):
        return document
    fields = codec.payload_class(kind).DESCRIPTOR.fields_by_name
    if "kind" in fields and "message" in fields:
        return document  # the payload's own fields, named so
    if document["kind"] != kind:
        raise EncodeError(
            f"the JSON is a decoded {document['kind']} datagram, not {kind}: give KIND "
            f"{document['kind']}, or its message alone"
        )
    return document["message"]
