"""The schema layer's git revisions: a repository's objects read without a checkout, buf's
spelling, and the scratch copy, against real repositories."""

import os
from pathlib import Path

import pytest
from git_support import HEADER, Repo

from erc_codec import SchemaError
from erc_codec.schema import GitError, GitSpec, TreeSource, open_tree, parse_tree_spec

PROTO = HEADER + "message A { int32 x = 1; }\n"


def files_of(source: TreeSource) -> dict[str, bytes]:
    """Every file under a source's folder, by path, with its bytes (symlinks would show)."""
    found = {}
    for folder, _, names in os.walk(source.folder):
        for name in names:
            path = Path(folder) / name
            assert not path.is_symlink()
            found[path.relative_to(source.folder).as_posix()] = path.read_bytes()
    return found


def test_a_revision_is_its_commit_not_the_working_tree_and_nothing_changes(
    tmp_path: Path,
) -> None:
    repo = Repo(tmp_path / "repo")
    first = repo.commit("one", a="message A { int32 x = 1; }\n")
    (repo.root / "proto" / "a.options").write_text("A.x int_size:IS_8\n")
    (repo.root / "proto" / "README").write_text("not a proto\n")
    (repo.root / "proto" / "pyproject.toml").write_text("[tool.erc-lint]\n")
    repo.commit("two")
    (repo.root / "proto" / "a.proto").write_text("edited, not committed")
    status = repo.git("status", "--porcelain")
    index = (repo.root / ".git" / "index").read_bytes()
    with open_tree(repo.spec("main"), ("pyproject.toml",)) as source:
        assert source.shown == repo.root / "proto"
        assert source.revision == repo.git("rev-parse", "main")
        assert files_of(source) == {
            "a.proto": PROTO.encode(),
            "a.options": b"A.x int_size:IS_8\n",
            "pyproject.toml": b"[tool.erc-lint]\n",
        }
        scratch = source.folder
    assert not scratch.exists()
    with open_tree(repo.spec(first)) as source:
        assert files_of(source) == {"a.proto": PROTO.encode()}
    assert repo.git("status", "--porcelain") == status
    assert (repo.root / ".git" / "index").read_bytes() == index


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("proto", Path("proto")),
        ("repo#ref=main", GitSpec(Path("repo"), "main")),
        ("#branch=x,subdir=/a b/c/", GitSpec(Path("."), "x", "a b/c")),
        ("my repo#tag=v1,subdir=with space", GitSpec(Path("my repo"), "v1", "with space")),
    ],
)
def test_the_spelling_is_bufs(text: str, expected: Path | GitSpec) -> None:
    assert parse_tree_spec(text) == expected


@pytest.mark.parametrize(
    ("text", "complaint"),
    [
        ("repo#ref=main,depth=3", "not the option 'depth=3'"),
        ("repo#subdir=proto", "give exactly one of ref=, branch= or tag="),
        ("repo#ref=a,ref=b", "ref given twice"),
        ("repo#ref=main,subdir=a/../b", "subdir must be a plain path"),
        ("repo#ref=main,subdir=./a", "subdir must be a plain path"),
    ],
)
def test_a_bad_spelling_is_a_git_error(text: str, complaint: str) -> None:
    with pytest.raises(GitError, match=complaint):
        parse_tree_spec(text)


def test_git_errors_are_schema_errors() -> None:
    assert issubclass(GitError, SchemaError)
