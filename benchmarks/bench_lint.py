"""Wall time of ``erc-lint OLD NEW`` against buf's breaking-change checker (WIRE), as a ratio.

    python benchmarks/bench_lint.py [--quick] [--rounds N] [--keep] [--here]

Both contenders run as subprocesses on the same pairs of generated trees (written to a temporary
folder, never into the repository): ``erc-lint OLD NEW`` and ``buf breaking NEW --against OLD``
with a buf configuration limited to the WIRE category (``pip install buf-bin`` ships ``buf``).
Two pairs of 30 files are timed: a proto3 pair, and a pair of proto2 and edition 2023 files with
required fields, defaults, groups and delimited fields, closed enums, extension ranges and
extensions. On each, they run interleaved, erc-lint then buf, for N rounds (default 11,
``--quick`` 3); each keeps the MEDIAN of its rounds, and the best is printed beside it for
information. Before timing, a sanity check makes sure both really compare the trees: on OLD
against itself both must report no error, on OLD against NEW both must report the changes NEW
makes, naming each member (the proto3 pair: a changed field type and a deleted field; the other: a
changed default, a deleted field, an extension's changed type, a group made a plain message);
anything else stops the script with exit status 2. The erc-lint timed is a wheel of this checkout
installed in a new virtual environment, as ``pipx install`` leaves it: byte-compiled, its
dependencies at the versions this interpreter has (pip fetches them, or takes them from its
cache), and nothing of this interpreter's own site-packages on its path, whose ``.pth`` files may
run code at every start (a sandbox's certificate hook importing certifi: some 13 ms of every run
here). ``--here``, or an install pip cannot make, times this interpreter's erc-lint instead,
byte-compiled first. Each round also times the start-up floor, erc-lint's interpreter importing
erc-lint's dependencies and nothing of its own, which is printed for information as a share of
buf's time.

Targets (from the linter issues):
- ratio erc-lint/buf ≤ 1.0 on each 30-file pair;
- erc-lint under 5 s on a 1,000-file tree;
- linear growth: erc-lint alone is timed at 250, 500 and 1,000 files (median of 5 runs after one
  warm-up, ``--quick`` 1), and its time per file (whole command, start-up included) at 1,000 files
  must be at most 1.5x its time per file at 250 files.

Generated trees have no package: files spread over a few ``components/<board>/`` folders with
root-relative imports of one or two earlier files, globally unique names, and in each file an enum
and three messages of scalar, enum and submessage fields; ``components/common/envelope.proto``
holds ``message PBEnvelope { oneof payload { ... } }`` over every fourth file's report message.
Everything is fixed-size (no repeated, string or bytes fields). In the proto2 and editions pair,
files alternate between the two; each sample has a default, each status a required mode, each
report a group (proto2) or a delimited submessage (editions) and an extension range, which the
next file extends; the first file has a ``.options`` file and the envelope a service, so the
nanopb and RPC rules compare something. The file count includes the envelope. Exit status 1 when
a target is missed.
"""

import argparse
import compileall
import importlib.metadata
import json
import os
import random
import re
import shutil
import statistics
import subprocess
import sys
import sysconfig
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import NoReturn

import erc_codec
import erc_lint

_RATIO_FILES = 30
_SCALING_FILES = (250, 500, 1000)
_TARGET_RATIO = 1.0
_TARGET_SECONDS = 5.0  # erc-lint on the largest tree
_TARGET_GROWTH = 1.5  # time per file at the largest size over time per file at the smallest

_BUF_CONFIG = json.dumps({"version": "v2", "breaking": {"use": ["WIRE"]}})
_BUF_FINDINGS = 100  # buf's exit status when it found breaking changes
_TIMEOUT = 300.0

_FOLDERS = ("arm_board", "basestation", "driving_board", "sensor_board", "power_board", "science")
_SCALARS = ("float", "double", "uint32", "int32", "sint32", "fixed32", "bool", "uint64", "int64")
_QUANTITIES = (
    "voltage",
    "current",
    "temperature",
    "pressure",
    "rpm",
    "angle",
    "speed",
    "position_x",
    "position_y",
    "position_z",
    "heading",
    "timestamp_ms",
    "counter",
    "flags",
    "load",
    "humidity",
)
_MODES = ("IDLE", "RUNNING", "CALIBRATING", "ERRORED", "STOPPED")


