"""``Codec``: one loaded schema with its nanopb sizes and its envelope encoder/decoder."""

import functools
import os
from importlib import resources
from pathlib import Path

from google.protobuf.message import Message

from ._contract import contract
from ._envelope import Envelope
from .schema import Schema, Sizes, load_schema

__all__ = ["Codec", "default_tree"]


def default_tree() -> Path:
    """The packaged proto tree: ``erc_codec/proto`` in a wheel, ``proto/`` in a checkout."""
    packaged = Path(str(resources.files("erc_codec"))) / "proto"
    if packaged.is_dir():
        return packaged
    return Path(__file__).resolve().parent.parent / "proto"


class Codec(Envelope):
    """Encoder and decoder for one schema revision, rooted at its envelope message.

    Loading compiles the root's file and its imports, computes every message's nanopb maximum size
    and checks that everything reachable from the root is fixed-size; any problem is a
    ``SchemaError`` naming the file and line.
    """

    def __init__(self, schema: Schema) -> None:
        self._schema = schema
        self._sizes = Sizes(schema)
        root = schema.root
        self._sizes.require_fixed(root)
        self.root = root.full_name
        super().__init__(
            schema.message_class(root.full_name),
            self._sizes.max_size(root.full_name),
            functools.partial(contract, self._sizes),
        )

    @property
    def schema(self) -> Schema:
        """The loaded schema: its files, descriptor pool, locations and comments."""
        return self._schema

    @property
    def nanopb(self) -> Sizes:
        """nanopb's view of the schema: maximum sizes, field limits and resolved options."""
        return self._sizes

    @classmethod
    def from_path(cls, tree: str | os.PathLike[str], root: str = "PBEnvelope") -> "Codec":
        """Load the proto tree under ``tree`` (the import root), starting from message ``root``."""
        return cls(load_schema(tree, root))

    @classmethod
    def default(cls) -> "Codec":
        """The codec for the packaged rover schema (loaded once, then shared)."""
        return _default()

    def max_size(self, name: str) -> int:
        """nanopb's ``<name>_size``: the longest encoding of message ``name`` (a full name)."""
        return self._sizes.max_size(name)

    def sizes(self) -> dict[str, int | None]:
        """Every loaded message's nanopb maximum size; ``None`` where nanopb has none."""
        return self._sizes.all()

    def message_class(self, name: str) -> type[Message]:
        """The message class for a full message name, e.g. ``"SensorBoardGPSInfo"``."""
        return self._schema.message_class(name)


@functools.cache
def _default() -> Codec:
    return Codec.from_path(default_tree())
