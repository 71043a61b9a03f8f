"""What both command lines share about click: a group whose every error is one line."""

import sys
from typing import Any

import click

__all__ = ["OneLineGroup"]


class OneLineGroup(click.Group):
    """A command group whose every error is one line on stderr: click's usage errors print
    usage, hint and error on three. Exit statuses stay click's (2 for usage errors)."""

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
        sys.exit(status if isinstance(status, int) else 0)
