"""Which schema a command or ``Codec.default()`` uses, and where that was said.

The first of these that is there wins:
1. the tree a caller names (``--proto TREE``);
2. the environment variable ``ERC_CODEC_PROTO``;
3. ``[tool.erc-codec] proto = "..."`` (with ``root``, ``include``, ``options_file`` and
   ``settings``) in the nearest ``pyproject.toml`` from the working folder up (paths there
   relative to that file's folder);
4. the packaged rover schema.

nanopb's generator inputs (include folders ``-I``, the options file ``-f``, settings ``-s``) come
with the source: given by the caller (a command line), each replaces the configuration's.

A tree is a folder or a git revision in erc-lint's spelling, ``GITDIR#ref=REF[,subdir=PATH]``,
read from the repository's objects (``erc_codec.schema.open_tree``), never checked out. What a
source names is only read when it is loaded: finding it costs a walk up the folders and, where a
``pyproject.toml`` is found, reading that file.
"""

import functools
import os
import sys
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any, NamedTuple, TypeVar

from ._errors import SchemaError
from .schema import (
    FileError,
    TreeSource,
    file_exists,
    given_options_file,
    open_tree,
    proto_files,
    read_text,
)

__all__ = [
    "DEFAULT_OPTIONS_FILE",
    "ENVIRONMENT",
    "SchemaSource",
    "find_schema",
    "load_source",
    "packaged_tree",
]

ENVIRONMENT = "ERC_CODEC_PROTO"
DEFAULT_OPTIONS_FILE = "%s.options"  # nanopb's generator's -f: each .proto's own, beside it
_CONFIG_LIMIT = 1024 * 1024  # a pyproject.toml larger than this is no configuration
_TABLE = "erc-codec"
_T = TypeVar("_T")


class SchemaSource(NamedTuple):
    """A schema to load: its ``tree`` (a folder or a git revision, as spelled), the envelope
    message ``root``, further import folders ``include``, and ``origin``: ``"--proto"``,
    ``"ERC_CODEC_PROTO"``, the path of the ``pyproject.toml`` that named it, or ``"packaged"``;
    and nanopb's generator's ``options_file`` (``-f``) and ``settings`` (``-s``)."""

    tree: str
    root: str
    include: tuple[str, ...]
    origin: str
    options_file: str = DEFAULT_OPTIONS_FILE
    settings: tuple[str, ...] = ()


@functools.cache
def packaged_tree() -> Path:
    """The packaged proto tree: ``erc_codec/proto`` in a wheel, ``proto/`` in a checkout."""
    from importlib import resources

    packaged = Path(str(resources.files("erc_codec"))) / "proto"
    if packaged.is_dir():
        return packaged
    return Path(__file__).resolve().parent.parent / "proto"


def find_schema(
    tree: str | None = None,
    root: str | None = None,
    start: str | os.PathLike[str] | None = None,
    environ: Mapping[str, str] | None = None,
    include: Sequence[str] | None = None,
    options_file: str | None = None,
    settings: Sequence[str] | None = None,
) -> SchemaSource:
    """The schema to use: ``tree`` if given, else ``ERC_CODEC_PROTO`` in ``environ`` (the
    process's environment), else the nearest ``pyproject.toml`` from ``start`` (the working
    folder) up that has a ``[tool.erc-codec]`` table, else the packaged one. ``root``,
    ``include``, ``options_file`` and ``settings``, where given (not ``None``), replace what the
    source names (``PBEnvelope``, no include folder, ``%s.options`` and no setting unless a
    configuration says otherwise).

    A configuration that cannot be read or holds what it should not is a ``SchemaError`` naming
    the file and the key."""
    given = _Given(root, include, options_file, settings)
    if tree is not None:
        return given.over(SchemaSource(tree, "PBEnvelope", (), "--proto"))
    value = (os.environ if environ is None else environ).get(ENVIRONMENT, "")
    if value.strip():
        return given.over(SchemaSource(value, "PBEnvelope", (), ENVIRONMENT))
    place = os.path.abspath(os.getcwd() if start is None else os.fspath(start))
    while True:
        config = os.path.join(place, "pyproject.toml")
        if file_exists(config):
            table = _table(Path(config))
            if table is not None:
                return given.over(_configured(Path(config), table))
        above = os.path.dirname(place)
        if above == place:
            break
        place = above
    return given.over(SchemaSource(str(packaged_tree()), "PBEnvelope", (), "packaged"))


class _Given(NamedTuple):
    """What a caller gave itself (``None``: not given), to replace what a source names."""

    root: str | None
    include: Sequence[str] | None
    options_file: str | None
    settings: Sequence[str] | None

    def over(self, source: SchemaSource) -> SchemaSource:
        return source._replace(
            root=self.root or source.root,
            include=source.include if self.include is None else tuple(self.include),
            options_file=source.options_file if self.options_file is None else self.options_file,
            settings=source.settings if self.settings is None else tuple(self.settings),
        )