# --- generated trees ---------------------------------------------------------------------------


@dataclass
class _Field:
    type: str
    name: str
    number: int
    note: str


@dataclass
class _Message:
    name: str
    fields: list[_Field] = field(default_factory=list)


@dataclass
class _File:
    index: int
    path: str
    imports: list[int]
    enum: str
    messages: list[_Message]


@dataclass(frozen=True)
class Breaking:
    """Where NEW differs from OLD: each member ("Message.field") both tools must name."""

    members: tuple[str, ...]


@dataclass(frozen=True)
class _Legacy:
    """What NEW changes in a proto2 and editions tree (unit indexes), beyond ``_break``'s."""

    default: int  # its sample's default
    extension: int  # the type of its extension (of the previous unit's report)
    group: int  # a proto2 unit whose report's group becomes a plain message


def _plan(files: int, seed: int) -> list[_File]:
    """The unit files of a tree of ``files`` files (the envelope not included)."""
    rng = random.Random(seed)
    plan: list[_File] = []
    for index in range(files - 1):
        stem = f"Unit{index:04d}"
        earlier = [index - 1] if index else []
        if index >= 2 and rng.random() < 0.5:
            earlier.append(rng.randrange(index - 1))
        sample = _Message(f"{stem}Sample", _scalars(rng, [("float", "value")], 2, 5))
        status = _Message(f"{stem}Status", [_Field(f"{stem}Mode", "mode", 1, "current mode")])
        status.fields += _scalars(rng, [], 2, 4, start=2)
        if earlier:
            other = rng.choice(earlier)
            status.fields.append(
                _Field(f"Unit{other:04d}Sample", "upstream", len(status.fields) + 1, "last input")
            )
        report = _Message(f"{stem}Report", [_Field(sample.name, "sample", 1, "latest sample")])
        report.fields.append(_Field(status.name, "status", 2, "board status"))
        for other in earlier:
            report.fields.append(
                _Field(f"Unit{other:04d}Mode", f"mode_{other:04d}", len(report.fields) + 1, "peer")
            )
        report.fields += _scalars(rng, [], 1, 3, start=len(report.fields) + 1)
        folder = _FOLDERS[index % len(_FOLDERS)]
        path = f"components/{folder}/unit_{index:04d}.proto"
        plan.append(_File(index, path, earlier, f"{stem}Mode", [sample, status, report]))
    return plan


def _scalars(
    rng: random.Random, first: list[tuple[str, str]], low: int, high: int, start: int = 1
) -> list[_Field]:
    """``first`` then between ``low`` and ``high`` more scalar fields, numbered from ``start``."""
    chosen = first + [
        (rng.choice(_SCALARS), name) for name in rng.sample(_QUANTITIES, rng.randint(low, high))
    ]
    return [
        _Field(kind, name, start + k, f"{name.replace('_', ' ')}, board units")
        for k, (kind, name) in enumerate(chosen)
    ]


