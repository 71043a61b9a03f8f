"""A fuzz test over hostile git objects: trees with random entry names, modes and nesting,
symlinks with random targets, blobs of random bytes, written as git stores them and linted the
way a CI lints a pull request's revision (fetching runs no fsck).

The property, for ``erc-lint check`` and ``erc-lint ledger update --history`` alike: the command
exits 0, 1 or 2, never with a traceback or an internal error; a refusal is one line; nothing is
written or removed anywhere but in its scratch folders, which are gone when it ends (the
temporary folder is a fresh one per example, and everything around it is compared before and
after, a sentinel folder that absolute and ``..`` names aim at included). The commands run in
that folder, beside a program ``sub/a.proto`` that a folder named ``--plugin=protoc-gen-e=sub``
once had protoc run: it would write a file there.
"""

import os
import tempfile
from pathlib import Path
from typing import TypeAlias

import pytest
from click.testing import CliRunner
from git_support import HEADER, Repo, loose, loose_commit
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from erc_lint.cli import main

SENTINEL = b"@sentinel@"  # stands for the sentinel folder's absolute path in generated names

Node: TypeAlias = "tuple[str, bytes] | tuple[str, list[tuple[bytes | None, bytes, Node]]]"

ORDINARY = st.sampled_from(
    [b"a.proto", b"b.proto", b"a.options", b"pyproject.toml", b"erc-lint.lock", b"sub", b"sub dir"]
)
HOSTILE = st.sampled_from(
    [
        b"..",
        b".",
        b"",
        b".git",
        b".GIT",
        b".git.",
        b"git~1",
        b"../x.proto",
        b"../../x.proto",
        b"a/b.proto",
        SENTINEL + b"/abs.proto",
        # names protoc would read as options (it has no end of options), or print raw
        b"-I.proto",
        b"@x.proto",
        b"--plugin=protoc-gen-e=sub",
        b"--e_out=out",
        b"a\nb.proto",
        b"\x1b[2J.proto",
    ]
)
# Names a tree may hold, and (in half the examples) names no git writes: so that half the
# examples get past the names to the files, links and configurations.
PLAIN = st.one_of(
    ORDINARY,
    ORDINARY,
    ORDINARY,
    st.text("ab. ~:Gg\u200c", min_size=1, max_size=8)
    .filter(lambda n: n.strip(". "))
    .map(str.encode),
    st.sampled_from([b"x\xff.proto", b"\xfe.options"]),
)
NAMES = st.one_of(PLAIN, PLAIN, HOSTILE, st.binary(max_size=6))
PROTOS = st.sampled_from(
    [
        HEADER + "message A { int32 x = 1; }\n",
        HEADER + 'import "b.proto";\nmessage A { B b = 1; }\n',
        HEADER + "message B { string s = 1; }\n",
        HEADER + "message PBEnvelope { oneof payload { int32 a = 1; } }\n",
        HEADER + 'import "../x.proto";\n',
        HEADER + 'import "sub/a.proto";\nmessage C { oops }\n',
        "[tool.erc-lint]\nroots = ['A']\n",
        "message A 1 x int32 -\n",
    ]
).map(str.encode)
BLOBS = st.one_of(PROTOS, st.binary(max_size=64))
TARGETS = st.lists(
    st.sampled_from(["..", ".", "", "a.proto", "b.proto", "sub", "proto", "/", "/tmp", "@"]),
    max_size=5,
).map(lambda parts: "/".join(parts).replace("@", SENTINEL.decode()).encode())
ODD_MODES = st.sampled_from(
    [b"100644", b"100755", b"100664", b"120000", b"40000", b"040000", b"160000", b"644", b"1x"]
)
MODES = st.one_of(st.none(), st.none(), st.none(), ODD_MODES)  # None: the one its object needs


def _name(entry: tuple[bytes | None, bytes, Node]) -> bytes:
    return entry[1]


def nodes(
    names: st.SearchStrategy[bytes], modes: st.SearchStrategy[bytes | None]
) -> st.SearchStrategy[Node]:
    """Trees of blobs, symlinks and trees, entries named from ``names``, moded from ``modes``."""
    leaves = st.one_of(st.tuples(st.just("blob"), BLOBS), st.tuples(st.just("link"), TARGETS))
    return st.recursive(
        leaves,
        lambda inner: trees(names, modes, inner, 6),
        max_leaves=12,
    )


def trees(
    names: st.SearchStrategy[bytes],
    modes: st.SearchStrategy[bytes | None],
    inner: st.SearchStrategy[Node],
    size: int,
) -> st.SearchStrategy[Node]:
    entries = st.lists(st.tuples(modes, names, inner), max_size=size, unique_by=_name)
    return st.tuples(st.just("tree"), entries)


