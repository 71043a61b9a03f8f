"""What OLD, NEW or TREE name, opened for the linter, and findings named as the user named them.

A tree is a folder or a git revision (``erc_codec.schema.open_tree``); a revision's scratch copy
holds its protos and options, and the configuration and ledger at its top. Findings about files
of a git revision name them as the repository does (``GITDIR/PATH/file.proto``), so a CI
annotation or an editor opens the same file a plain folder would have named.
"""

import os
import re
from collections.abc import Sequence
from contextlib import AbstractContextManager
from pathlib import Path

from erc_codec.schema import TreeSource, open_tree, proto_files

from ._config import CONFIG, CONFIG_LIMIT, LEDGER, LEDGER_LIMIT
from ._finding import Finding, stable_text
from ._loader import relative
from ._suggest import did_you_mean

__all__ = ["baseline_key", "missing_folder", "open_input", "relocate"]


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
    """The findings with every scratch folder's path replaced by the name its tree is shown as
    (in ``path``, ``message`` and ``in_new``)."""
    moves = [
        (str(source.folder) + os.sep, "" if str(source.shown) == "." else f"{source.shown}{os.sep}")
        for source in sources
        if source.folder != source.shown
    ]
    if not moves:
        return list(findings)

    def moved(path: str) -> str:
        for scratch, shown in moves:
            if path.startswith(scratch):
                return shown + path.removeprefix(scratch)
        return path

    out = []
    for finding in findings:
        message = finding.message
        for scratch, shown in moves:
            message = message.replace(scratch, shown)
        where = finding.in_new
        out.append(
            finding._replace(
                path=moved(finding.path),
                message=message,
                in_new=where._replace(path=moved(where.path)) if where else None,
            )
        )
    return out


def baseline_key(
    finding: Finding, old: TreeSource, new: TreeSource, sources: Sequence[TreeSource]
) -> str:
    """The finding's baseline key: its file relative to its tree's root (OLD's for a finding in
    OLD), and every path of a tree in its message made relative too (a git input's scratch
    folder, a folder as the user spelled it, the ledger beside the protos): the same finding
    has the same key however the trees were read."""
    root = old if finding.in_old else new
    prefixes = sorted(
        {
            f"{folder}{os.sep}"
            for source in sources
            for folder in (source.folder, source.shown)
            if str(folder) != "."
        },
        key=len,
        reverse=True,
    )
    message = finding.message
    if prefixes:
        # A path starts a word: after the start, a space, a quote or a parenthesis.
        spelled = "|".join(re.escape(prefix) for prefix in prefixes)
        message = re.sub(f"(?<![^\\s\"'(])(?:{spelled})", "", message)
    return stable_text(finding._replace(message=message), relative(root.folder, finding.path))
