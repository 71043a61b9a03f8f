"""``[tool.erc-lint]`` in a pyproject.toml: embedded roots and their size budgets, the rules to
run (``use`` and ``except``, rule IDs or categories; ``ignore``, rule IDs; ``ignore_only``, rule
IDs each with the paths it is not reported for), paths to exclude, and nanopb's generator inputs
(``include`` folders, ``options_file``, ``settings``; paths relative to the file's folder) with
the ``nanopb_version`` whose sizing rules apply.

Every value is checked as it is read: a wrong type, a name that is no rule or category, a budget
for a message that is not a root, is a ``ConfigError`` naming the file, the line and the key
(and, for a mistyped rule or category, the name it is closest to).
"""

import sys
from collections.abc import Collection, Mapping
from fnmatch import fnmatchcase
from pathlib import Path
from types import MappingProxyType
from typing import Any, NamedTuple

from erc_schema import (
    NANOPB_VERSIONS,
    FileError,
    SchemaError,
    file_exists,
    given_options_file,
    read_text,
    resolve_options,
)

from ._errors import ConfigError
from ._suggest import did_you_mean

__all__ = [
    "CONFIG",
    "CONFIG_LIMIT",
    "DEFAULT_OPTIONS_FILE",
    "LEDGER",
    "LEDGER_LIMIT",
    "Config",
    "check_config",
    "find_config",
    "read_config",
]

CONFIG = "pyproject.toml"  # where [tool.erc-lint] is looked for, beside a tree's protos
LEDGER = "erc-lint.lock"  # the ledger's file name, beside a tree's protos
# The largest file of each kind read (a longer one is refused, exit 2): the rover's are some
# 2 KiB and 4 KiB; a ledger of 64 MiB holds about a million entries.
CONFIG_LIMIT = 1024 * 1024
LEDGER_LIMIT = 64 * 1024 * 1024


_ROOTS = ("PBEnvelope",)  # embedded roots unless the configuration names others


_KEYS = (
    "roots",
    "ignore",
    "exclude",
    "use",
    "except",
    "budget",
    "ignore_only",
    "include",
    "options_file",
    "settings",
    "nanopb_version",
)
_LISTS = ("roots", "ignore", "exclude", "use", "except", "include", "settings")
DEFAULT_OPTIONS_FILE = "%s.options"  # nanopb's generator's -f: each .proto's own, beside it


class Config(NamedTuple):
    """What ``[tool.erc-lint]`` (or a ``--config`` file, or the command line) sets: the roots held
    fixed-size, the rules and categories chosen, budgets, exclusions, and nanopb's generator
    inputs; ``read_config`` reads one, and every field has the default a tree without one gets."""

    roots: tuple[str, ...] = _ROOTS  # embedded roots: fixed-size from here down
    ignore: frozenset[str] = frozenset()  # rule IDs
    exclude: tuple[str, ...] = ()  # fnmatch patterns on paths relative to a tree's root
    source: str | None = None  # the file it was read from
    roots_line: int = 0  # the line of that file that sets roots (0: the default roots)
    use: tuple[str, ...] = ()  # rule IDs and categories to run (none: the default categories)
    except_: tuple[str, ...] = ()  # rule IDs and categories not to run (``except``)
    budget: Mapping[str, int] = MappingProxyType({})  # root → most bytes its size may be
    budget_line: int = 0  # the line that sets budget
    # rule ID → fnmatch patterns of paths (relative to a tree's root) it is not reported for
    ignore_only: Mapping[str, tuple[str, ...]] = MappingProxyType({})
    # nanopb's generator inputs: import folders (-I), the options file (-f), settings (-s)
    include: tuple[str, ...] = ()
    options_file: str = DEFAULT_OPTIONS_FILE
    settings: tuple[str, ...] = ()
    nanopb_version: str = NANOPB_VERSIONS[0]  # whose generator's sizing rules apply

    def ignored_at(self, rule: str, path: str) -> bool:
        """Whether ``ignore_only`` silences ``rule`` for the file at ``path`` (tree-relative)."""
        patterns = self.ignore_only.get(rule, ())
        return any(fnmatchcase(path, pattern) for pattern in patterns)

    @property
    def roots_chosen(self) -> bool:
        """Whether someone named the roots, or gave one a budget (a typo there must not pass in
        silence)."""
        return self.roots_line > 0 or self.roots != _ROOTS or bool(self.budget)

    @property
    def roots_where(self) -> int:
        """The line that names the roots: ``roots``, else ``budget`` (0: neither)."""
        return self.roots_line or self.budget_line


