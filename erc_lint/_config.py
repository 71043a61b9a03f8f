"""``[tool.erc-lint]`` in a pyproject.toml: embedded roots, rules to ignore, paths to exclude."""

import sys
from pathlib import Path
from typing import Any, NamedTuple

from erc_codec.schema import FileError, file_exists, read_text

from ._errors import ConfigError

__all__ = [
    "CONFIG",
    "CONFIG_LIMIT",
    "LEDGER",
    "LEDGER_LIMIT",
    "Config",
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


class Config(NamedTuple):
    roots: tuple[str, ...] = _ROOTS  # embedded roots: fixed-size from here down
    ignore: frozenset[str] = frozenset()  # rule IDs
    exclude: tuple[str, ...] = ()  # fnmatch patterns on paths relative to a tree's root
    source: str | None = None  # the file it was read from
    roots_line: int = 0  # the line of that file that sets roots (0: the default roots)

    @property
    def roots_chosen(self) -> bool:
        """Whether someone named the roots (a typo there must not pass in silence)."""
        return self.roots_line > 0 or self.roots != _ROOTS


def find_config(*folders: Path) -> Path | None:
    """The first pyproject.toml in ``folders`` with a ``[tool.erc-lint]`` table."""
    for folder in folders:
        candidate = folder / CONFIG
        if file_exists(candidate) and _table(candidate) is not None:  # a FIFO is refused
            return candidate
    return None


def read_config(path: Path | None, known_rules: set[str], explicit: bool = False) -> Config:
    """The configuration in ``path`` (defaults when None); an ``explicit`` file must have one."""
    if path is None:
        return Config()
    table = _table(path)
    if table is None:
        if explicit:
            raise ConfigError(f"{path}: no [tool.erc-lint] table")
        return Config()
    unknown = set(table) - {"roots", "ignore", "exclude"}
    if unknown:
        raise ConfigError(f"{path}: unknown [tool.erc-lint] key {sorted(unknown)[0]!r}")
    values: dict[str, list[str]] = {}
    for key in ("roots", "ignore", "exclude"):
        value = table.get(key, [])
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            raise ConfigError(f"{path}: [tool.erc-lint] {key} must be a list of strings")
        values[key] = value
    strange = set(values["ignore"]) - known_rules
    if strange:
        raise ConfigError(f"{path}: [tool.erc-lint] ignore names no rule {sorted(strange)[0]!r}")
    return Config(
        roots=tuple(values["roots"]) if "roots" in table else _ROOTS,
        ignore=frozenset(values["ignore"]),
        exclude=tuple(values["exclude"]),
        source=str(path),
        roots_line=_line_of(path, "roots") if "roots" in table else 0,
    )


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
    # Only when there is a file to read: for bench_lint's 30-file ratio, a tree without a
    # configuration does not pay for it (about 8 ms of start-up).
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
