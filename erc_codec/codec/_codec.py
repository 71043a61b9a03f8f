"""``Codec``: one loaded schema with its nanopb sizes and its JSON, and a root handler beside it.

A codec joins ``Codec``'s schema-level half to a root handler, which encodes and decodes the root.
There are two such classes:
- ``EnvelopeCodec``, with ``Envelope``, for an envelope root;
- ``MessageCodec``, with ``Plain``, for any other message.

``Codec(schema)`` is the envelope codec.
"""

import functools
import os
import re
from collections.abc import Hashable, Mapping, Sequence
from pathlib import Path
from typing import Any, NamedTuple

from google.protobuf.message import Message

from erc_schema import NANOPB_VERSIONS, Schema, SchemaError, Sizes, load_schema, message_of

from ._contract import contract
from ._discovery import SchemaSource, find_schema, load_source, packaged_tree, snapshot
from ._envelope import Decoded, Envelope, Mode, is_envelope
from ._plain import Plain
from ._sendable import unsendable
from ._strict import refusal

__all__ = [
    "Codec",
    "Direction",
    "EnvelopeCodec",
    "Member",
    "MessageCodec",
    "default_tree",
    "is_envelope",
]

# A member's trailing comment, as the rover's envelope writes it: ``// direction: ROS2 -> BS``.
_DIRECTION = re.compile(r"direction:[ \t]*(\S.*?)[ \t]*->[ \t]*(\S.*?)[ \t]*$", re.MULTILINE)


class Direction(NamedTuple):
    """Who sends an envelope member and who receives it, as its ``// direction:`` comment says."""

    sender: str
    receiver: str


class Member(NamedTuple):
    """One member of the envelope's oneof.

    - ``number``: its field number.
    - ``kind``: the member name a decode returns.
    - ``message``: the full name of its message type.
    - ``direction``: who sends and receives it; ``None`` where the schema does not give one.
    """

    number: int
    kind: str
    message: str
    direction: Direction | None


def default_tree() -> Path:
    """The packaged proto tree: ``erc_codec/proto`` in a wheel, ``proto/`` in a checkout."""
    return packaged_tree()