def find_config(*folders: Path) -> Path | None:
    """The first pyproject.toml in ``folders`` with a ``[tool.erc-lint]`` table."""
    for folder in folders:
        candidate = folder / CONFIG
        if file_exists(candidate) and _table(candidate) is not None:  # a FIFO is refused
            return candidate
    return None


def read_config(
    path: Path | None,
    known_rules: Collection[str],
    explicit: bool = False,
    categories: Collection[str] = (),
    base: Path | None = None,
) -> Config:
    """The configuration in ``path`` (defaults when None); an ``explicit`` file must have one.
    ``use`` and ``except`` may name ``known_rules`` and ``categories``; ``ignore`` rules only.
    Its paths are relative to ``base``, else to its folder."""
    if path is None:
        return Config()
    table = _table(path)
    if table is None:
        if explicit:
            raise ConfigError(f"{path}: no [tool.erc-lint] table")
        return Config()
    unknown = set(table) - set(_KEYS)
    if unknown:
        raise ConfigError(f"{path}: unknown [tool.erc-lint] key {sorted(unknown)[0]!r}")
    values: dict[str, list[str]] = {}
    for key in _LISTS:
        value = table.get(key, [])
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            raise ConfigError(f"{_at(path, key)} [tool.erc-lint] {key} must be a list of strings")
        values[key] = value
    for key, allowed, what in (
        ("ignore", set(known_rules), "rule"),
        ("use", {*known_rules, *categories}, "rule or category"),
        ("except", {*known_rules, *categories}, "rule or category"),
    ):
        strange = [name for name in values[key] if name not in allowed]
        if strange:
            raise ConfigError(
                f"{_at(path, key)} [tool.erc-lint] {key} names no {what} {strange[0]!r}"
                + did_you_mean(strange[0], allowed)
            )
    roots = tuple(values["roots"]) if "roots" in table else _ROOTS
    include, options_file, settings = _generator(path, base or path.parent, table, values)
    return Config(
        roots=roots,
        ignore=frozenset(values["ignore"]),
        exclude=tuple(values["exclude"]),
        source=str(path),
        roots_line=_line_of(path, "roots") if "roots" in table else 0,
        use=tuple(values["use"]),
        except_=tuple(values["except"]),
        budget=_budget(path, table.get("budget"), roots),
        budget_line=_line_of(path, "budget") if "budget" in table else 0,
        ignore_only=_ignore_only(path, table.get("ignore_only"), known_rules),
        include=include,
        options_file=options_file,
        settings=settings,
        nanopb_version=_nanopb_version(path, table),
    )


def _nanopb_version(path: Path, table: dict[str, Any]) -> str:
    """``nanopb_version``: one of ``NANOPB_VERSIONS`` (the first when not set)."""
    version = table.get("nanopb_version", NANOPB_VERSIONS[0])
    if version not in NANOPB_VERSIONS:
        raise ConfigError(
            f"{_at(path, 'nanopb_version')} [tool.erc-lint] nanopb_version must be one of "
            f"{', '.join(map(repr, NANOPB_VERSIONS))}, not {version!r}"
        )
    return str(version)


def _generator(
    path: Path, here: Path, table: dict[str, Any], values: dict[str, list[str]]
) -> tuple[tuple[str, ...], str, tuple[str, ...]]:
    """nanopb's generator inputs: ``include`` folders (each there), ``options_file`` (a file
    there taken from there) and ``settings`` (each read as nanopb reads it); ``here`` is where
    paths are relative to."""
    for folder in values["include"]:
        if not (here / folder).is_dir():
            raise ConfigError(
                f"{_at(path, 'include')} [tool.erc-lint] include: {here / folder} is not a folder"
            )
    for setting in values["settings"]:
        try:
            resolve_options(here, (), settings=[setting])
        except SchemaError as error:
            raise ConfigError(
                f"{_at(path, 'settings')} [tool.erc-lint] settings: {error}"
            ) from None
    options_file = table.get("options_file", DEFAULT_OPTIONS_FILE)
    if not isinstance(options_file, str) or not options_file.strip():
        raise ConfigError(
            f"{_at(path, 'options_file')} [tool.erc-lint] options_file must be a file or a "
            "pattern (%s.options)"
        )
    return (
        tuple(str(here / folder) for folder in values["include"]),
        given_options_file(options_file, here),
        tuple(values["settings"]),
    )


