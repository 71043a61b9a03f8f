"""Which schema a command or ``Codec.default()`` uses, and where that was said.

The first of these that is there wins:
1. the tree a caller names (``--proto TREE``);
2. the environment variable ``ERC_CODEC_PROTO``;
3. ``[tool.erc-codec] proto = "..."`` (with ``root``, ``include``, ``options_file``,
   ``settings`` and ``nanopb_version``) in the nearest ``pyproject.toml`` from the working
   folder up (paths there relative to that file's folder);
4. the packaged rover schema.

nanopb's generator inputs (include folders ``-I``, the options file ``-f``, settings ``-s``, the
generator version whose sizing rules apply) come with the source: given by the caller (a command
line), each replaces the configuration's.

A tree is a folder or a git revision in erc-lint's spelling, ``GITDIR#ref=REF[,subdir=PATH]``,
read from the repository's objects (``erc_codec.schema.open_tree``), never checked out. What a
source names is only read when it is loaded: finding it costs a walk up the folders and, where a
``pyproject.toml`` is found, reading that file.
"""

import functools
import os
import sys
from collections.abc import Callable, Hashable, Mapping, Sequence
from pathlib import Path
from typing import Any, NamedTuple, TypeVar

from erc_schema import (
    NANOPB_VERSIONS,
    FileError,
    GitError,
    GitSpec,
    Repository,
    SchemaError,
    TreeSource,
    file_exists,
    given_options_file,
    open_tree,
    parse_tree_spec,
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
    "snapshot",
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
    and nanopb's generator's ``options_file`` (``-f``) and ``settings`` (``-s``), and the
    ``nanopb_version`` whose sizing rules apply (one of ``erc_codec.schema.NANOPB_VERSIONS``)."""

    tree: str
    root: str
    include: tuple[str, ...]
    origin: str
    options_file: str = DEFAULT_OPTIONS_FILE
    settings: tuple[str, ...] = ()
    nanopb_version: str = NANOPB_VERSIONS[0]


@functools.cache
def packaged_tree() -> Path:
    """The packaged proto tree: ``erc_codec/proto`` in a wheel, ``proto/`` in a checkout."""
    from importlib import resources

    package = Path(str(resources.files("erc_codec")))
    packaged = package / "proto"
    if packaged.is_dir():
        return packaged
    return package.parent / "proto"


def find_schema(
    tree: str | None = None,
    root: str | None = None,
    start: str | os.PathLike[str] | None = None,
    environ: Mapping[str, str] | None = None,
    include: Sequence[str] | None = None,
    options_file: str | None = None,
    settings: Sequence[str] | None = None,
    nanopb_version: str | None = None,
) -> SchemaSource:
    """The schema to use: ``tree`` if given, else ``ERC_CODEC_PROTO`` in ``environ`` (the
    process's environment), else the nearest ``pyproject.toml`` from ``start`` (the working
    folder) up that has a ``[tool.erc-codec]`` table, else the packaged one. ``root``,
    ``include``, ``options_file``, ``settings`` and ``nanopb_version``, where given (not
    ``None``), replace what the source names (``PBEnvelope``, no include folder, ``%s.options``,
    no setting and ``0.4.9``'s rules unless a configuration says otherwise).

    A configuration that cannot be read or holds what it should not is a ``SchemaError`` naming
    the file and the key."""
    given = _Given(root, include, options_file, settings, nanopb_version)
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
    nanopb_version: str | None

    def over(self, source: SchemaSource) -> SchemaSource:
        return source._replace(
            root=self.root or source.root,
            include=source.include if self.include is None else tuple(self.include),
            options_file=source.options_file if self.options_file is None else self.options_file,
            settings=source.settings if self.settings is None else tuple(self.settings),
            nanopb_version=self.nanopb_version or source.nanopb_version,
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


_KEYS = ("proto", "root", "include", "options_file", "settings", "nanopb_version")


def _configured(path: Path, table: dict[str, Any]) -> SchemaSource:
    unknown = sorted(set(table) - set(_KEYS))
    if unknown:
        raise SchemaError(
            f"{path}: [tool.{_TABLE}] has no key {unknown[0]!r} (it takes {', '.join(_KEYS)})"
        )
    proto, named_root = table.get("proto"), table.get("root", "PBEnvelope")
    include, settings = table.get("include", []), table.get("settings", [])
    options_file = table.get("options_file", DEFAULT_OPTIONS_FILE)
    nanopb_version = table.get("nanopb_version", NANOPB_VERSIONS[0])
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
    if nanopb_version not in NANOPB_VERSIONS:
        raise SchemaError(
            f"{path}: [tool.{_TABLE}] nanopb_version must be one of "
            f"{', '.join(map(repr, NANOPB_VERSIONS))}, not {nanopb_version!r}"
        )
    here = path.parent
    return SchemaSource(
        _beside(here, proto),
        named_root,
        tuple(str(here / folder) for folder in include),
        str(path),
        given_options_file(options_file, here),
        tuple(settings),
        nanopb_version,
    )


def _beside(here: Path, tree: str) -> str:
    """``tree`` with its folder (or its GITDIR) taken relative to ``here``."""
    if "#" in tree and not (here / tree).is_dir():
        folder, _, options = tree.partition("#")
        return f"{here / (folder or '.')}#{options}"
    return str(here / tree)


def snapshot(source: SchemaSource) -> tuple[SchemaSource, Hashable]:
    """``source`` as it stands now, and what tells this state from another, for a cache of
    loaded schemas: a git revision with its ref replaced by the commit it names now (one ``git
    rev-parse``; a moved ``HEAD`` or branch is a new source, the same commit under two spellings
    one source); a folder as spelled. The state: the size, times and inode of each ``.proto``
    and ``.options`` file in the folder and in the ``include`` folders (a stat each: an edit, a
    new file or a removed one is a new state). The packaged schema is part of the installed
    package, as its code is: it is not stat'ed (``erc_codec.decode`` stays cheap). What cannot
    be read now is left for loading to report."""
    if source.origin == "packaged":
        return source, None
    try:
        spec = parse_tree_spec(source.tree)
        included = tuple(_stats(folder) for folder in source.include)
        if isinstance(spec, GitSpec):
            with Repository(spec.folder) as repository:
                commit = repository.commit(spec.ref)
            pinned = f"{spec.folder}#ref={commit}" + (
                f",subdir={spec.subdir}" if spec.subdir else ""
            )
            return source._replace(tree=pinned), included
        return source, (_stats(source.tree), *included)
    except GitError:  # no such ref, no repository, or no commit yet
        return source, None


def _stats(folder: str) -> tuple[tuple[str, int, int, int, int], ...]:
    """The state of each ``.proto`` and ``.options`` file below ``folder`` (as ``proto_files``
    walks: not into symlinked folders). One ``scandir`` per folder and one stat per file,
    without ``pathlib``: ``Codec.default()`` (and ``erc_codec.decode``) pay it on every call."""
    states = []
    pending = [folder]
    while pending:
        try:
            listing = os.scandir(pending.pop())
        except OSError:  # no such folder, or not to be listed: loading says so if it matters
            continue
        with listing as entries:
            for entry in entries:
                if entry.is_dir(follow_symlinks=False):
                    pending.append(entry.path)
                elif entry.name.endswith((".proto", ".options")):
                    try:
                        stat = entry.stat()
                    except OSError:  # dangling, or gone since the listing: loading says so
                        continue
                    states.append(
                        (entry.path, stat.st_size, stat.st_mtime_ns, stat.st_ctime_ns, stat.st_ino)
                    )
    return tuple(sorted(states))


def load_source(source: SchemaSource, load: Callable[[TreeSource], _T]) -> _T:
    """``load(tree)`` for ``source``'s tree opened as a folder (a git revision read into a
    scratch folder for the call). A folder holding its ``.proto`` files below a folder they
    import each other by (``--proto proto/components``) gets a one-line hint naming the folder
    to give instead, not protoc's every line."""
    with open_tree(source.tree) as opened:
        try:
            return load(opened)
        except SchemaError as error:
            hint = _hint(opened.folder, source.tree, source.root, error)
            if hint:
                raise SchemaError(hint) from None
            if opened.folder != opened.shown:  # a scratch copy: name the repository instead
                text = str(error).replace(str(opened.folder), str(opened.shown))
                raise SchemaError(text) from None
            raise


def _hint(folder: Path, tree: str, root: str, error: SchemaError) -> str:
    """One line for the common mistake of naming a folder inside the import root (``--proto
    proto/components``): its protos import each other by paths from a folder above it. The tree
    to give instead is spelled as ``tree`` was: a folder, or ``GITDIR#ref=REF,subdir=PATH``."""
    if isinstance(error, FileError) or not folder.is_dir():
        return ""
    text = str(error)
    if "Import" not in text and "not found" not in text:
        return ""
    spec = parse_tree_spec(tree)
    name = (spec.shown if isinstance(spec, GitSpec) else folder).resolve().name
    files = proto_files(folder)
    if not files:
        return ""
    # every folder holding a file, however deep (X/ERC-Protobufs/components holds only folders)
    folders = {folder for file in files for folder in Path(file).parents if folder != Path(".")}
    for file in files:
        for line in read_text(folder / file, errors="replace").splitlines():
            stripped = line.strip()
            if stripped.startswith("import") and f'"{name}/' in stripped:
                return (
                    f"{tree}: its files import each other as {name}/..., so the import root "
                    f"is the folder above it: give {_moved(spec, Path('..'))} (root {root})"
                )
            first = stripped.partition('"')[2].partition("/")
            if stripped.startswith("import") and first[1]:
                # a tree below a subfolder (X/vendor/ERC-Protobufs imported as ERC-Protobufs/...)
                for below in sorted(folders, key=lambda path: (len(path.parts), path.parts)):
                    if below.name == first[0] and below.parent != Path("."):
                        return (
                            f"{tree}: its files import each other as {first[0]}/..., so the "
                            f"import root is the folder above {below}: give "
                            f"{_moved(spec, below.parent)} (root {root})"
                        )
    return ""


def _moved(spec: Path | GitSpec, step: Path) -> str:
    """The tree ``spec`` names moved by ``step`` (``..``, or a folder below it), spelled as it
    was: a folder, or a git revision with its ``subdir=`` changed (the ref as given)."""
    if isinstance(spec, Path):
        moved = spec.parent if step == Path("..") else spec / step
        return str(moved) if str(moved) else "."
    subdir = Path(spec.subdir) if spec.subdir else None
    if step != Path(".."):
        subdir = subdir / step if subdir else step
    elif subdir is not None:
        subdir = subdir.parent if subdir.parent != Path(".") else None
    else:  # GITDIR itself is the folder inside the import root: its parent is the GITDIR
        return f"{spec.folder.parent}#ref={spec.ref}"
    return f"{spec.folder}#ref={spec.ref}" + (f",subdir={subdir.as_posix()}" if subdir else "")