class Codec:
    """Encoder and decoder for one schema revision, rooted at its envelope message.

    ``from_path`` with another root gives a ``MessageCodec`` rooted at that message.

    Loading does three things:
    - it compiles the root's file and its imports;
    - it computes every message's nanopb maximum size;
    - it checks that everything reachable from the root is fixed-size.

    Any problem in loading is a ``SchemaError`` naming the file and line.

    Some messages erc-codec cannot encode or decode as nanopb does:
    - one protobuf's Python runtime cannot build (more than 63 required fields, clashing JSON
      names);
    - one with an editions DELIMITED field;
    - one with an override that protobuf does not write as nanopb reads it;
    - one with a field named as a method erc-codec asks a message for.

    Such a message keeps nanopb's size in ``sizes()`` and ``max_size``. Only encoding or decoding
    it (a member carrying it, or the whole root) is a ``SchemaError`` saying why.

    Parameters:
    - ``options_file`` and ``settings`` are nanopb's generator's ``-f`` and ``-s``.
    - ``nanopb_version`` is the generator version whose sizing rules apply: ``"0.4.9"``, or
      ``"1.0.0-dev"`` (master after 0.4.9.1); see ``erc_codec.schema.Sizes``.
    """

    def __new__(
        cls,
        schema: Schema,
        options_file: str = "%s.options",
        settings: Sequence[str] = (),
        nanopb_version: str = NANOPB_VERSIONS[0],
    ) -> "Codec":
        return super().__new__(EnvelopeCodec if cls is Codec else cls)

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if not issubclass(cls, (Envelope, Plain)):
            raise TypeError(
                f"{cls.__name__}: a codec is an EnvelopeCodec or a MessageCodec (its root's "
                "encoding and decoding): subclass one of them, not Codec"
            )

    def __init__(
        self,
        schema: Schema,
        options_file: str = "%s.options",
        settings: Sequence[str] = (),
        nanopb_version: str = NANOPB_VERSIONS[0],
    ) -> None:
        _require_compiled_runtime()
        self._schema = schema
        self._sizes = Sizes(schema, options_file, settings, nanopb_version)
        self._sizes.require_fixed(schema.root)
        self.root = schema.root.full_name

    def _handler_arguments(self) -> tuple[Any, ...]:
        """What a root handler (``Envelope``, ``Plain``) is made of, for this schema's root."""
        schema = self._schema
        return (
            schema.message_class(self.root, lenient=True),
            self._sizes.max_size(self.root),
            functools.partial(contract, self._sizes),
            functools.partial(refusal, self._sizes, schema.root),
            functools.partial(unsendable, schema, self._sizes),
        )

    # What the root handler defines: the encoding and decoding of the root.
    def kinds(self) -> dict[int, str]:
        """The envelope's members: field number → kind (``{}`` for a plain root)."""
        raise NotImplementedError("a codec's root handler (Envelope, Plain) defines it")

    def metadata_fields(self) -> dict[int, str]:
        """The envelope's metadata fields: field number → name (``{}`` for a plain root)."""
        raise NotImplementedError("a codec's root handler (Envelope, Plain) defines it")

    def payload_class(self, kind: str) -> type[Message]:
        """The message class member ``kind`` carries."""
        raise NotImplementedError("a codec's root handler (Envelope, Plain) defines it")

    def encode(self, message: Message, mode: Mode = "strip", /, **metadata: object) -> bytes:
        """The datagram carrying ``message`` in ``mode``, with metadata fields set."""
        raise NotImplementedError("a codec's root handler (Envelope, Plain) defines it")

    def reencode(self, decoded: Decoded, mode: Mode = "strip") -> bytes:
        """The datagram ``decoded`` came from, in ``mode``, with all it carried."""
        raise NotImplementedError("a codec's root handler (Envelope, Plain) defines it")

    def peek(self, data: bytes) -> tuple[str, bytes] | None:
        """The kind and exact payload bytes of a datagram in its usual shape, else ``None``."""
        raise NotImplementedError("a codec's root handler (Envelope, Plain) defines it")

    def decode(self, data: bytes, strict: bool = False) -> Decoded:
        """The payload of a datagram in exact, stripped or zero-padded form."""
        raise NotImplementedError("a codec's root handler (Envelope, Plain) defines it")

    def _root_class(self) -> type[Message]:
        raise NotImplementedError("a codec's root handler (Envelope, Plain) defines it")

    @property
    def schema(self) -> Schema:
        """The loaded schema: its files, descriptor pool, locations and comments."""
        return self._schema

    @property
    def nanopb(self) -> Sizes:
        """nanopb's view of the schema: maximum sizes, field limits and resolved options."""
        return self._sizes

    @classmethod
    def from_path(
        cls,
        tree: str | os.PathLike[str],
        root: str = "PBEnvelope",
        include: Sequence[str | os.PathLike[str]] = (),
        options_file: str = "%s.options",
        settings: Sequence[str] = (),
        nanopb_version: str = NANOPB_VERSIONS[0],
    ) -> "Codec":
        """Load the proto tree under ``tree`` and give its codec.

        - ``tree`` is the import root.
        - ``root`` is the full name of the message to start from.
        - ``include`` lists further import folders (``-I``).
        - The sizes are those nanopb's generator ``nanopb_version`` computes, with
          ``-f options_file`` and ``-s`` for each of ``settings``.

        An envelope root (one oneof of messages, metadata fields beside it) gives the envelope
        codec. Any other message gives a ``MessageCodec``, which sends that message alone in the
        same three forms.
        """
        if not isinstance(tree, (str, os.PathLike)):
            raise TypeError(f"tree is a folder (str or os.PathLike), not {type(tree).__name__}")
        if not isinstance(root, str):
            raise TypeError(f"root is a message name (str), not {type(root).__name__}")
        return cls.from_schema(
            load_schema(tree, root, include), options_file, settings, nanopb_version
        )

    @classmethod
    def from_source(cls, source: SchemaSource) -> "Codec":
        """Load the schema ``source`` names (``find_schema``).

        The source is a folder, or a git revision ``GITDIR#ref=REF[,subdir=PATH]`` read without
        a checkout. It also gives the include folders, the options file, the generator settings
        and the generator version whose sizing rules apply.
        """
        return load_source(
            source,
            lambda tree: cls.from_schema(
                load_schema(tree.folder, source.root, source.include, tree.shown),
                source.options_file,
                source.settings,
                source.nanopb_version,
            ),
        )

    @classmethod
    def from_schema(
        cls,
        schema: Schema,
        options_file: str = "%s.options",
        settings: Sequence[str] = (),
        nanopb_version: str = NANOPB_VERSIONS[0],
    ) -> "Codec":
        """The codec for a loaded ``schema`` (``erc_codec.schema.load_schema``): an envelope
        codec, or a ``MessageCodec`` for a plain root, as ``from_path`` gives."""
        if cls is Codec and not is_envelope(schema.root):
            return MessageCodec(schema, options_file, settings, nanopb_version)
        return cls(schema, options_file, settings, nanopb_version)

    @classmethod
    def default(cls) -> "Codec":
        """The codec for the schema found as every command finds it (``find_schema``).

        The schema is the first of:
        - ``ERC_CODEC_PROTO``;
        - ``[tool.erc-codec]`` in the nearest ``pyproject.toml`` from the working folder up;
        - the packaged rover schema.

        The schema is found anew on each call. It is loaded once for each state of it
        (``snapshot``), then shared. So the next call loads a new commit on a git input's ref or
        branch, or an edited file of a folder. That check costs a ``git rev-parse`` for a git
        input and a stat of each file for a folder, so in a loop, keep the codec.
        """
        return _loaded(*snapshot(find_schema()))

    def max_size(self, name: str) -> int:
        """nanopb's ``<name>_size``: the longest encoding of message ``name`` (a full name)."""
        return self._sizes.max_size(name)

    def sizes(self) -> dict[str, int | None]:
        """Every loaded message's nanopb maximum size; ``None`` where nanopb has none."""
        return self._sizes.all()

    def message_class(self, name: str) -> type[Message]:
        """The message class for a kind (``"gps_info"``) or a full message name
        (``"SensorBoardGPSInfo"``).

        A kind wins where a message has the same name. A member or root the codec cannot send
        (see the class's docstring) is a ``SchemaError`` saying why. An envelope that has other
        members the codec sends still gives its class.
        """
        if name in self.kinds().values():
            return self.payload_class(name)
        if name == self.root:
            return self._root_class()
        return self._schema.message_class(name)

    def members(self) -> tuple[Member, ...]:
        """The envelope's members in field-number order, each with its direction, read from
        the trailing ``// direction: SENDER -> RECEIVER`` comment of its declaration."""
        members = []
        for number, kind in sorted(self.kinds().items()):
            field = self._schema.root.fields_by_number[number]
            found = _DIRECTION.search(self._schema.comment(field.full_name))
            direction = Direction(found[1], found[2]) if found else None
            members.append(Member(number, kind, message_of(field).full_name, direction))
        return tuple(members)

    # -- protobuf's JSON mapping -----------------------------------------------------------------
    # Each method imports ``_json`` (and with it json and json_format) when first called: encoding
    # and decoding never need them; after the first call the import is a dict look-up.

    def to_dict(self, message: Message) -> dict[str, Any]:
        """``message`` (of any type) in protobuf's JSON mapping, as ``erc-codec decode`` prints
        it.

        - Field names are as in the .proto, in its order at every level.
        - Every field without presence is shown.
        - Enums are by name.
        - 64-bit integers are strings.
        - Bytes are in base64.
        - A float is the shortest decimal of its 32 bits.
        - ``"NaN"`` and ``"Infinity"`` are strings.
        """
        from ._json import to_dict

        return to_dict(_a_message(message))

    def to_json(self, message: Message) -> str:
        """``to_dict(message)`` as one line of JSON text."""
        from ._json import to_json

        return to_json(_a_message(message))

    def from_dict(self, kind_or_class: str | type[Message], document: Mapping[str, Any]) -> Message:
        """The message ``document`` spells in protobuf's JSON mapping.

        ``document`` is what ``to_dict`` gives, or json.loads of such text. ``kind_or_class`` is
        a payload kind (``"gps_info"``), a message name (``"SensorBoardGPSInfo"``) or a message
        class.

        What the document may spell:
        - names as in the .proto or in lowerCamelCase;
        - enums by name or by a declared number;
        - 64-bit integers as numbers or strings.

        Every value is range-checked before it is converted. A value that does not fit is an
        ``EncodeError`` naming its full path and what the field takes. An unknown kind or name is
        a ``SchemaError``. ``encode`` checks nanopb's own limits.
        """
        from ._json import from_dict

        return from_dict(self._json_class(kind_or_class), document)

    def from_json(self, kind_or_class: str | type[Message], text: str | bytes) -> Message:
        """``from_dict`` of JSON text, read strictly.

        A key given twice is an ``EncodeError``. Numbers are read exactly.
        """
        from ._json import from_json

        return from_json(self._json_class(kind_or_class), text)

    def _json_class(self, kind_or_class: str | type[Message]) -> type[Message]:
        if isinstance(kind_or_class, type) and issubclass(kind_or_class, Message):
            return kind_or_class
        if not isinstance(kind_or_class, str):
            raise TypeError(
                "from_dict and from_json take a kind, a message name or a message class, not "
                f"{type(kind_or_class).__name__}"
            )
        kinds = self.kinds().values()
        try:
            return self.message_class(kind_or_class)  # a kind or a message name
        except SchemaError:
            if kind_or_class in kinds or _defined(self._schema, kind_or_class):
                raise  # one the codec cannot send: why
            raise SchemaError(
                f"{kind_or_class!r} is neither a payload kind of {self.root} ({', '.join(kinds)}) "
                "nor a message of its schema"
            ) from None