TOPS = st.one_of(
    trees(PLAIN, st.none(), nodes(PLAIN, st.none()), 8),
    trees(NAMES, MODES, nodes(NAMES, MODES), 8),
)


_NATURAL = {"blob": b"100644", "link": b"120000", "tree": b"40000"}


def write(repo: Path, node: Node, sentinel: Path) -> str:
    """The objects of ``node``, written loose; the id of its own. An entry's mode is the one
    its object's kind calls for, or (when drawn) another."""
    kind, content = node
    if kind == "blob":
        assert isinstance(content, bytes)
        return loose(repo, "blob", content)
    if kind == "link":
        assert isinstance(content, bytes)
        return loose(repo, "blob", content.replace(SENTINEL, str(sentinel).encode()))
    assert isinstance(content, list)
    data = b""
    for mode, name, child in content:
        oid = write(repo, child, sentinel)
        entry = name.replace(SENTINEL, str(sentinel).encode())
        data += (mode or _NATURAL[child[0]]) + b" " + entry + b"\0" + bytes.fromhex(oid)
    return loose(repo, "tree", data)


def snapshot(folder: Path) -> dict[str, bytes | None]:
    """Every path under ``folder`` with each file's bytes, but the repository's objects (which
    the test writes, and git reads)."""
    objects = folder / "repo" / ".git" / "objects"
    return {
        str(path): None if path.is_dir() or path.is_symlink() else path.read_bytes()
        for path in sorted(folder.rglob("*"))
        if not path.is_relative_to(objects)
    }


@pytest.fixture(scope="module")
def place(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("hostile")
    Repo(root / "repo")
    (root / "sentinel").mkdir()
    (root / "sentinel" / "abs.proto").write_text("the sentinel\n")
    (root / "x.proto").write_text("beside the repository\n")
    (root / "out").mkdir()
    (root / "sub").mkdir()
    (root / "sub" / "a.proto").write_text(f"#!/bin/sh\necho ran > {root / 'PWNED'}\n")
    (root / "sub" / "a.proto").chmod(0o755)
    return root


def folder(*entries: tuple[bytes | None, bytes, Node]) -> Node:
    return ("tree", list(entries))


_EMPTY: Node = ("blob", HEADER.encode())
# The reviewer's reproducer: protoc ran sub/a.proto as a plugin, and wrote its output in out/.
OPTIONS = folder(
    (None, b"--plugin=protoc-gen-e=sub", folder((None, b"a.proto", _EMPTY))),
    (None, b"--e_out=out", folder((None, b"x.proto", _EMPTY))),
    (None, b"ok.proto", ("blob", (HEADER + "message A { int32 x = 1; }\n").encode())),
)


@settings(
    max_examples=60,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
@given(
    node=TOPS,
    subdir=st.booleans(),
)
@example(node=OPTIONS, subdir=False)
@example(node=OPTIONS, subdir=True)
def test_hostile_objects_exit_0_1_or_2_and_write_only_scratch_files(
    place: Path, node: Node, subdir: bool
) -> None:
    repo = place / "repo"
    top = write(repo, node, place / "sentinel")
    if subdir:
        top = loose(repo, "tree", b"40000 proto\0" + bytes.fromhex(top))
    commit = loose_commit(repo, top)
    spec = f"{repo}#ref={commit}" + (",subdir=proto" if subdir else "")
    scratch = Path(tempfile.mkdtemp(dir=place / "out"))
    ledger = scratch.with_suffix(".lock")  # the one file the commands may write
    before = snapshot(place)
    saved, tempfile.tempdir = tempfile.tempdir, str(scratch)
    here = os.getcwd()
    os.chdir(place)  # where protoc would run a plugin from, or write an output
    try:
        for args in (
            ["check", spec],
            ["ledger", "update", spec, "--history", "--ledger", str(ledger)],
        ):
            result = CliRunner().invoke(main, args)
            assert result.exit_code in (0, 1, 2), (args, result.output, result.exception)
            assert result.exception is None or isinstance(result.exception, SystemExit)
            assert "internal error" not in result.stderr, result.stderr
            if result.exit_code == 2:
                assert result.stderr.count("\n") == 1, result.stderr
                assert result.stderr.startswith("Error: ")
            assert list(scratch.iterdir()) == []  # every scratch folder removed
    finally:
        os.chdir(here)
        tempfile.tempdir = saved
    after = snapshot(place)
    after.pop(str(ledger), None)
    assert after == before
