"""Generator rules that depend on names and on versions, against every generator the machine has.

- ``.options`` patterns match the name nanopb gives an element under its file's ``mangle_names``
  (M_STRIP_PACKAGE, M_FLATTEN, M_PACKAGE_INITIALS) or ``(nanopb_fileopt).package``, not its full
  name: tests/nanopb_trees/mangling, one file per rule, checked against PyPI ``nanopb`` 0.4.9.1 (the
  test extra) and against a hand-computed table; and a field's type is looked up by the name the
  referring file's mangling makes of it, which the declaring file may never have registered
  (tests/nanopb_trees/crossfile: then no size, or a guessed 10 bytes for an enum).
- ``nanopb_version``: "0.4.9" against each 0.4.x generator installed here, PyPI ``nanopb``
  0.4.9.1, 0.4.9, 0.4.8 and 0.4.7 (the older three pinned in throwaway venvs made once per session,
  sharing this environment's protobuf and grpcio-tools, so only the generator differs) and Debian's
  0.4.7 (``nanopb_generator.py``, with Debian's protoc), on the rule trees of
  tests/schema/test_sizes.py and tests/nanopb_trees (pointers, allocation, mangling, crossfile);
  0.4.7 looks some types up otherwise (``CROSSFILE_0_4_7``). "1.0.0-dev" (nanopb's master after
  0.4.9.1, which sizes FT_POINTER and FT_CALLBACK fields whose bound is known) against PyPI's
  ``nanopb`` 1.0.0.dev1621 (``MASTER``, pinned in a venv the same way). Each rule set is held to its
  generator (0.4.9.1, master) over the whole corpus, every tree of tests/size_trees,
  tests/nanopb_trees and tests/any_trees and the packaged proto tree, message for message; the
  hand-computed tables (pointers.proto's and allocation/'s sums stand beside each field) are held to
  both.

Without a generator (no network for pip, no Debian package) a test skips, unless
ERC_REQUIRE_INTEROP=1 (CI), where it fails.
"""

import math
import os
import re
import shutil
import site
import subprocess
import sys
import sysconfig
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import pytest
from conftest import PROTO, TESTS
from test_sizes import TREES

import erc_codec
from erc_schema import (
    NANOPB_VERSIONS,
    Sizes,
    compile_files,
    declarations,
    load_schema,
    nanopb_name,
    resolve_options,
)

NANOPB_TREES = TESTS / "nanopb_trees"
MANGLING = NANOPB_TREES / "mangling"
POINTERS = NANOPB_TREES / "pointers"

# A header's sizes: "#define X_size 97", or an expression of other sizes, "(6 + Sub_size)",
# "(0 + sizeof(union X_u_size_union))" (a helper union of char arrays, "union ... {char f1[..];
# ...};"), under "#if defined(Sub_size) && ..." where a size it needs is another file's; and
# "/* X_size depends on runtime parameters */".
_DEFINE = re.compile(r"^#define\s+(\w+_size)\s+(.+?)\s*$")
_RUNTIME = re.compile(r"/\*\s*(\w+)_size depends on runtime parameters\s*\*/")
_UNION = re.compile(r"^union (\w+) \{(.*)\};$")
_MEMBER = re.compile(r"char f\d+\[(.*?)\];")
_NEEDED = re.compile(r"defined\((\w+)\)")
_TERM = re.compile(r"sizeof\(union (\w+)\)|\b\w+_size\b")

Sized = dict[str, int | None]


