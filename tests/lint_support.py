"""What the erc-lint tests share: trees written from text, the command run as a user runs it,
and git repositories whose histories a test scripts."""

import functools
import re
import subprocess
import sys
import tempfile
from pathlib import Path

from git_support import HEADER, Repo

from erc_lint import Finding
from erc_lint._history import History
from erc_lint._ledger import Entry, Ledger
from erc_schema import GitSpec, ProtocError, Repository, compile_files


@functools.cache
def protoc_edition() -> int:
    """The latest edition the bundled protoc compiles, as protoc itself answers: 2023 up to
    grpcio-tools 1.80 (the protobuf floor's), 2024 from 1.81 on."""
    with tempfile.TemporaryDirectory() as folder:
        Path(folder, "probe.proto").write_text('edition = "2024";\n')
        try:
            compile_files(Path(folder), ["probe.proto"], locations=False)
        except ProtocError as error:
            found = re.search(r"maximum supported edition (\d+)", str(error))
            if found is None:
                raise
            return int(found[1])
    return 2024


def tree(root: Path, files: dict[str, str]) -> Path:
    """Write ``files`` (``{path: text}``, each given a proto3 syntax line) under ``root``."""
    for name, text in files.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(HEADER + text)
    return root


def erc_lint_cli(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    """``erc-lint ARGS`` as a user runs it (``python -m erc_lint``), output captured."""
    return subprocess.run(
        [sys.executable, "-m", "erc_lint", *args], capture_output=True, text=True, cwd=cwd
    )


def rules(findings: list[Finding]) -> list[str]:
    """The rule of each finding, in order."""
    return [finding.rule for finding in findings]


SHAPES = {
    "components/a/shape.proto": "message Shape { float width = 1; }\n",
    "components/b/prefixed.proto": 'import "ERC-Protobufs/components/a/shape.proto";\n'
    "message Prefixed { Shape shape = 1; }\n",
    "components/b/bare.proto": 'import "shape.proto";\nmessage Bare { Shape shape = 1; }\n',
    "proto/components/c/rooted.proto": 'import "components/a/shape.proto";\n'
    "message Rooted { Shape shape = 1; }\n",
}


READING = {
    "envelope.proto": 'import "reading.proto";\n'
    "message PBEnvelope { oneof payload { Reading reading = 1; } }\n",
    "reading.proto": 'import "nanopb.proto";\n'
    "enum Mode { MODE_IDLE = 0; MODE_RUN = 1; }\n"
    "message Reading {\n  message Raw { uint32 count = 1 [(nanopb).int_size = IS_8]; }\n"
    "  string label = 1;\n  Mode mode = 2;\n  Raw raw = 3;\n}\n",
    "reading.options": "Reading.label max_size:16\n",
}


def walk(repo: Repo, commits: list[str] | None = None) -> tuple[History, Ledger, list[Entry]]:
    """``ledger update --history`` in process over ``repo``'s main (or ``commits``): the walker,
    the ledger it filled and the entries it added."""
    book = Ledger("mem")
    with Repository(repo.root) as repository:
        history = History(repository, GitSpec(repo.root, "main", "proto"))
        added = history.update(book, repository.history("main") if commits is None else commits)
    return history, book, added


def reused_history(tmp_path: Path) -> tuple[Repo, dict[str, str]]:
    """Number 2 of Diag: a float, deleted unreserved, then on a branch a uint32 under another
    name, merged back while main moved on."""
    repo = Repo(tmp_path / "repo")
    ids = {
        "add": repo.commit(
            "add", diag="message Diag { uint32 board = 1; float temperature = 2; }\n"
        ),
        "delete": repo.commit("delete", diag="message Diag { uint32 board = 1; }\n"),
    }
    repo.git("checkout", "-q", "-b", "side")
    ids["reuse"] = repo.commit(
        "reuse", diag="message Diag { uint32 board = 1; uint32 error_count = 2; }\n"
    )
    repo.git("checkout", "-q", "main")
    ids["other"] = repo.commit("other", other="message Other { bool on = 1; }\n")
    repo.git("merge", "-q", "--no-ff", "side", "-m", "merge")
    ids["merge"] = repo.git("rev-parse", "HEAD")
    return repo, ids