class EnvelopeCodec(Envelope, Codec):
    """The ``Codec`` of an envelope root: what ``Codec(schema)``, ``Codec.default()`` and
    ``Codec.from_path`` of an envelope give."""

    def __init__(
        self,
        schema: Schema,
        options_file: str = "%s.options",
        settings: Sequence[str] = (),
        nanopb_version: str = NANOPB_VERSIONS[0],
    ) -> None:
        Codec.__init__(self, schema, options_file, settings, nanopb_version)
        Envelope.__init__(self, *self._handler_arguments())


class MessageCodec(Plain, Codec):
    """A ``Codec`` rooted at a plain message, not an envelope.

    - ``encode`` takes an instance of the root.
    - ``decode`` returns it, with the root's full name as the kind.
    - The three forms, the contract and the errors are the envelope codec's.
    - ``kinds()`` and ``members()`` are empty.
    """

    def __init__(
        self,
        schema: Schema,
        options_file: str = "%s.options",
        settings: Sequence[str] = (),
        nanopb_version: str = NANOPB_VERSIONS[0],
    ) -> None:
        Codec.__init__(self, schema, options_file, settings, nanopb_version)
        Plain.__init__(self, *self._handler_arguments())


def _defined(schema: Schema, name: str) -> bool:
    """Whether ``schema`` has a message named ``name``."""
    try:
        schema.descriptor(name)
    except SchemaError:
        return False
    return True