@dataclass
class _Header:
    """The size defines of a generator's headers, as a C compiler including them all sees them."""

    defines: dict[str, tuple[str, list[str]]]  # X_size -> its expression, the defines it needs
    unions: dict[str, list[str]]  # a helper union -> its members' sizes

    @classmethod
    def read(cls, headers: Sequence[str]) -> "tuple[_Header, list[str]]":
        """The defines of ``headers``, and the C names whose size depends on runtime parameters."""
        header, runtime = cls({}, {}), []
        for text in headers:
            needed: list[str] = []
            for line in text.splitlines():
                if line.startswith("#if ") and "defined(" in line:
                    needed = _NEEDED.findall(line)
                elif line.startswith("#endif"):
                    needed = []
                elif union := _UNION.match(line):
                    header.unions[union[1]] = _MEMBER.findall(union[2])
                elif define := _DEFINE.match(line):
                    header.defines[define[1]] = (define[2], needed)
                runtime += _RUNTIME.findall(line)
        return header, runtime

    def value(self, name: str, seen: tuple[str, ...] = ()) -> int | None:
        """What ``name`` (``X_size``) comes to: ``None`` where it is defined nowhere, its guard
        does not hold, or it names itself (master's "(22 + Recursive_size)", which no compiler
        can evaluate)."""
        if name in seen or name not in self.defines:
            return None
        expression, needed = self.defines[name]
        if any(other not in self.defines for other in needed):
            return None
        return self._evaluate(expression, (*seen, name))

    def _evaluate(self, expression: str, seen: tuple[str, ...]) -> int | None:
        """A sum of products of numbers, sizes and helper unions' sizes (their largest member)."""
        values: list[str] = []
        for term in _TERM.finditer(expression):
            if term[1] is not None:
                members = [self._evaluate(member, seen) for member in self.unions[term[1]]]
                known = [size for size in members if size is not None]
                size = max(known) if len(known) == len(members) else None
            else:
                size = self.value(term[0], seen)
            if size is None:
                return None
            values.append(str(size))
        plain = iter(values)
        arithmetic = _TERM.sub(lambda _: next(plain), expression).strip("() ")
        assert re.fullmatch(r"[\d+* ]+", arithmetic), expression
        return sum(
            math.prod(int(factor) for factor in term.split("*")) for term in arithmetic.split("+")
        )


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
        every message, ``None`` where it writes "depends on runtime parameters" or a size guarded
        by ``#if defined(X_size)`` with X_size defined by none of the headers; or ``None`` and
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
        header, runtime = _Header.read(
            [(outdir / name).with_suffix(".pb.h").read_text(encoding="utf-8") for name in files]
        )
        sizes: Sized = {name[: -len("_size")]: header.value(name) for name in header.defines}
        sizes.update(dict.fromkeys(runtime))
        return sizes, ""


