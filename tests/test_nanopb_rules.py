"""Generator rules that depend on names and on versions, against every generator the machine has.

- ``.options`` patterns match the name nanopb gives an element under its file's ``mangle_names``
  (M_STRIP_PACKAGE, M_FLATTEN, M_PACKAGE_INITIALS) or ``(nanopb_fileopt).package``, not its full
  name: tests/nanopb_trees/mangling, one file per rule, checked against PyPI ``nanopb`` 0.4.9.1 (the
  test extra) and against a hand-computed table.

Without a generator (no network for pip, no Debian package) a test skips, unless
ERC_REQUIRE_INTEROP=1 (CI), where it fails.
"""

import os
import re
import subprocess
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import pytest

from erc_codec.schema import Sizes, load_schema

NANOPB_TREES = Path(__file__).resolve().parent / "nanopb_trees"
MANGLING = NANOPB_TREES / "mangling"
POINTERS = NANOPB_TREES / "pointers"

_DEFINE = re.compile(r"^#define\s+(\w+)_size\s+(\d+)\s*$", re.MULTILINE)
_RUNTIME = re.compile(r"/\*\s*(\w+)_size depends on runtime parameters\s*\*/")

Sized = dict[str, int | None]


def _fail_or_skip(reason: str) -> None:
    if os.environ.get("ERC_REQUIRE_INTEROP") == "1":
        pytest.fail(f"ERC_REQUIRE_INTEROP=1 but {reason}")
    pytest.skip(reason)


@dataclass(frozen=True)
class Generator:
    """One nanopb generator: the command that runs it."""

    version: str
    command: tuple[str, ...]

    def run(self, tree: Path, files: Sequence[str], outdir: Path) -> tuple[Sized | None, str]:
        """Run over ``files`` of ``tree`` (from its root, ``-I .``): the ``<C name>_size`` of
        every message, ``None`` where it writes "depends on runtime parameters"; or ``None`` and
        its complaint when it refuses the tree."""
        done = subprocess.run(
            [*self.command, "-q", "--error-on-unmatched", "-I", ".", "-D", str(outdir), *files],
            cwd=tree,
            capture_output=True,
            text=True,
            check=False,
        )
        if done.returncode != 0:
            return None, done.stderr
        sizes: Sized = {}
        for name in files:
            header = (outdir / name).with_suffix(".pb.h").read_text(encoding="utf-8")
            sizes.update({c: int(size) for c, size in _DEFINE.findall(header)})
            sizes.update(dict.fromkeys(_RUNTIME.findall(header)))
        return sizes, ""


def _files(tree: Path) -> list[str]:
    return sorted(path.relative_to(tree).as_posix() for path in tree.rglob("*.proto"))


# -- mangle_names and (nanopb_fileopt).package ---------------------------------------------------

# file -> (its package, the C name nanopb gives Outer, Outer.Inner and Plain)
MANGLED = {
    "none": ("alpha.none", ("alpha_none_Outer", "alpha_none_Outer_Inner", "alpha_none_Plain")),
    "strip": ("alpha.strip", ("Outer", "Outer_Inner", "Plain")),
    "flatten": ("alpha.flatten", ("Outer", "Inner", "Plain")),
    "initials": ("alpha.initials.deep", ("aid_Outer", "aid_Outer_Inner", "aid_Plain")),
    "renamed": ("alpha.renamed", ("rn_x_Outer", "rn_x_Outer_Inner", "rn_x_Plain")),
    "both": ("alpha.both", ("Outer", "Outer_Inner", "Plain")),
}
# Outer, Outer.Inner, Plain: sizes the options lines give when their patterns match.
MANGLED_SIZES = (40, 6, None)


@pytest.fixture(scope="module")
def mangled(tmp_path_factory: pytest.TempPathFactory) -> Sized:
    pytest.importorskip("nanopb")
    generator = Generator("0.4.9.1", (sys.executable, "-m", "nanopb.generator.nanopb_generator"))
    sizes, complaint = generator.run(MANGLING, _files(MANGLING), tmp_path_factory.mktemp("mangled"))
    assert sizes is not None, complaint  # --error-on-unmatched: every pattern matched in nanopb
    return sizes


@pytest.mark.parametrize("file", sorted(MANGLED))
def test_options_patterns_match_the_mangled_name_as_in_nanopb(mangled: Sized, file: str) -> None:
    package, c_names = MANGLED[file]
    full_names = (f"{package}.Outer", f"{package}.Outer.Inner", f"{package}.Plain")
    theirs = {c_name: mangled[c_name] for c_name in c_names}
    ours = Sizes(load_schema(MANGLING, root=f"{file}.proto:{package}.Outer")).all()
    assert theirs == dict(zip(c_names, MANGLED_SIZES, strict=True))
    assert ours == dict(zip(full_names, MANGLED_SIZES, strict=True))


def test_a_pattern_on_the_full_name_misses_a_stripped_message(tmp_path: Path) -> None:
    """Under M_STRIP_PACKAGE a pattern naming the package matches nothing, in nanopb and here."""
    (tmp_path / "s.proto").write_text(
        'syntax = "proto3";\npackage p.q;\nimport "nanopb.proto";\n'
        "option (nanopb_fileopt).mangle_names = M_STRIP_PACKAGE;\n"
        "message M { string s = 1; }\n"
    )
    (tmp_path / "s.options").write_text("p.q.M.s max_size:5\n")
    assert Sizes(load_schema(tmp_path, root="p.q.M")).all() == {"p.q.M": None}
    (tmp_path / "s.options").write_text("M.s max_size:5\n")
    assert Sizes(load_schema(tmp_path, root="p.q.M")).all() == {"p.q.M": 6}
