"""``erc-lint ledger update --history`` over a generated git history: time, and how it grows.

    python benchmarks/bench_ledger.py [--quick] [--keep]

A git repository is generated in a temporary folder (never in this repository) with
``git fast-import``: 500 revisions of a 30-file tree (bench_lint's generator: 29 unit files with
imports between them and an envelope importing every fourth). The first revision adds the tree;
each later one edits one file the way a proto history does: a field added (60%), the last field
deleted without ``reserved`` (25%; a later addition may take the number again, with another name
and type), or a field's type changed (15%). Branches ``at-100``, ``at-250`` and ``at-500`` point
at the 100th, 250th and 500th revision.

For each, the command runs as a subprocess (median of 3 runs, ``--quick`` 1) into a fresh
ledger. Printed: the wall time, the time per revision, and the growth: time per revision at 500
over time per revision at 100 (linear means about 1; target at most 1.5). Also printed, from an
in-process run over all 500 revisions: how many files it compiled against the 15,000 a walk
without the blob cache would compile, and the time such a walk would take, estimated from
whole-tree compilations of the final tree. No edit renames a definition, so a correct cache
compiles the first tree and then at most the edited file of each revision. Exit status 1 when
the growth target is missed or the cache compiled more than that.
"""

import argparse
import random
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench_lint import _envelope, _Field, _File, _plan, _render

from erc_lint._history import History
from erc_lint._ledger import Ledger
from erc_lint._loader import load_tree
from erc_schema import GitSpec, Repository

_FILES = 30
_REVISIONS = (100, 250, 500)
_TARGET_GROWTH = 1.5
_SCALARS = ("float", "double", "uint32", "int32", "sint32", "fixed32", "bool", "uint64", "int64")


def generate(repo: Path, revisions: int, seed: int = 20261122) -> None:
    """Write the history into a new repository at ``repo``."""
    rng = random.Random(seed)
    plan = _plan(_FILES, seed)
    stream: list[bytes] = []

    def commit(number: int, message: str, files: list[_File], envelope: bool) -> None:
        body = [
            f"commit refs/heads/main\nmark :{number}\n",
            f"committer bench <bench@example.invalid> {1_700_000_000 + number * 60} +0000\n",
            f"data {len(message)}\n{message}\n",
        ]
        if number > 1:
            body.append(f"from :{number - 1}\n")
        for unit in files:
            body.append(_inline(f"proto/{unit.path}", _render(unit, plan)))
        if envelope:
            body.append(_inline("proto/components/common/envelope.proto", _envelope(plan)))
        stream.append("".join(body).encode())
        if number in _REVISIONS:
            stream.append(f"reset refs/heads/at-{number}\nfrom :{number}\n\n".encode())

    commit(1, "the tree", plan, True)
    for number in range(2, revisions + 1):
        unit = rng.choice(plan)
        message = rng.choice(unit.messages)
        roll = rng.random()
        if roll < 0.25 and len(message.fields) > 2:
            gone = message.fields.pop()
            what = f"delete {message.name}.{gone.name}"
        elif roll < 0.40:
            target = rng.choice(message.fields[1:] or message.fields)
            if target.type in _SCALARS:
                target.type = rng.choice([t for t in _SCALARS if t != target.type])
            what = f"retype {message.name}.{target.name}"
        else:
            name = f"field_{number}"
            kind = rng.choice(_SCALARS)
            message.fields.append(_Field(kind, name, len(message.fields) + 1, "added"))
            what = f"add {message.name}.{name}"
        commit(number, what, [unit], False)
    subprocess.run(["git", "init", "-q", "-b", "main", str(repo)], check=True)
    subprocess.run(["git", "fast-import", "--quiet"], cwd=repo, input=b"".join(stream), check=True)


def _inline(path: str, text: str) -> str:
    data = text.encode()
    return f"M 100644 inline {path}\ndata {len(data)}\n{text}\n"


def _time_cli(repo: Path, ref: str, scratch: Path, runs: int) -> float:
    times = []
    for run in range(runs):
        ledger = scratch / f"{ref}-{run}.lock"
        spec = f"{repo}#ref={ref},subdir=proto"
        command = ["erc-lint", "ledger", "update", spec, "--history", "--ledger", str(ledger)]
        start = time.perf_counter()
        subprocess.run(command, check=True, capture_output=True)
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="one run per size")
    parser.add_argument("--keep", action="store_true", help="keep and print the scratch folder")
    args = parser.parse_args()
    runs = 1 if args.quick else 3
    scratch = Path(tempfile.mkdtemp(prefix="erc-lint-bench-ledger-"))
    repo = scratch / "repo"
    generate(repo, max(_REVISIONS))
    print(f"history: {max(_REVISIONS)} revisions of a {_FILES}-file tree in {repo}")

    per_revision = {}
    for count in _REVISIONS:
        seconds = _time_cli(repo, f"at-{count}", scratch, runs)
        per_revision[count] = seconds / count
        print(
            f"  {count:>4} revisions: {seconds:6.2f} s  "
            f"({1000 * seconds / count:5.2f} ms per revision, median of {runs})"
        )
    growth = per_revision[max(_REVISIONS)] / per_revision[min(_REVISIONS)]
    print(f"growth: {growth:.2f}x time per revision from {min(_REVISIONS)} to {max(_REVISIONS)}")

    with Repository(repo) as repository:
        walker = History(repository, GitSpec(repo, "main", "proto"))
        start = time.perf_counter()
        walker.update(Ledger("bench"), repository.history("main"))
        cached = time.perf_counter() - start
    bound = _FILES + max(_REVISIONS) - 1
    naive_files = _FILES * max(_REVISIONS)
    print(
        f"compiled: {walker.compiled} files (bound {bound}: the first tree, then one per edit) "
        f"against {naive_files} without the cache"
    )
    final = scratch / "final"
    subprocess.run(
        ["git", "-C", str(repo), "archive", "main", "proto", "-o", str(scratch / "final.tar")],
        check=True,
    )
    final.mkdir()
    subprocess.run(["tar", "-xf", str(scratch / "final.tar"), "-C", str(final)], check=True)
    start = time.perf_counter()
    for _ in range(5):
        load_tree(final / "proto")
    whole = (time.perf_counter() - start) / 5
    naive = whole * naive_files / _FILES
    print(
        f"in-process walk: {cached:.2f} s; without the cache about {naive:.1f} s "
        f"({1000 * whole:.0f} ms per whole-tree compile x {max(_REVISIONS)})"
    )
    if args.keep:
        print(f"kept: {scratch}")
    else:
        shutil.rmtree(scratch)
    missed = growth > _TARGET_GROWTH or walker.compiled > bound
    print("targets:", "MISSED" if missed else "met")
    return 1 if missed else 0


if __name__ == "__main__":
    sys.exit(main())