def _ignore_only(
    path: Path, value: object, known_rules: Collection[str]
) -> Mapping[str, tuple[str, ...]]:
    """``ignore_only = { RULE = ["path/*", ...] }``: each key a rule ID, each value patterns."""
    if value is None:
        return MappingProxyType({})
    where = _at(path, "ignore_only")
    if not isinstance(value, dict):
        raise ConfigError(
            f'{where} [tool.erc-lint] ignore_only must be a table, {{ RULE = ["path/*"] }}'
        )
    for rule, patterns in value.items():
        if rule not in known_rules:
            raise ConfigError(
                f"{where} [tool.erc-lint] ignore_only names no rule {rule!r}"
                + did_you_mean(rule, known_rules)
            )
        if not isinstance(patterns, list) or not all(isinstance(p, str) for p in patterns):
            raise ConfigError(
                f"{where} [tool.erc-lint] ignore_only for {rule!r} must be a list of path patterns"
            )
    return MappingProxyType({rule: tuple(patterns) for rule, patterns in value.items()})


def _budget(path: Path, value: object, roots: tuple[str, ...]) -> Mapping[str, int]:
    """``budget = { Root = bytes, ... }``: each key a root, each value a positive byte count."""
    if value is None:
        return MappingProxyType({})
    where = _at(path, "budget")
    if not isinstance(value, dict):
        raise ConfigError(f"{where} [tool.erc-lint] budget must be a table, {{ Root = bytes }}")
    for root, limit in value.items():
        if isinstance(limit, dict):  # a dotted key, `acme.Env = 300`, reads as nested tables
            raise ConfigError(
                f'{where} [tool.erc-lint] budget: quote a dotted root name ("{root}.…" = bytes)'
            )
    problem = _budget_problem(value, roots)
    if problem:
        raise ConfigError(f"{where} [tool.erc-lint] {problem}")
    return MappingProxyType(dict(value))


def check_config(config: Config) -> None:
    """``ConfigError`` for a ``Config`` built in code that ``read_config`` would refuse: a
    budget that is no positive number of bytes, or for a message that is not a root (it would
    check nothing, in silence)."""
    problem = _budget_problem(config.budget, config.roots)
    if problem:
        where = f"{config.source}: [tool.erc-lint]" if config.source else "Config:"
        raise ConfigError(f"{where} {problem}")


def _budget_problem(budget: Mapping[str, object], roots: tuple[str, ...]) -> str:
    """What is wrong with ``budget`` for ``roots``, in the words of ``[tool.erc-lint]`` errors
    ("" when nothing is)."""
    for root, limit in budget.items():
        if not isinstance(limit, int) or isinstance(limit, bool) or limit <= 0:
            return f"budget for {root!r} must be a positive number of bytes"
        if root not in roots:
            return f"budget names {root!r}, which is not one of the roots ({', '.join(roots)})"
    return ""


def _at(path: Path, key: str) -> str:
    """``path:line:`` of the line setting ``key``, for an error message."""
    return f"{path}:{_line_of(path, key)}:"


def _line_of(path: Path, key: str) -> int:
    """The line of ``path`` that sets ``key`` in ``[tool.erc-lint]`` (1 if none is found)."""
    inside = False
    for number, line in enumerate(_read(path).splitlines(), 1):
        text = line.strip()
        if text.startswith("["):
            inside = text.replace(" ", "") in ("[tool.erc-lint]", '[tool."erc-lint"]')
        elif inside and text.split("=", 1)[0].strip() == key:
            return number
    return 1


def _table(path: Path) -> dict[str, Any] | None:
    """The ``[tool.erc-lint]`` table of a pyproject.toml, ``None`` if it has none."""
    # Imported only when there is a file to read: a tree without a configuration never loads it.
    if sys.version_info >= (3, 11):
        import tomllib
    else:  # tomllib is tomli, joined to the standard library in 3.11
        import tomli as tomllib

    try:
        document = tomllib.loads(_read(path))
    except tomllib.TOMLDecodeError as error:
        raise ConfigError(f"{path}: {error}") from None
    tool = document.get("tool", {})
    table = tool.get("erc-lint") if isinstance(tool, dict) else None
    if table is not None and not isinstance(table, dict):
        raise ConfigError(f"{path}: tool.erc-lint must be a table")
    return table


def _read(path: Path) -> str:
    """The configuration's text: a regular file of at most CONFIG_LIMIT bytes of UTF-8."""
    try:
        return read_text(path, CONFIG_LIMIT)
    except FileError as error:
        raise ConfigError(str(error)) from None