def _pypi_generator(version: str, folder: Path) -> Generator:
    """PyPI ``nanopb==version`` in a venv of its own, which sees this environment's protobuf and
    grpcio-tools (a .pth file) but has its own nanopb and a setuptools with ``pkg_resources``,
    which generators before 0.4.9 import."""
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(folder)], check=True)
    python = folder / "bin" / "python"
    installed = subprocess.run(
        [
            *(sys.executable, "-m", "pip", "--python", str(python), "install", "-q"),
            *("--no-deps", f"nanopb=={version}", "setuptools<81"),
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    if installed.returncode != 0:
        _fail_or_skip(f"pip could not install nanopb=={version}: {installed.stderr[-300:]}")
    purelib = subprocess.run(
        [str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    # This environment's site folders, and the system's beneath a venv made with
    # --system-site-packages; the venv's own nanopb comes first all the same (a .pth file's
    # folders are appended after the venv's own).
    shared = {sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"]}
    shared.update(site.getsitepackages())
    (Path(purelib) / "erc_test_shared.pth").write_text("".join(f"{p}\n" for p in sorted(shared)))
    return Generator(version, (str(python), "-m", "nanopb.generator.nanopb_generator"))


def _debian_generator() -> Generator:
    program = shutil.which("nanopb_generator.py")
    if program is None:
        _fail_or_skip("Debian's nanopb generator (apt-get install nanopb) is not installed")
    assert program is not None
    said = subprocess.run([program, "--version"], capture_output=True, text=True, check=False)
    assert said.stdout.strip() == "nanopb-0.4.7", said.stdout
    return Generator("0.4.7 (Debian)", (program,))


PYPI_OLDER = ("0.4.9", "0.4.8", "0.4.7")
GENERATORS = ("0.4.9.1", *PYPI_OLDER, "0.4.7 (Debian)")
# nanopb's master after 0.4.9.1 as PyPI publishes it (its headers say "nanopb-1.0.0-dev"; dev1621:
# the 1621st commit): the generator of the "1.0.0-dev" rules. Whether the ERC firmware's pin,
# d68cd4e, is older or newer is not known here (the package names no commit).
MASTER = "1.0.0.dev1621"


@pytest.fixture(scope="session")
def generators() -> dict[str, Generator]:
    """The generators made so far in this session, by version (a venv takes seconds to make)."""
    return {}


def _generator(
    cache: dict[str, Generator], version: str, factory: pytest.TempPathFactory
) -> Generator:
    if version not in cache:
        if version == "0.4.9.1":
            pytest.importorskip("nanopb")
            cache[version] = Generator(
                version, (sys.executable, "-m", "nanopb.generator.nanopb_generator")
            )
        elif version in (*PYPI_OLDER, MASTER):
            cache[version] = _pypi_generator(version, factory.mktemp(f"nanopb-{version}"))
        else:
            cache[version] = _debian_generator()
    return cache[version]


def _files(tree: Path) -> list[str]:
    return sorted(path.relative_to(tree).as_posix() for path in tree.rglob("*.proto"))


def _c_names(sizes: Sized) -> Sized:
    """erc_codec's sizes keyed as nanopb's C names of a tree without packages."""
    return {name.replace(".", "_"): size for name, size in sizes.items()}


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


CROSSFILE = NANOPB_TREES / "crossfile"

# (root, {full name: (C name, size)}): every message the root's file and imports define. A size
# nanopb writes under a "#if defined(X_size)" that never holds is no size (X_size is defined in
# no header).
CROSSFILE_CASES: dict[str, dict[str, tuple[str, int | None]]] = {
    "p.UsesSub": {
        "p.Sub": ("p_Sub", 11),
        "p.UsesSub": ("UsesSub", None),
        "p.UsesColor": ("UsesColor", 33),
    },
    "q.FlatUses": {"p.Sub": ("p_Sub", 11), "q.FlatUses": ("FlatUses", None)},
    "p.UsesPart": {"p.Part": ("Part", 11), "p.UsesPart": ("UsesPart", 13)},
    "r.RefPart": {
        "p.Part": ("Part", 11),
        "s.Outer": ("Outer", 13),
        "s.Outer.Leaf": ("Leaf", 11),
        "r.RefPart": ("r_RefPart", 13),
        "r.RefLeaf": ("r_RefLeaf", None),
    },
    "UsesLoose": {
        "Loose": ("Loose", 11),
        "p.Sub": ("p_Sub", 11),
        "UsesLoose": ("np_UsesLoose", 13),
        "UsesBase": ("np_UsesBase", 13),
        "UsesTones": ("np_UsesTones", 4),
        "Own": ("np_Own", 11),
        "UsesOwn": ("np_UsesOwn", 13),
    },
    "t.UsesOther": {
        "p.Sub": ("p_Sub", 11),
        "t.UsesOther": ("tt_UsesOther", 13),
        "t.Mine": ("tt_Mine", 11),
        "t.UsesMine": ("tt_UsesMine", 13),
    },
}
# nanopb's master looks a type up otherwise from a file without a package but with a
# (nanopb_fileopt).package (nopackage.proto): it finds no other file's types. The other cases
# are the same there.
MASTER_CROSSFILE = {
    **CROSSFILE_CASES,
    "UsesLoose": {
        **CROSSFILE_CASES["UsesLoose"],
        "UsesLoose": ("np_UsesLoose", None),
        "UsesBase": ("np_UsesBase", None),
        "UsesTones": ("np_UsesTones", 22),
    },
}
CROSSFILE_BY_VERSION = dict(zip(NANOPB_VERSIONS, (CROSSFILE_CASES, MASTER_CROSSFILE), strict=True))
# 0.4.7, before 0.4.8 looked a type outside the file's package up by its full name, finds no
# other file's type from a file with a (nanopb_fileopt).package, with a package or without: no
# rule set here follows it in that (renamedref.proto).
CROSSFILE_0_4_7 = {
    **MASTER_CROSSFILE,
    "t.UsesOther": {**CROSSFILE_CASES["t.UsesOther"], "t.UsesOther": ("tt_UsesOther", None)},
}


@pytest.fixture(scope="module")
def crossfile(tmp_path_factory: pytest.TempPathFactory) -> Sized:
    pytest.importorskip("nanopb")
    outdir = tmp_path_factory.mktemp("crossfile")
    generator = Generator("0.4.9.1", (sys.executable, "-m", "nanopb.generator.nanopb_generator"))
    sizes, complaint = generator.run(CROSSFILE, _files(CROSSFILE), outdir)
    assert sizes is not None, complaint
    return sizes


@pytest.mark.parametrize("root", sorted(CROSSFILE_CASES))
def test_a_type_nanopb_does_not_find_has_no_size(crossfile: Sized, root: str) -> None:
    """Where the referring and the declaring file mangle names differently, nanopb looks the
    type up by a name the declaring file never registered: no size for a message type, the guess
    of 10 bytes for an enum in a oneof or repeated."""
    case = CROSSFILE_CASES[root]
    assert {c_name: crossfile[c_name] for c_name, _ in case.values()} == dict(case.values())
    ours = Sizes(load_schema(CROSSFILE, root=root)).all()
    assert ours == {name: size for name, (_, size) in case.items()}


@pytest.mark.parametrize("version", NANOPB_VERSIONS)
def test_each_rule_set_finds_types_as_its_generator(version: str) -> None:
    """The lookup by each version's rules, against the tables (held to the generators by
    test_every_0_4_generator_... and test_each_rule_set_sizes_the_corpus_...)."""
    for root, case in CROSSFILE_BY_VERSION[version].items():
        ours = Sizes(load_schema(CROSSFILE, root=root), nanopb_version=version).all()
        assert ours == {name: size for name, (_, size) in case.items()}, root


# A singular field of loose.proto's Tone from nopackage.proto's rules: 0.4.x finds the enum,
# master looks for np_Tone and stops ("Could not find enum type np_Tone").
ONE_TONE = (
    'syntax = "proto3";\nimport "nanopb.proto";\nimport "loose.proto";\n'
    'option (nanopb_fileopt).package = "np";\nmessage OneTone { Tone tone = 1; }\n'
)


def _one_tone(tree: Path) -> Path:
    tree.mkdir(exist_ok=True)
    shutil.copy(CROSSFILE / "loose.proto", tree / "loose.proto")
    (tree / "single.proto").write_text(ONE_TONE)
    return tree


def test_a_singular_enum_master_does_not_find_stops_it(tmp_path: Path) -> None:
    schema = load_schema(_one_tone(tmp_path), root="OneTone")
    assert Sizes(schema).all() == {"Loose": 11, "OneTone": 2}
    master = Sizes(schema, nanopb_version="1.0.0-dev")
    assert master.all() == {"Loose": 11, "OneTone": None}
    with pytest.raises(erc_codec.SchemaError, match=r"OneTone\.tone: .*enum type Tone .* stops"):
        master.max_size("OneTone")


def test_a_singular_enum_nanopb_does_not_find_stops_it(tmp_path: Path) -> None:
    """nanopb's generator stops on a singular enum field whose type it does not find ("Could not
    find enum type"): that message has no size here, said in a SchemaError naming the field."""
    pytest.importorskip("nanopb")
    for name in ("base.proto", "stripped.proto"):
        shutil.copy(CROSSFILE / name, tmp_path / name)
    (tmp_path / "single.proto").write_text(
        'syntax = "proto3";\npackage p;\nimport "nanopb.proto";\nimport "base.proto";\n'
        "option (nanopb_fileopt).mangle_names = M_STRIP_PACKAGE;\n"
        "message OneColor { Color color = 1; }\n"
    )
    generator = Generator("0.4.9.1", (sys.executable, "-m", "nanopb.generator.nanopb_generator"))
    sizes, complaint = generator.run(tmp_path, ["single.proto"], tmp_path)
    assert sizes is None
    assert "Could not find enum type Color" in complaint
    ours = Sizes(load_schema(tmp_path, root="p.OneColor"))
    assert ours.all() == {"p.Sub": 11, "p.OneColor": None}
    with pytest.raises(erc_codec.SchemaError, match=r"p\.OneColor\.color: .*enum type p\.Color"):
        ours.max_size("p.OneColor")


# -- nanopb_version ------------------------------------------------------------------------------

# pointers.proto by the rules of 0.4.x (every pointer or callback field: no size) and of master
# after 0.4.9.1 (the sums stand beside each field), each held to its generator over the corpus.
POINTER_SIZES: dict[str, Sized] = {
    "0.4.9": {
        "Leaf": 11,
        "Pointers": None,
        "Callbacks": None,
        "HoldsPointers": None,
        "PointerInOneof": None,
        "UnboundedPointer": None,
        "UnboundedRepeatedPointer": None,
        "Recursive": None,
    },
    "1.0.0-dev": {
        "Leaf": 11,
        "Pointers": 97,
        "Callbacks": 23,
        "HoldsPointers": 99,
        "PointerInOneof": 13,
        "UnboundedPointer": None,
        "UnboundedRepeatedPointer": None,
        "Recursive": None,
    },
}

ALLOCATION = NANOPB_TREES / "allocation"
# allocation/ by master's rules (the sums stand beside each field); by 0.4.x's, no size for every
# message holding a pointer or callback field.
MASTER_ALLOCATION: Sized = {
    "Ext": 11,
    "ExtPointer": 7,
    "ExtUnbounded": None,
    "Legacy": 41,
    "Leaf": 11,
    "RepeatedStrings": 18,
    "RepeatedBytesCallback": 12,
    "FixedCount": 33,
    "OneCount": 20,
    "CallbackEnum": 9,
    "CallbackMap": 48,
    "CallbackMap.MEntry": 22,
    "Narrow": 25,
    "Mid": 39,
    "Outer": 82,
    "External": 31,
    "NoUnions": 17,
    "InUnion": 13,
    "WideTag": 5,
    "Ignored": 11,
    "Unbounded": None,
    "PointsAtUnbounded": None,
    "CallbackOneofUnbounded": None,
    "Fallback": None,
    "ExternalUnbounded": None,
    "PointsAtSkipped": None,
    "Cycle": None,
    "CycleB": None,
    "CycleC": None,
}
STATIC_ONLY = {"Ext", "Leaf", "CallbackMap.MEntry"}  # no pointer or callback field
ALLOCATION_SIZES = {
    "0.4.9": {
        name: size if name in STATIC_ONLY else None for name, size in MASTER_ALLOCATION.items()
    },
    "1.0.0-dev": MASTER_ALLOCATION,
}

# What each generator refuses, and why: options it does not know yet (discard_deprecated and
# label_override came with 0.4.9), editions (Debian's protoc 3.21 predates them).
REFUSED = {
    "0.4.9.1": set(),
    "0.4.9": set(),
    "0.4.8": {"options", "overrides", "skipped"},
    "0.4.7": {"options", "overrides", "skipped"},
    "0.4.7 (Debian)": {"options", "overrides", "skipped", "editions"},
}


def test_nanopb_versions_are_the_two_rule_sets() -> None:
    assert NANOPB_VERSIONS == ("0.4.9", "1.0.0-dev")
    assert tuple(POINTER_SIZES) == NANOPB_VERSIONS


@pytest.mark.parametrize("version", NANOPB_VERSIONS)
def test_pointer_and_callback_fields_by_each_rule_set(version: str) -> None:
    schema = load_schema(POINTERS, root="Pointers")
    assert Sizes(schema, nanopb_version=version).all() == POINTER_SIZES[version]
    schema = load_schema(ALLOCATION, root="Leaf")
    assert Sizes(schema, nanopb_version=version).all() == ALLOCATION_SIZES[version]


def test_the_default_rules_are_0_4_9() -> None:
    schema = load_schema(POINTERS, root="Pointers")
    assert Sizes(schema).all() == Sizes(schema, nanopb_version="0.4.9").all()


def test_a_codec_takes_the_newer_rules() -> None:
    """A root with pointer fields has no size by 0.4.x's rules, 97 bytes by master's."""
    with pytest.raises(erc_codec.SchemaError, match=r"Pointers\.name: nanopb type FT_POINTER"):
        erc_codec.Codec.from_path(POINTERS, root="Pointers")
    codec = erc_codec.Codec.from_path(POINTERS, root="Pointers", nanopb_version="1.0.0-dev")
    assert isinstance(codec, erc_codec.MessageCodec)
    assert codec.max_size("Pointers") == 97
    assert codec.nanopb.nanopb_version == "1.0.0-dev"
    assert erc_codec.Codec.from_path(POINTERS, root="Leaf").nanopb.nanopb_version == "0.4.9"


def test_an_envelope_codec_takes_the_rules_too() -> None:
    envelope = TESTS / "size_trees" / "envelope"
    codec = erc_codec.Codec.from_path(envelope, root="Env", nanopb_version="1.0.0-dev")
    assert not isinstance(codec, erc_codec.MessageCodec)
    assert codec.nanopb.nanopb_version == "1.0.0-dev"
    assert codec.max_size("Env") == erc_codec.Codec.from_path(envelope, root="Env").max_size("Env")


def test_an_unbounded_pointer_still_has_no_size_by_the_newer_rules() -> None:
    with pytest.raises(erc_codec.SchemaError, match=r"string field without nanopb max_size"):
        erc_codec.Codec.from_path(POINTERS, root="UnboundedPointer", nanopb_version="1.0.0-dev")


def test_an_unknown_nanopb_version_is_a_schema_error() -> None:
    with pytest.raises(
        erc_codec.SchemaError, match=r"nanopb_version '0\.5'.*0\.4\.9 and 1\.0\.0-dev"
    ):
        Sizes(load_schema(POINTERS, root="Leaf"), nanopb_version="0.5")


@pytest.mark.slow
@pytest.mark.parametrize("version", GENERATORS)
def test_every_0_4_generator_sizes_as_the_0_4_9_rules(
    generators: dict[str, Generator],
    tmp_path_factory: pytest.TempPathFactory,
    version: str,
) -> None:
    """Each 0.4.x generator gives every message of every rule tree it accepts erc_codec's size
    by the "0.4.9" rules, the pointer and allocation trees included; it refuses exactly the trees
    listed; and it names and finds types under mangle_names as 0.4.9.1 does (the two tables
    above), but for 0.4.7 (CROSSFILE_0_4_7). (The test extra's 0.4.9.1 meets the rule trees in
    tests/schema/test_sizes.py already: here it runs on the pointer and allocation trees alone.)"""
    generator = _generator(generators, version, tmp_path_factory)
    trees = [("pointers", POINTERS, "Pointers"), ("allocation", ALLOCATION, "Leaf")]
    if version != "0.4.9.1":
        trees += [(tree.name, tree.path, tree.root) for tree in TREES]
    refused: dict[str, str] = {}
    differ: dict[str, Mapping[str, tuple[object, object]]] = {}
    for name, path, root in trees:
        theirs, complaint = generator.run(path, _files(path), tmp_path_factory.mktemp(name))
        if theirs is None:
            refused[name] = complaint.strip().splitlines()[-1] if complaint.strip() else "?"
            continue
        ours = _c_names(Sizes(load_schema(path, root=root), nanopb_version="0.4.9").all())
        wrong = {
            c: (ours.get(c, "<missing>"), size)
            for c, size in theirs.items()
            if ours.get(c, "<missing>") != size
        }
        if wrong:
            differ[name] = wrong
    assert differ == {}
    assert set(refused) == REFUSED[version], refused
    # Every 0.4.x mangles names alike, and finds (or misses) a field's type alike.
    mangled, complaint = generator.run(MANGLING, _files(MANGLING), tmp_path_factory.mktemp("m"))
    assert mangled is not None, complaint
    for _, c_names in MANGLED.values():
        assert [mangled[c_name] for c_name in c_names] == list(MANGLED_SIZES)
    found, complaint = generator.run(CROSSFILE, _files(CROSSFILE), tmp_path_factory.mktemp("c"))
    assert found is not None, complaint
    finds = CROSSFILE_0_4_7 if version.startswith("0.4.7") else CROSSFILE_CASES
    for case in finds.values():
        assert {c_name: found[c_name] for c_name, _ in case.values()} == dict(case.values())


# Files the generators refuse (0.4.9.1 and master alike), by tree, with what they say: proto2
# groups (NotImplementedError: 10, TYPE_GROUP), an enum or message type_override of a field of no
# such type (the generator fails on the missing type), and files importing such a file.
_GROUP = "NotImplementedError: 10"
_NO_TYPE = "IndexError: string index out of range"
CORPUS_REFUSES = {
    "groups": {"extension.proto": _GROUP, "group.proto": _GROUP, "imports.proto": _GROUP},
    "typeoverrides": {
        "enum.proto": _NO_TYPE,
        "importer.proto": _NO_TYPE,
        "message.proto": _NO_TYPE,
        "submessage.proto": "Expected enum type as Sub, got Message(Sub)",
        "enum_message.proto": "TypeError: Enum.encoded_size() takes 1 positional argument",
    },
}


def _corpus() -> list[Path]:
    """Every tree whose sizes are held to a 0.4.x generator: tests/size_trees, tests/nanopb_trees,
    tests/any_trees (but include/, which needs test_generator_inputs' -I, -f and -s) and the
    packaged proto tree."""
    folders = (TESTS / "size_trees", NANOPB_TREES, TESTS / "any_trees")
    trees = [tree for folder in folders for tree in sorted(folder.iterdir()) if tree.is_dir()]
    return [tree for tree in trees if tree.name != "include"] + [PROTO]


def _ours_by_c_name(tree: Path, version: str) -> Sized:
    """erc_codec's size, by nanopb's C name, of every message of every file of ``tree`` (each
    file loaded from its first message) by the rules of ``version``."""
    sizes: Sized = {}
    for name in _files(tree):
        compiled = compile_files(tree, [name])
        first = next((d.name for d in declarations(compiled.file[-1]) if d.is_message), None)
        if first is None:
            continue
        schema = load_schema(tree, root=f"{name}:{first}")
        options = resolve_options(schema.tree, schema.files, schema.include).files
        for full_name, size in Sizes(schema, nanopb_version=version).all().items():
            proto = schema.descriptor(full_name).file
            c_name = nanopb_name(proto.package, options[proto.name], full_name)
            sizes[c_name.replace(".", "_")] = size
    return sizes


def _corpus_sizes(generator: Generator, tree: Path, outdir: Path) -> Sized:
    """The generator's sizes for the files of ``tree`` it takes; it refuses the listed ones."""
    refused = CORPUS_REFUSES.get(tree.name, {})
    for name, says in sorted(refused.items()):
        failed, complaint = generator.run(tree, [name], outdir)
        assert failed is None, name
        assert says in complaint, complaint
    files = [name for name in _files(tree) if name not in refused]
    sizes, complaint = generator.run(tree, files, outdir)
    assert sizes, complaint
    return sizes


# Each rule set: the generator it is held to over the whole corpus and what its --version says,
# its crossfile table, and what the singular enum of ONE_TONE comes to (None: the generator stops).
CORPUS_RUNS = {
    "0.4.9": ("0.4.9.1", "nanopb-0.4.9.1", CROSSFILE_CASES, 2),
    "1.0.0-dev": (MASTER, "nanopb-1.0.0-dev", MASTER_CROSSFILE, None),
}


@pytest.mark.slow
@pytest.mark.parametrize("version", NANOPB_VERSIONS)
def test_each_rule_set_sizes_the_corpus_as_its_generator(
    generators: dict[str, Generator], tmp_path_factory: pytest.TempPathFactory, version: str
) -> None:
    """The generator of each rule set, PyPI's nanopb 0.4.9.1 (the test extra) and 1.0.0.dev1621
    (master after 0.4.9.1, in a venv of its own), gives every message of every tree of the
    corpus erc_codec's size by those rules, and erc_codec lists no other message; it refuses
    only the files listed; it gives the hand-computed tables; and master stops on the singular
    enum it does not find."""
    pinned, says, crossfile, one_tone = CORPUS_RUNS[version]
    generator = _generator(generators, pinned, tmp_path_factory)
    said = subprocess.run(
        [*generator.command, "--version"], capture_output=True, text=True, check=False
    )
    # On the protobuf floor it prints protoc's and protobuf's versions around its own.
    assert says in said.stdout.split(), said
    theirs: dict[Path, Sized] = {}
    differ: dict[str, dict[str, tuple[object, object]]] = {}
    for tree in _corpus():
        theirs[tree] = _corpus_sizes(generator, tree, tmp_path_factory.mktemp(tree.name))
        ours = _ours_by_c_name(tree, version)
        wrong: dict[str, tuple[object, object]] = {
            c: (ours.get(c, "<missing>"), theirs[tree].get(c, "<missing>"))
            for c in ours.keys() | theirs[tree].keys()
            if ours.get(c, "<missing>") != theirs[tree].get(c, "<missing>")
        }
        if wrong:
            differ[tree.relative_to(TESTS.parent).as_posix()] = wrong
    assert differ == {}
    assert theirs[POINTERS] == _c_names(POINTER_SIZES[version])
    assert theirs[ALLOCATION] == _c_names(ALLOCATION_SIZES[version])
    for case in crossfile.values():
        assert {c: theirs[CROSSFILE][c] for c, _ in case.values()} == dict(case.values())
    tree = _one_tone(tmp_path_factory.mktemp("one-tone"))
    sizes, complaint = generator.run(tree, ["loose.proto", "single.proto"], tree)
    if one_tone is None:
        assert sizes is None
        assert "Could not find enum type np_Tone" in complaint
    else:
        assert sizes == {"Loose": 11, "np_OneTone": one_tone}


def test_a_maximal_message_with_pointer_fields_encodes_to_its_newer_size() -> None:
    """The newer rule's 97 bytes are tight: protobuf's encoding of the longest Pointers message
    the bounds allow is exactly that long, and the contract refuses one byte more."""
    codec = erc_codec.Codec.from_path(POINTERS, root="Pointers", nanopb_version="1.0.0-dev")
    cls = codec.message_class("Pointers")
    leaf = codec.message_class("Leaf")(v=-1)
    longest = cls(
        name="n" * 8,
        blob=b"\xff" * 4,
        values=[-1, -2],
        leaf=leaf,
        leaves=[leaf, leaf],
        key=b"\xff" * 3,
        label="l" * 7,
        plain=2**32 - 1,
    )
    assert len(longest.SerializeToString()) == 97
    assert codec.encode(longest, "exact") == longest.SerializeToString()
    with pytest.raises(erc_codec.EncodeError, match=r"Pointers\.name"):
        codec.encode(cls(name="n" * 9), "exact")


def test_a_message_containing_itself_through_a_pointer_has_no_size_by_either_rule() -> None:
    for version in NANOPB_VERSIONS:
        with pytest.raises(erc_codec.SchemaError, match=r"Recursive|FT_POINTER"):
            erc_codec.Codec.from_path(POINTERS, root="Recursive", nanopb_version=version)
    with pytest.raises(erc_codec.SchemaError, match=r"Recursive contains itself"):
        erc_codec.Codec.from_path(POINTERS, root="Recursive", nanopb_version="1.0.0-dev")
