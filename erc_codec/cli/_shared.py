"""What the erc-codec commands share: the schema options, loading, JSON in and out, hex, errors,
--mode, addresses and positive numbers."""

import json
import math
import re
import socket
from collections.abc import Callable
from typing import Any, TypeVar, cast

import click
from google.protobuf.message import Message

from erc_schema import CodecError, EncodeError
from erc_schema.cli import generator_options

from ..codec import Codec
from ..codec._discovery import SchemaSource, find_schema
from ..codec._json import load_json
from ..codec._json import to_dict as _to_dict

__all__ = [
    "FINITE",
    "MODE",
    "Fatal",
    "emit",
    "envelope_from_json",
    "load",
    "one_line",
    "parse_address",
    "plural",
    "resolve",
    "schema_options",
    "shown",
    "source",
    "text_or_json",
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
    """``--proto TREE`` and ``--root NAME``, the schema revision a command works with, and
    nanopb's generator inputs ``-I``, ``-f``, ``-s`` and ``--nanopb-version``, which ``source``
    reads (the command is not given them)."""
    command = generator_options(_remember)(command)
    command = click.option(
        "--root",
        metavar="NAME",
        help="The root message: an envelope, or any message (named in full). Default: the "
        "configuration's root, else PBEnvelope.",
    )(command)
    return click.option(
        "--proto",
        "tree",
        metavar="TREE",
        help="Proto tree to load: its import root, a folder, or a git revision "
        "GITDIR#ref=REF[,subdir=PATH] (read without a checkout). Default: $ERC_CODEC_PROTO, "
        "else [tool.erc-codec] proto in the nearest pyproject.toml, else the packaged schema "
        "(erc-codec schema says which).",
    )(command)


_GIVEN = "erc_codec.generator."  # ctx.meta keys of the generator inputs given


def _remember(ctx: click.Context, param: click.Parameter, value: Any) -> Any:
    """Keep a generator input the command line gives (a command's after its group's, so the
    command's wins) for ``source``."""
    if value:
        ctx.meta[_GIVEN + str(param.name)] = value
    return value


def source(tree: str | None, root: str | None) -> SchemaSource:
    """The schema ``--proto`` and ``--root`` name, or the one found (see ``find_schema``), with
    the ``-I``, ``-f``, ``-s`` and ``--nanopb-version`` given (each replaces the
    configuration's); a configuration that cannot be read is exit 2. Options given before the
    command (``erc-codec --proto TREE decode``) hold where the command gives none."""
    context = click.get_current_context(silent=True)
    given: dict[str, Any] = {}
    if context is not None:
        params = context.find_root().params
        tree = tree if tree is not None else params.get("tree")
        root = root if root is not None else params.get("root")
        given = {
            key.removeprefix(_GIVEN): value
            for key, value in context.meta.items()
            if key.startswith(_GIVEN)
        }
    includes = given.get("includes")
    settings = given.get("generator_settings")
    try:
        return find_schema(
            tree,
            root,
            include=None if includes is None else [str(folder) for folder in includes],
            options_file=given.get("options_file"),
            settings=None if settings is None else list(settings),
            nanopb_version=given.get("nanopb_version"),
        )
    except CodecError as error:
        raise Fatal(one_line(str(error))) from None


def load(tree: str | None, root: str | None) -> Codec:
    """The codec ``--proto`` and ``--root`` name, or the one found; a schema that does not load
    is exit 2, one line."""
    found = source(tree, root)
    try:
        return Codec.from_source(found)
    except CodecError as error:
        where = "" if found.origin in ("--proto", "packaged") else f" (from {found.origin})"
        raise Fatal(one_line(str(error)) + where) from None


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
        document = load_json(text)
        fields, line = _payload_of(codec, kind, document)
        payload = codec.from_dict(kind, fields)
        metadata = line.get("metadata", {}) if line is not None else {}
        if not isinstance(metadata, dict):
            raise EncodeError("the decoded line's metadata must be an object of fields")
        beside = codec.from_dict(codec.root, metadata) if metadata else None
    except EncodeError as error:
        raise click.ClickException(one_line(str(error))) from None
    if line is not None and line.get("unknown_fields"):  # listed by decode, never their bytes
        count = len(line["unknown_fields"])
        click.echo(
            f"warning: the decoded line lists {count} field(s) this schema does not know; "
            "JSON holds no bytes of them, so they are not sent",
            err=True,
        )
    if plain:
        return payload
    envelope = codec.message_class(codec.root)()
    if beside is not None:  # the metadata a decoded line carried (timeout, ...), sent on
        envelope.MergeFrom(beside)
    getattr(envelope, kind).CopyFrom(payload)
    getattr(envelope, kind).SetInParent()  # an all-default payload is still the one sent
    return envelope


def _payload_of(codec: Codec, kind: str, document: Any) -> tuple[Any, dict[str, Any] | None]:
    """The payload's fields in ``document`` (itself, or the ``message`` of a decoded line), and
    the decoded line when it is one."""
    if not isinstance(document, dict):
        name = codec.payload_class(kind).DESCRIPTOR.full_name
        raise EncodeError(f"JSON must be an object: the fields of {name}, or a decoded line")
    if not isinstance(document.get("message"), dict) or not isinstance(document.get("kind"), str):
        return document, None
    fields = codec.payload_class(kind).DESCRIPTOR.fields_by_name
    if "kind" in fields and "message" in fields:
        return document, None  # the payload's own fields, named so
    if document["kind"] != kind:
        raise EncodeError(
            f"the JSON is a decoded {document['kind']} datagram, not {kind}: give KIND "
            f"{document['kind']}, or its message alone"
        )
    return document["message"], document


# -- what send, listen and proton listen share ------------------------------------------------

MODE = click.option(
    "--mode",
    type=click.Choice(["strip", "exact", "pad"]),
    default="strip",
    show_default=True,
    help="strip trailing zeros (the fleet's UDP form), exact protobuf, or pad to the envelope's "
    "maximum size.",
)


class _Finite(click.FloatRange):
    """A positive, finite number: click's ``FloatRange`` lets ``nan`` and ``inf`` through (NaN
    fails no comparison with its bounds)."""

    name = "positive number"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        number = super().convert(value, param, ctx)
        if not math.isfinite(number):
            self.fail(f"{value!r} is not a finite number.", param, ctx)
        return number


FINITE = _Finite(min=0, min_open=True)  # --seconds, --rate: a positive, finite number


def parse_address(text: str, default_host: str | None = None) -> tuple[str, int]:
    """``HOST:PORT`` (``[v6]:PORT`` too) as (host, port); ``PORT`` alone with a default host."""
    host, _, port = text.rpartition(":")
    host = host.removeprefix("[").removesuffix("]") if host.startswith("[") else host
    if not host and default_host is None:
        raise click.BadParameter(f"{text!r}: expected HOST:PORT")
    try:
        number = int(port)
    except ValueError:
        raise click.BadParameter(f"{text!r}: the port is not a number") from None
    if not 0 <= number <= 65535:
        raise click.BadParameter(f"{text!r}: the port must be within 0..65535")
    return (host or cast(str, default_host)), number


def resolve(host: str, port: int) -> tuple[socket.AddressFamily, tuple[Any, ...]]:
    """The family and socket address of ``host`` (a name or an IPv4 or IPv6 address). A name
    with addresses of both families takes IPv4, as the boards speak it: ``listen localhost:P``
    must hear a board that sends to 127.0.0.1, wherever the system lists ::1 first."""
    try:
        found = socket.getaddrinfo(host, port, type=socket.SOCK_DGRAM)
    except (OSError, UnicodeError) as error:
        reason = error.strerror if isinstance(error, OSError) and error.strerror else error
        raise Fatal(f"cannot resolve {host!r}: {reason}") from None
    family, _, _, _, address = min(found, key=lambda entry: entry[0] != socket.AF_INET)
    return family, address


def shown(address: tuple[Any, ...]) -> str:
    """``host:port``, with an IPv6 host in brackets so the port stays readable."""
    host, port = address[0], address[1]
    return f"[{host}]:{port}" if ":" in host else f"{host}:{port}"


# ``--format text|json``: a command's output for people or for programs (sizes, schema).
text_or_json = click.option(
    "--format",
    "output",
    type=click.Choice(["text", "json"]),
    default="text",
    show_default=True,
    help="text for people, json for programs.",
)
