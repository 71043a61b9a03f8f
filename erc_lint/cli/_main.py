"""The ``erc-lint`` group: ``erc-lint OLD NEW`` means ``erc-lint diff OLD NEW``; every command
group of the command line added to it."""

from pathlib import Path

import click

from erc_schema.cli import OneLineGroup

from .._suggest import did_you_mean
from ._diff import baseline, check, diff

__all__ = ["main"]

_OPTIONS = ("-h", "--help", "--version")


# Commands loaded on first use: linting never loads the history walker's imports, nor builds
# the rules commands.
_LATER = ("ledger", "rules", "explain")


class _LintGroup(OneLineGroup):
    """A group whose default command is ``diff``; those of ``_LATER`` load on first use."""

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        commands = self.list_commands(ctx)
        if args and args[0] not in commands and args[0] not in _OPTIONS:
            hint = did_you_mean(args[0], commands) if _not_a_tree(args[0]) else ""
            if hint:  # `erc-lint chek real`: a mistyped command, not a missing folder
                raise click.UsageError(f"no command {args[0]!r}{hint}", ctx)
            args = ["diff", *args]
        return super().parse_args(ctx, args)

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted({*super().list_commands(ctx), *_LATER})

    def get_command(self, ctx: click.Context, name: str) -> click.Command | None:
        if name == "ledger" and name not in self.commands:
            from ._ledger import ledger

            self.add_command(ledger)
        elif name in ("rules", "explain") and name not in self.commands:
            from ._rules import explain, list_rules

            self.add_command(list_rules)
            self.add_command(explain)
        return super().get_command(ctx, name)


def _not_a_tree(word: str) -> bool:
    """Whether ``word`` cannot be a tree: no folder of that name, and no git input."""
    return "#" not in word and "/" not in word and not Path(word).exists()


@click.group(cls=_LintGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="erc-codec")
def main() -> None:
    """Wire-compatibility linter for proto trees: erc-lint OLD NEW.

    A tree is a folder, or a git revision in buf's spelling, GITDIR#ref=REF[,subdir=PATH],
    read from the repository's objects without a checkout.
    """


for _command in (diff, check, baseline):
    main.add_command(_command)