def _break(plan: list[_File]) -> Breaking:
    """Apply NEW's changes to ``plan``: float → double, a field deleted, a field added."""
    target = plan[len(plan) // 2].messages[0]  # a Sample: its field 1 is always float "value"
    target.fields[0].type = "double"
    victim = plan[len(plan) // 3].messages[1]  # a Status: drop its last field, reserve nothing
    gone = victim.fields.pop()
    grown = plan[(2 * len(plan)) // 3].messages[2]  # a Report: one more field (not breaking)
    grown.fields.append(_Field("uint32", "sequence", len(grown.fields) + 1, "added in NEW"))
    return Breaking((f"{target.name}.{target.fields[0].name}", f"{victim.name}.{gone.name}"))


def _legacy_break(plan: list[_File]) -> tuple[Breaking, _Legacy]:
    """NEW's changes to a proto2 and editions plan: a deleted field, and what ``_Legacy`` says."""
    victim = plan[len(plan) // 3].messages[1]  # a Status: drop its last field, reserve nothing
    gone = victim.fields.pop()
    grown = plan[(2 * len(plan)) // 3].messages[2]  # a Report: one more field (not breaking)
    grown.fields.append(_Field("uint32", "sequence", len(grown.fields) + 1, "added in NEW"))
    changes = _Legacy(len(plan) // 2, (2 * len(plan)) // 3 + 1, 2 * (len(plan) // 8))
    extended = plan[changes.extension - 1].messages[2].name
    return Breaking(
        (
            f"{plan[changes.default].messages[0].name}.value",
            f"{victim.name}.{gone.name}",
            f"{extended}.unit_{changes.extension:04d}_extra",
            f"{plan[changes.group].messages[2].name}.reading",
        )
    ), changes


def _render(unit: _File, plan: list[_File]) -> str:
    lines = [
        f"// Generated unit {unit.index} of the erc-lint benchmark tree.",
        f"// Holds {unit.enum} and {', '.join(m.name for m in unit.messages)}.",
        "",
        'syntax = "proto3";',
        "",
    ]
    lines += [f'import "{plan[other].path}";' for other in unit.imports]
    upper = unit.enum.removesuffix("Mode").upper()
    lines += ["", f"// Operating mode of unit {unit.index}.", f"enum {unit.enum} {{"]
    lines += [f"  {upper}_MODE_{mode} = {k};  // {mode.lower()}" for k, mode in enumerate(_MODES)]
    lines.append("}")
    for message in unit.messages:
        lines += [
            "",
            f"// {message.name}: one record of unit {unit.index}.",
            f"message {message.name} {{",
        ]
        for f in message.fields:
            lines.append(f"  {f.type} {f.name} = {f.number};  // {f.note}")
        lines.append("}")
    return "\n".join(lines) + "\n"


def _render_legacy(unit: _File, plan: list[_File], changes: _Legacy | None) -> str:
    """A unit as proto2 (even indexes) or edition 2023 (odd): the same messages, with a default
    on each sample's value, a required mode, a group or delimited reading, an extension range,
    and an extension of the previous unit's report."""
    proto2 = unit.index % 2 == 0
    optional = "optional " if proto2 else ""
    lines = [
        f"// Generated unit {unit.index} of the erc-lint benchmark's proto2 and editions tree.",
        "",
        'syntax = "proto2";' if proto2 else 'edition = "2023";',
        "",
    ]
    lines += [f'import "{plan[other].path}";' for other in unit.imports]
    upper = unit.enum.removesuffix("Mode").upper()
    lines += ["", f"enum {unit.enum} {{"]
    if not proto2:
        lines.append("  option features.enum_type = CLOSED;")
    lines += [f"  {upper}_MODE_{mode} = {k};  // {mode.lower()}" for k, mode in enumerate(_MODES)]
    lines.append("}")
    sample, status, report = unit.messages
    default = "2.5" if changes and changes.default == unit.index else "1.5"
    for message in (sample, status):
        lines += ["", f"message {message.name} {{"]
        for f in message.fields:
            option = ""
            if message is sample and f.number == 1:
                option = f" [default = {default}]"
            elif message is status and f.number == 1:
                option = "" if proto2 else " [features.field_presence = LEGACY_REQUIRED]"
            label = "required " if proto2 and message is status and f.number == 1 else optional
            lines.append(f"  {label}{f.type} {f.name} = {f.number}{option};  // {f.note}")
        lines.append("}")
    lines += ["", f"message {report.name} {{"]
    reading = ["float level = 1;", "uint32 count = 2;"]
    if proto2 and not (changes and changes.group == unit.index):
        lines.append("  optional group Reading = 1 {")
        lines += [f"    optional {line}" for line in reading]
        lines.append("  }")
    else:
        lines.append("  message Reading {")
        lines += [f"    {optional}{line}" for line in reading]
        lines.append("  }")
        delimited = "" if proto2 else " [features.message_encoding = DELIMITED]"
        lines.append(f"  {optional}Reading reading = 1{delimited};")
    for f in report.fields[1:]:
        lines.append(f"  {optional}{f.type} {f.name} = {f.number};  // {f.note}")
    lines += ["  extensions 100 to 199;", "}"]
    if unit.index:
        previous = plan[unit.index - 1].messages[2].name
        kind = "sint32" if changes and changes.extension == unit.index else "uint32"
        lines += [
            "",
            f"extend {previous} {{",
            f"  {optional}{kind} unit_{unit.index:04d}_extra = 100;",
            "}",
        ]
    return "\n".join(lines) + "\n"


def _envelope(plan: list[_File]) -> str:
    members = plan[::4]
    lines = [
        "// PBEnvelope: the wrapper around every message of the benchmark tree.",
        "",
        'syntax = "proto3";',
        "",
    ]
    lines += [f'import "{unit.path}";' for unit in members]
    lines += ["", "message PBEnvelope {", "  oneof payload {"]
    for number, unit in enumerate(members, start=1):
        report = unit.messages[2].name
        lines.append(f"    {report} unit_{unit.index:04d}_report = {number};  // direction: up")
    lines += ["  }", "}"]
    return "\n".join(lines) + "\n"


def write_tree(
    root: Path, files: int, *, breaking: bool, legacy: bool = False, seed: int = 20261122
) -> Breaking | None:
    """Write a tree of ``files`` .proto files under ``root`` (proto3, or with ``legacy`` proto2
    and editions); with ``breaking``, NEW's version."""
    plan = _plan(files, seed)
    changes: Breaking | None = None
    legacy_changes: _Legacy | None = None
    if breaking and legacy:
        changes, legacy_changes = _legacy_break(plan)
    elif breaking:
        changes = _break(plan)
    for unit in plan:
        target = root / unit.path
        target.parent.mkdir(parents=True, exist_ok=True)
        text = _render_legacy(unit, plan, legacy_changes) if legacy else _render(unit, plan)
        target.write_text(text, encoding="utf-8")
    envelope = root / "components/common/envelope.proto"
    envelope.parent.mkdir(parents=True, exist_ok=True)
    text = _envelope(plan)
    if legacy:  # the nanopb and RPC rules have something to compare (the same on both sides)
        first = plan[0]
        options = (root / first.path).with_suffix(".options")
        options.write_text(f"{first.messages[0].name}.* int_size:IS_32\n", encoding="utf-8")
        text += "\nservice Telemetry {\n  rpc Send(PBEnvelope) returns (PBEnvelope);\n}\n"
    envelope.write_text(text, encoding="utf-8")
    return changes


def write_pair(folder: Path, files: int, legacy: bool = False) -> tuple[Path, Path, Breaking]:
    """OLD and NEW trees of ``files`` files in ``folder`` (proto3, or with ``legacy`` proto2 and
    editions); NEW carries the breaking changes."""
    kind = "legacy" if legacy else "proto3"
    old, new = folder / f"old_{kind}_{files}", folder / f"new_{kind}_{files}"
    write_tree(old, files, breaking=False, legacy=legacy)
    changes = write_tree(new, files, breaking=True, legacy=legacy)
    assert changes is not None
    assert len(list(old.rglob("*.proto"))) == files == len(list(new.rglob("*.proto")))
    return old, new, changes


# --- the contenders ----------------------------------------------------------------------------


def _executable(name: str) -> str:
    """``name`` from this interpreter's scripts folder (no pyenv shim in between), else PATH."""
    beside = Path(sysconfig.get_path("scripts")) / name
    if beside.is_file() and os.access(beside, os.X_OK):
        return str(beside)
    found = shutil.which(name)
    if found is None:
        sys.exit(f"bench_lint: `{name}` not found (pip install -e . / pip install buf-bin)")
    return found


def _pinned() -> list[str]:
    """erc-codec's own dependencies (and grpcio-tools' grpcio), each at the version installed
    here, so that the isolated install runs the very same libraries; one under an environment
    marker (tomli, before Python 3.11) as erc-codec asks for it, for pip to judge."""
    pins = []
    for requirement in importlib.metadata.requires("erc-codec") or []:
        if "extra ==" in requirement:
            continue
        if ";" in requirement:
            pins.append(requirement)
            continue
        name = re.split(r"[^A-Za-z0-9._-]", requirement, maxsplit=1)[0]
        pins.append(f"{name}=={importlib.metadata.version(name)}")
    return [*pins, f"grpcio=={importlib.metadata.version('grpcio')}"]


def isolated_install(folder: Path) -> tuple[str, str]:
    """erc-lint and its interpreter from a new virtual environment in ``folder``, installed from
    a wheel of this checkout as ``pipx install`` leaves it: byte-compiled, the dependencies at
    this interpreter's versions, and nothing of this interpreter's own site-packages on its path
    (whatever the ``.pth`` files there run at every start is no part of erc-lint's time).
    Raises ``subprocess.CalledProcessError`` where pip cannot install it."""
    root = Path(__file__).resolve().parent.parent
    wheels, venv = folder / "wheel", folder / "venv"
    quiet = ("--quiet", "--disable-pip-version-check")
    build = [sys.executable, "-m", "pip", "wheel", *quiet, "--no-deps", "--no-build-isolation"]
    subprocess.run([*build, "-w", str(wheels), str(root)], check=True, capture_output=True)
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True, capture_output=True)
    scripts = venv / ("Scripts" if os.name == "nt" else "bin")
    (wheel,) = wheels.glob("erc_codec-*.whl")
    install = [str(scripts / "python"), "-m", "pip", "install", *quiet, str(wheel), *_pinned()]
    subprocess.run(install, check=True, capture_output=True)
    return str(scripts / "erc-lint"), str(scripts / "python")


@dataclass(frozen=True)
class Tools:
    erc_lint: str
    python: str  # erc-lint's interpreter, for the start-up floor
    buf: str

    def erc_lint_command(self, old: Path, new: Path, *extra: str) -> list[str]:
        return [self.erc_lint, str(old), str(new), *extra]

    def floor_command(self) -> list[str]:
        # The part of every erc-lint run that is no code of its own: the interpreter start-up,
        # the imports of its dependencies, and the interpreter's shutdown.
        imported = "import click, google.protobuf.descriptor_pb2, grpc_tools._protoc_compiler"
        return [self.python, "-c", imported]

    def buf_command(self, old: Path, *extra: str) -> list[str]:
        # Run in NEW, so the v2 configuration's module ("." by default) is the tree itself.
        return [
            self.buf,
            "breaking",
            ".",
            "--against",
            str(old),
            "--config",
            _BUF_CONFIG,
            "--against-config",
            _BUF_CONFIG,
            *extra,
        ]


def _run(command: Sequence[str], cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        command, cwd=cwd, capture_output=True, text=True, timeout=_TIMEOUT, check=False
    )


def _timed(command: Sequence[str], cwd: Path, expected: int) -> float:
    start = time.perf_counter()
    done = subprocess.run(
        command,
        cwd=cwd,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        timeout=_TIMEOUT,
        check=False,
    )
    elapsed = time.perf_counter() - start
    if done.returncode != expected:
        _fail(f"{' '.join(command)} exited {done.returncode}, not {expected}", done.stderr.decode())
    return elapsed


def _fail(what: str, detail: str = "") -> NoReturn:
    print(f"SANITY CHECK FAILED: {what}", file=sys.stderr)
    if detail:
        print(detail.rstrip(), file=sys.stderr)
    sys.exit(2)


def sanity_check(tools: Tools, old: Path, new: Path, changes: Breaking) -> str:
    """Fail loudly unless both tools build the trees and find the known breaking changes."""
    for name, done in (
        ("erc-lint OLD OLD", _run(tools.erc_lint_command(old, old, "--format", "json"), old)),
        ("buf OLD OLD", _run(tools.buf_command(old, "--error-format", "json"), old)),
    ):
        if done.returncode != 0 or _errors(name, done):
            _fail(f"{name} exited {done.returncode} or reported errors", done.stdout + done.stderr)
    reports = {
        "erc-lint": (_run(tools.erc_lint_command(old, new, "--format", "json"), new), 1),
        "buf": (_run(tools.buf_command(old, "--error-format", "json"), new), _BUF_FINDINGS),
    }
    summary = []
    for tool, (done, expected) in reports.items():
        found = _errors(tool, done)
        if done.returncode != expected or not found:
            _fail(
                f"{tool} OLD NEW exited {done.returncode} with {len(found)} findings",
                done.stdout + done.stderr,
            )
        for change in changes.members:
            message, member = change.split(".")
            if not any(f'"{message}"' in text and f'"{member}"' in text for _, text in found):
                _fail(f"{tool} OLD NEW did not report {change}", done.stdout)
        rules = ", ".join(sorted({rule for rule, _ in found}))
        summary.append(f"{tool}: {len(found)} error(s) {rules}")
    return "; ".join(summary)


def _errors(tool: str, done: subprocess.CompletedProcess[str]) -> list[tuple[str, str]]:
    """(rule, message) of every error in a JSON report (erc-lint's warnings left out)."""
    found = []
    for line in done.stdout.splitlines():
        if not line.strip():
            continue
        try:
            finding = json.loads(line)
            if finding.get("severity", "error") == "error":
                found.append((str(finding.get("rule") or finding["type"]), str(finding["message"])))
        except (ValueError, KeyError, AttributeError):
            _fail(f"{tool}: output is not a JSON report", done.stdout + done.stderr)
    return found


# --- measurement -------------------------------------------------------------------------------


@dataclass
class Times:
    samples: list[float] = field(default_factory=list)

    @property
    def median(self) -> float:
        return statistics.median(self.samples)

    @property
    def best(self) -> float:
        return min(self.samples)


def interleaved(tools: Tools, old: Path, new: Path, rounds: int) -> tuple[Times, Times, Times]:
    """erc-lint, buf and the start-up floor, in turn, ``rounds`` times each."""
    ours, theirs, floor = Times(), Times(), Times()
    for _ in range(rounds):
        ours.samples.append(_timed(tools.erc_lint_command(old, new), new.parent, 1))
        theirs.samples.append(_timed(tools.buf_command(old), new, _BUF_FINDINGS))
        floor.samples.append(_timed(tools.floor_command(), new, 0))
    return ours, theirs, floor


def _compile_bytecode() -> None:
    """Byte-compile erc-lint's packages, as installing a wheel does: from a source checkout (an
    editable install) with PYTHONDONTWRITEBYTECODE set, every run would compile them anew."""
    for package in (erc_codec, erc_lint):
        for folder in package.__path__:
            compileall.compile_dir(folder, quiet=1)


def _contender(folder: Path, here: bool) -> tuple[str, str]:
    """The erc-lint to time and its interpreter: an isolated install in ``folder``, else (with
    ``here``, or where pip cannot make one) this interpreter's, byte-compiled."""
    if not here:
        try:
            return isolated_install(folder)
        except (OSError, ValueError, ImportError, subprocess.CalledProcessError) as error:
            detail = getattr(error, "stderr", b"") or b""
            last = detail.decode(errors="replace").strip().splitlines()[-1:] or [str(error)]
            print(f"no isolated install ({last[0]}): timing this interpreter's erc-lint")
    _compile_bytecode()
    return _executable("erc-lint"), sys.executable


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer rounds (a smoke run)")
    parser.add_argument("--rounds", type=int, help="rounds per measurement (default 11, quick 3)")
    parser.add_argument("--keep", action="store_true", help="keep the generated trees; print where")
    parser.add_argument(
        "--here",
        action="store_true",
        help="time the erc-lint this interpreter has installed, not an isolated install",
    )
    args = parser.parse_args()
    rounds = args.rounds or (3 if args.quick else 11)
    scaling_rounds = args.rounds or (1 if args.quick else 5)

    folder = Path(tempfile.mkdtemp(prefix="bench-lint-"))
    try:
        tools = Tools(*_contender(folder, args.here), _executable("buf"))
        buf_version = _run([tools.buf, "--version"], Path.cwd()).stdout.strip()
        print(f"erc-lint: {tools.erc_lint}; buf {buf_version}: {tools.buf}; {os.cpu_count()} CPUs")
        print(
            f"times: median of {rounds} interleaved rounds (best beside it); scaling: median of "
            f"{scaling_rounds}"
        )
        pairs = {"proto3": False, "proto2+editions": True}
        measured: dict[str, tuple[Times, Times, Times]] = {}
        for name, legacy in pairs.items():
            old, new, changes = write_pair(folder, _RATIO_FILES, legacy=legacy)
            summary = sanity_check(tools, old, new, changes)
            print(f"sanity ({name}, {_RATIO_FILES} files): {summary}")
            measured[name] = interleaved(tools, old, new, rounds)
        print()
        print(
            f"{'pair':<16}{'files':>6}{'erc-lint s':>12}{'(best)':>8}{'buf s':>8}{'(best)':>8}"
            f"{'ratio':>8}{'target':>8}  ok"
        )
        factors = {}
        for name, (ours, theirs, _) in measured.items():
            factors[name] = factor = ours.median / theirs.median
            print(
                f"{name:<16}{_RATIO_FILES:>6}{ours.median:>12.3f}{ours.best:>8.3f}"
                f"{theirs.median:>8.3f}{theirs.best:>8.3f}{factor:>7.2f}x{_TARGET_RATIO:>7.2f}x  "
                f"{'yes' if factor <= _TARGET_RATIO else 'NO'}"
            )
        ratio_ok = all(factor <= _TARGET_RATIO for factor in factors.values())
        _, theirs, floor = measured["proto3"]
        print(
            f"start-up floor (Python with click, protobuf and grpcio-tools imported, nothing of "
            f"erc-lint's): {floor.median:.3f} s, {floor.median / theirs.median:.2f}x buf (proto3)"
        )

        print()
        base = f"vs {_SCALING_FILES[0]}"
        print(f"{'files':>6}{'erc-lint s':>12}{'(best)':>8}{'ms/file':>9}{base:>8}")
        per_file: dict[int, float] = {}
        largest = 0.0
        for files in _SCALING_FILES:
            old, new, _ = write_pair(folder, files)
            _timed(tools.erc_lint_command(old, new), folder, 1)  # warm the file cache
            times = Times(
                [_timed(tools.erc_lint_command(old, new), folder, 1) for _ in range(scaling_rounds)]
            )
            per_file[files] = times.median / files
            largest = times.median
            growth = per_file[files] / per_file[_SCALING_FILES[0]]
            print(
                f"{files:>6}{times.median:>12.3f}{times.best:>8.3f}"
                f"{per_file[files] * 1e3:>9.2f}{growth:>7.2f}x"
            )
        growth = per_file[_SCALING_FILES[-1]] / per_file[_SCALING_FILES[0]]
        time_ok = largest < _TARGET_SECONDS
        growth_ok = growth <= _TARGET_GROWTH
        print()
        for name, factor in factors.items():
            print(
                f"ratio at {_RATIO_FILES} files, {name}: {factor:.2f}x (≤ {_TARGET_RATIO:.2f}x): "
                f"{'yes' if factor <= _TARGET_RATIO else 'NO'}"
            )
        print(
            f"erc-lint at {_SCALING_FILES[-1]} files: {largest:.2f} s (< {_TARGET_SECONDS:.0f} s):"
            f" {'yes' if time_ok else 'NO'}"
        )
        print(
            f"time per file {_SCALING_FILES[-1]} vs {_SCALING_FILES[0]}: {growth:.2f}x "
            f"(≤ {_TARGET_GROWTH:.1f}x): {'yes' if growth_ok else 'NO'}"
        )
    finally:
        if args.keep:
            print(f"trees kept in {folder}")
        else:
            shutil.rmtree(folder, ignore_errors=True)
    return 0 if ratio_ok and time_ok and growth_ok else 1


if __name__ == "__main__":
    sys.exit(main())
