"""What both command lines share about click: a group whose every error is one line."""

import contextlib
import os
import sys
from typing import Any

import click

from .._errors import CodecError, SchemaError

__all__ = ["OneLineGroup"]


class OneLineGroup(click.Group):
    """A command group whose every error is one line on stderr: click's usage errors print
    usage, hint and error on three. Exit statuses stay click's (2 for usage errors); output that
    cannot be written is one line and 2, except a reader that went away (``| head``), which ends
    the command quietly with status 1. A codec error no command turned into its own words is
    one line too: 2 for a ``SchemaError`` (a message of the schema erc-codec cannot encode or
    decode, say), else 1."""

    def main(self, *args: Any, **kwargs: Any) -> Any:
        kwargs["standalone_mode"] = False
        try:
            status = super().main(*args, **kwargs)
        except click.ClickException as error:
            if type(error).__name__ == "NoArgsIsHelpError":  # a bare group: its help, as is
                click.echo(error.format_message(), err=True)
            else:
                click.echo(f"Error: {error.format_message()}", err=True)
            sys.exit(error.exit_code)
        except click.Abort:
            click.echo("Aborted!", err=True)
            sys.exit(1)
        except CodecError as error:
            click.echo(f"Error: {' '.join(str(error).split())}", err=True)
            sys.exit(2 if isinstance(error, SchemaError) else 1)
        except BrokenPipeError:
            _silence_unwritable_stdout()
            sys.exit(1)
        except OSError as error:  # output that could not be written (a full disk, say)
            _silence_unwritable_stdout()
            with contextlib.suppress(OSError):  # stderr may be just as full: nothing to add
                click.echo(f"Error: {error}", err=True)
            sys.exit(2)
        sys.exit(status if isinstance(status, int) else 0)


def _silence_unwritable_stdout() -> None:
    """Point a standard output that cannot take what it holds at /dev/null, so the flush at exit
    does not fail a second time (Python's own recipe for a closed pipe)."""
    try:
        if sys.stdout is not None:
            sys.stdout.flush()
    except OSError:
        sink = os.open(os.devnull, os.O_WRONLY)
        os.dup2(sink, sys.stdout.fileno())
        os.close(sink)
