"""nanopb's generator inputs on a command line, as both command lines take them: ``-I DIR``
(repeatable), ``-f OPTIONS_FILE`` and ``-s OPTION=VALUE`` (repeatable, ``OPTION:VALUE`` too), and
``--nanopb-version`` (whose generator's sizing rules apply: one of ``NANOPB_VERSIONS``).

Each is checked as it is read, so a mistake is a usage error (one line, exit 2) before any tree
is compiled: an include folder that is not there, a setting nanopb's generator cannot read. An
options file is a pattern (``%s.nanopb``: each ``.proto``'s own, looked for as the generator
looks, under the tree's root, then under each include folder) or one file for every ``.proto``,
taken from the working folder when it is there, else looked for as a pattern is; one found
nowhere is a ``SchemaError`` when the tree loads.
"""

from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import click

from .. import NANOPB_VERSIONS, given_options_file, resolve_options
from .._errors import SchemaError

__all__ = ["generator_options"]

_Command = TypeVar("_Command", bound=Callable[..., Any])
Store = Callable[[click.Context, click.Parameter, Any], Any]


def _options_file(value: str | None) -> str | None:
    """``-f``: a pattern as given, or one file, made absolute when the working folder holds it."""
    if value is None:
        return None
    if not value.strip():
        raise click.BadParameter("give a file, or a pattern such as %s.options")
    return given_options_file(value, Path.cwd())


def _settings(values: tuple[str, ...]) -> tuple[str, ...]:
    """``-s``: each setting read as nanopb's generator reads it."""
    for value in values:
        try:
            resolve_options(Path("."), (), settings=[value])
        except SchemaError as error:
            raise click.BadParameter(" ".join(str(error).split())) from None
    return values


def generator_options(store: Store | None = None) -> Callable[[_Command], _Command]:
    """``-I/--include DIR`` (``includes``), ``-f/--options-file FILE`` (``options_file``),
    ``-s OPTION=VALUE`` (``generator_settings``) and ``--nanopb-version`` (``nanopb_version``,
    ``None`` when not given) for a command; with ``store``, the values are handed to it (click's
    option callback) rather than to the command."""

    def checked(check: Callable[[Any], Any]) -> Store:
        def callback(ctx: click.Context, param: click.Parameter, value: Any) -> Any:
            value = check(value)
            return value if store is None else store(ctx, param, value)

        return callback

    options = [
        click.option(
            "-I",
            "--include",
            "includes",
            metavar="DIR",
            multiple=True,
            type=click.Path(exists=True, file_okay=False, path_type=Path),
            expose_value=store is None,
            callback=checked(lambda value: value),
            help="Another import folder, searched after the tree's root (repeatable): "
            "protoc's and nanopb's -I.",
        ),
        click.option(
            "-f",
            "--options-file",
            "options_file",
            metavar="FILE",
            expose_value=store is None,
            callback=checked(_options_file),
            help="nanopb's -f: each .proto's options file, a pattern (%s its name without "
            ".proto; default %s.options), or one file for all.",
        ),
        click.option(
            "-s",
            "generator_settings",
            multiple=True,
            expose_value=store is None,
            callback=checked(_settings),
            metavar="OPTION=VALUE",
            help="nanopb's -s: a generator setting every file starts from, e.g. max_size=61 "
            "(repeatable).",
        ),
        click.option(
            "--nanopb-version",
            "nanopb_version",
            type=click.Choice(NANOPB_VERSIONS),
            expose_value=store is None,
            callback=checked(lambda value: value),
            help=f"Whose generator's sizing rules apply: {NANOPB_VERSIONS[0]} (every 0.4.x, the "
            "default), or 1.0.0-dev (master after 0.4.9.1: bounded pointer and callback fields "
            "get a size).",
        ),
    ]

    def decorate(command: _Command) -> _Command:
        for option in reversed(options):
            command = option(command)
        return command

    return decorate
