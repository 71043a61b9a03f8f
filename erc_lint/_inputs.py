"""What OLD, NEW or TREE name, opened for the linter, and findings named as the user named them.

A tree is a folder or a git revision (``erc_schema.open_tree``); a revision's scratch copy
holds its protos and options, and the configuration and ledger at its top. Findings about files
of a git revision name them as the repository does (``GITDIR/PATH/file.proto``), so a CI
annotation or an editor opens the same file a plain folder would have named.
"""

import os
import re
from collections.abc import Iterator, Sequence
from contextlib import AbstractContextManager, contextmanager
from pathlib import Path

from erc_schema import (
    GitSpec,
    Repository,
    TreeSource,
    open_tree,
    parse_tree_spec,
    proto_files,
)

from ._config import CONFIG, CONFIG_LIMIT, LEDGER, LEDGER_LIMIT
from ._errors import LintError
from ._finding import Finding, stable_text
from ._loader import relative
from ._suggest import did_you_mean

__all__ = [
    "baseline_keys",
    "missing_folder",
    "missing_in_git",
    "open_input",
    "opened",
    "relocate",
]


def open_input(text: str) -> AbstractContextManager[TreeSource]:
    """The tree ``text`` names, as a folder, for the duration of the ``with`` block."""
    return open_tree(text, {CONFIG: CONFIG_LIMIT, LEDGER: LEDGER_LIMIT})


@contextmanager
def opened(text: str, role: str, allow_empty: bool = False) -> Iterator[TreeSource]:
    """The tree ``text`` names, for ``role`` (OLD, NEW or TREE): a wrong path, a subdir a
    revision lacks, or a tree with no .proto is a ``LintError`` rather than an empty tree that
    passes every check (for the commands and the API alike). An empty OLD passes only before a
    repository's first commit (``HEAD`` unborn) or with ``allow_empty``."""
    spec = parse_tree_spec(text)
    if isinstance(spec, Path):
        problem = missing_folder(spec)
        if problem and not (allow_empty and spec.is_dir()):
            raise LintError(f"{text}: {problem} in {role} (a wrong path would pass every check)")
    with open_input(text) as source:
        if isinstance(spec, GitSpec) and not proto_files(source.folder):
            unborn = source.revision is None
            if not (allow_empty or (unborn and role == "OLD")):
                with Repository(spec.folder) as repository:
                    inside = repository.where(spec.subdir)[0]
                    why = missing_in_git(repository, source.revision or "", inside)
                    raise LintError(f"{text}: no .proto file in {role}: {why}")
        yield source


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


def missing_in_git(repository: Repository, commit: str, inside: str) -> str:
    """Where a git input found no .proto, with the closest folder that has some."""
    folders = {
        str(Path(name).parent) for name in repository.files(commit) if name.endswith(".proto")
    }
    where = f"subdir {inside!r}" if inside else "the repository"
    return f"none in {where} at {commit[:12]}" + did_you_mean(inside, folders)


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
        message, fix = finding.message, finding.fix
        for scratch, shown in moves:
            message, fix = message.replace(scratch, shown), fix.replace(scratch, shown)
        where = finding.in_new
        out.append(
            finding._replace(
                path=moved(finding.path),
                message=message,
                fix=fix,
                in_new=where._replace(path=moved(where.path)) if where else None,
            )
        )
    return out


def baseline_keys(
    findings: Sequence[Finding], old: TreeSource, new: TreeSource, sources: Sequence[TreeSource]
) -> list[str]:
    """Each finding's baseline key: its file relative to its tree's root (OLD's for a finding in
    OLD), and every path of a tree in its message made relative too (a git input's scratch
    folder, a folder as the user spelled it, the ledger beside the protos): the same finding
    has the same key however the trees were read."""
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
    # A path starts a word: after the start, a space, a quote or a parenthesis.
    spelled = "|".join(re.escape(prefix) for prefix in prefixes)
    paths = re.compile(f"(?<![^\\s\"'(])(?:{spelled})") if prefixes else None
    keys = []
    for finding in findings:
        root = old if finding.in_old else new
        message = paths.sub("", finding.message) if paths else finding.message
        path = relative(root.folder, finding.path)
        keys.append(stable_text(finding._replace(message=message), path))
    return keys