def _a_message(message: object) -> Message:
    """``message``, when it is a protobuf message; else a ``TypeError`` naming what it is."""
    if not isinstance(message, Message):
        raise TypeError(f"message is a protobuf message, not {type(message).__name__}")
    return message


def _require_compiled_runtime() -> None:
    """Refuse protobuf's pure-Python runtime with a ``SchemaError``, rather than decode
    differently.

    That runtime keeps no serialized descriptors and reads some malformed bytes otherwise than
    upb does. So a codec on it would answer otherwise than the one tested. nanopb's generator
    switches to it for its own process: it sets ``PROTOCOL_BUFFERS_PYTHON_IMPLEMENTATION=python``
    in ``os.environ`` on import. Every process started after that inherits it.
    """
    from google.protobuf.internal import api_implementation

    if api_implementation.Type() == "python":
        raise SchemaError(
            "protobuf runs its pure-Python implementation here "
            "(PROTOCOL_BUFFERS_PYTHON_IMPLEMENTATION=python, which importing nanopb's generator "
            "sets): erc_codec needs its compiled one (upb); unset the variable"
        )


def _loaded(source: SchemaSource, state: Hashable) -> Codec:
    """The codec of ``source`` in ``state``.

    The packaged schema's codec is kept for the life of the process. So ``Codec.default()`` and
    its message classes stay the same objects however many other schemas are loaded meanwhile.
    Another schema's codecs are kept while they are among the eight last used, so an edited
    folder's old state is soon let go.
    """
    if source.origin == "packaged":
        return _packaged(source)
    return _edited(source, state)


@functools.cache
def _packaged(source: SchemaSource) -> Codec:
    return Codec.from_source(source)


@functools.lru_cache(maxsize=8)
def _edited(source: SchemaSource, state: Hashable) -> Codec:
    return Codec.from_source(source)