def _table(path: Path) -> dict[str, Any] | None:
    """The ``[tool.erc-codec]`` table of a pyproject.toml, ``None`` if it has none."""
    if sys.version_info >= (3, 11):
        import tomllib
    else:  # tomllib is tomli, joined to the standard library in 3.11
        import tomli as tomllib

    try:
        document = tomllib.loads(read_text(path, _CONFIG_LIMIT))
    except FileError:
        raise
    except tomllib.TOMLDecodeError as error:
        raise SchemaError(f"{path}: {error}") from None
    tool = document.get("tool", {})
    table = tool.get(_TABLE) if isinstance(tool, dict) else None
    if table is not None and not isinstance(table, dict):
        raise SchemaError(f"{path}: tool.{_TABLE} must be a table")
    return table


_KEYS = ("proto", "root", "include", "options_file", "settings")


def _configured(path: Path, table: dict[str, Any]) -> SchemaSource:
    unknown = sorted(set(table) - set(_KEYS))
    if unknown:
        raise SchemaError(
            f"{path}: [tool.{_TABLE}] has no key {unknown[0]!r} (it takes {', '.join(_KEYS)})"
        )
    proto, named_root = table.get("proto"), table.get("root", "PBEnvelope")
    include, settings = table.get("include", []), table.get("settings", [])
    options_file = table.get("options_file", DEFAULT_OPTIONS_FILE)
    if not isinstance(proto, str) or not proto.strip():
        raise SchemaError(
            f"{path}: [tool.{_TABLE}] proto must be a tree: a folder or GITDIR#ref=REF"
        )
    if not isinstance(named_root, str) or not named_root:
        raise SchemaError(f"{path}: [tool.{_TABLE}] root must be a message name")
    if not isinstance(include, list) or not all(isinstance(i, str) and i for i in include):
        raise SchemaError(f"{path}: [tool.{_TABLE}] include must be a list of folders")
    if not isinstance(options_file, str) or not options_file:
        raise SchemaError(
            f"{path}: [tool.{_TABLE}] options_file must be a file or a pattern (%s.options)"
        )
    if not isinstance(settings, list) or not all(isinstance(s, str) and s for s in settings):
        raise SchemaError(
            f'{path}: [tool.{_TABLE}] settings must be a list of generator settings ("max_size=61")'
        )
    here = path.parent
    return SchemaSource(
        _beside(here, proto),
        named_root,
        tuple(str(here / folder) for folder in include),
        str(path),
        given_options_file(options_file, here),
        tuple(settings),
    )


def _beside(here: Path, tree: str) -> str:
    """``tree`` with its folder (or its GITDIR) taken relative to ``here``."""
    if "#" in tree and not (here / tree).is_dir():
        folder, _, options = tree.partition("#")
        return f"{here / (folder or '.')}#{options}"
    return str(here / tree)


def load_source(source: SchemaSource, load: Callable[[TreeSource], _T]) -> _T:
    """``load(tree)`` for ``source``'s tree opened as a folder (a git revision read into a
    scratch folder for the call). A folder holding its ``.proto`` files below a folder they
    import each other by (``--proto proto/components``) gets a one-line hint naming the folder
    to give instead, not protoc's every line."""
    with open_tree(source.tree) as opened:
        try:
            return load(opened)
        except SchemaError as error:
            hint = _hint(opened.folder, opened.shown, source.root, error)
            if hint:
                raise SchemaError(hint) from None
            if opened.folder != opened.shown:  # a scratch copy: name the repository instead
                text = str(error).replace(str(opened.folder), str(opened.shown))
                raise SchemaError(text) from None
            raise


def _hint(folder: Path, shown: Path, root: str, error: SchemaError) -> str:
    """One line for the common mistake of naming a folder inside the import root (``--proto
    proto/components``): its protos import each other by paths from a folder above it."""
    if isinstance(error, FileError) or not folder.is_dir():
        return ""
    text = str(error)
    if "Import" not in text and "not found" not in text:
        return ""
    name = folder.resolve().name
    files = proto_files(folder)
    if not files:
        return ""
    folders = {Path(file).parent for file in files}
    for file in files:
        for line in read_text(folder / file, errors="replace").splitlines():
            stripped = line.strip()
            if stripped.startswith("import") and f'"{name}/' in stripped:
                return (
                    f"{shown}: its files import each other as {name}/..., so the import root "
                    f"is the folder above it: give {shown.parent if str(shown.parent) else '.'} "
                    f"(root {root})"
                )
            first = stripped.partition('"')[2].partition("/")
            if stripped.startswith("import") and first[1]:
                # a tree below a subfolder (X/vendor/ERC-Protobufs imported as ERC-Protobufs/...)
                for below in sorted(folders, key=lambda path: len(path.parts)):
                    if below.name == first[0] and below.parent != Path("."):
                        return (
                            f"{shown}: its files import each other as {first[0]}/..., so the "
                            f"import root is the folder above {below}: give "
                            f"{shown / below.parent} (root {root})"
                        )
    return ""
