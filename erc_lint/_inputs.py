"""What OLD, NEW or TREE name, opened for the linter, and findings named as the user named them.

A tree is a folder or a git revision (``erc_codec.schema.open_tree``); a revision's scratch copy
holds its protos and options, and the configuration and ledger at its top. Findings about files
of a git revision name them as the repository does (``GITDIR/PATH/file.proto``), so a CI
annotation or an editor opens the same file a plain folder would have named.
"""

import os
from collections.abc import Sequence
from contextlib import AbstractContextManager
from pathlib import Path

from erc_codec.schema import TreeSource, open_tree, proto_files

from ._config import CONFIG, CONFIG_LIMIT, LEDGER, LEDGER_LIMIT
from ._finding import Finding
from ._suggest import did_you_mean

__all__ = ["missing_folder", "open_input", "relocate"]


def open_input(text: str) -> AbstractContextManager[TreeSource]:
    """The tree ``text`` names, as a folder, for the duration of the ``with`` block."""
    return open_tree(text, {CONFIG: CONFIG_LIMIT, LEDGER: LEDGER_LIMIT})


def missing_folder(folder: Path) -> str:
    """Why ``folder`` holds no proto tree (with the closest name beside it), or ``""``."""
    if not folder.is_dir():
        what = "not a folder" if folder.exists() else "no such folder"
        parent = folder.parent if folder.parent.is_dir() else None
        names = [p.name for p in parent.iterdir() if p.is_dir()] if parent else []
        return f"{what}{did_you_mean(folder.name, names)}"
    if not proto_files(folder):
        return "no .proto file"
    return ""


def relocate(findings: Sequence[Finding], sources: Sequence[TreeSource]) -> list[Finding]:
    """The findings with every scratch folder's path replaced by the name its tree is shown as."""
    moves = [
        (str(source.folder) + os.sep, "" if str(source.shown) == "." else f"{source.shown}{os.sep}")
        for source in sources
        if source.folder != source.shown
    ]
    if not moves:
        return list(findings)
    moved = []
    for finding in findings:
        path, message = finding.path, finding.message
        for scratch, shown in moves:
            path = shown + path.removeprefix(scratch) if path.startswith(scratch) else path
            message = message.replace(scratch, shown)
        moved.append(finding._replace(path=path, message=message))
    return moved
