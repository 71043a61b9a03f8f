"""The schema layer's git revisions: a repository's objects read without a checkout, buf's
spelling, and the scratch copy, against real repositories, hostile objects included (made with
git's plumbing: a fetch hands such objects over unchecked, and a CI lints what it fetched)."""

import os
import subprocess
import sys
from pathlib import Path

import pytest
from git_support import HEADER, Repo, loose, loose_commit
from git_support import tree as git_tree

from erc_codec import SchemaError
from erc_schema import (
    GitError,
    GitSpec,
    Repository,
    TreeSource,
    open_tree,
    parse_tree_spec,
)
from erc_schema._git import MAX_DEPTH, MAX_FILES

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
    with open_tree(repo.spec("main"), {"pyproject.toml": 100}) as source:
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


def test_symlinks_resolve_in_the_commit_and_never_leave_it(tmp_path: Path) -> None:
    repo = Repo(tmp_path / "repo")
    (repo.root / "shared" / "deep").mkdir(parents=True)
    (repo.root / "shared" / "deep" / "common.proto").write_text(PROTO)
    (repo.root / "proto").mkdir()
    (tmp_path / "outside.proto").write_text("outside the repository\n")
    links = {
        "inside.proto": "../shared/deep/common.proto",  # out of the tree, inside the repo
        "through.proto": "../shared/link/common.proto",  # through a symlinked folder
        "chain.proto": "inside.proto",  # a link to a link
        "absolute.proto": str(tmp_path / "outside.proto"),
        "escape.proto": "../../outside.proto",
        "dangling.proto": "missing.proto",
        "folder.proto": "../shared",
        "loop.proto": "loop.proto",
        "file-as-folder.proto": "inside.proto/x",
    }
    (repo.root / "shared" / "link").symlink_to("deep")
    for name, target in links.items():
        (repo.root / "proto" / name).symlink_to(target)
    repo.commit("links")
    with open_tree(repo.spec("main")) as source:
        found = files_of(source)
    followed = ("inside.proto", "through.proto", "chain.proto")
    assert found == dict.fromkeys(followed, PROTO.encode())


def test_a_chain_of_more_than_40_links_is_left_out(tmp_path: Path) -> None:
    repo = Repo(tmp_path / "repo")
    (repo.root / "proto").mkdir()
    (repo.root / "proto" / "0.proto").write_text(PROTO)
    for k in range(1, 42):
        (repo.root / "proto" / f"{k}.proto").symlink_to(f"{k - 1}.proto")
    repo.commit("chain")
    with open_tree(repo.spec("main")) as source:
        found = files_of(source)
    # Linux follows 40 links: 40.proto reaches 0.proto through 40 of them, 41.proto needs 41.
    assert sorted(found, key=lambda name: int(name.split(".")[0])) == [
        f"{k}.proto" for k in range(41)
    ]


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


def test_spaces_work_in_every_part_of_the_spelling(tmp_path: Path) -> None:
    """Ref names cannot hold a space; a repository's folder, a subdir and file names can."""
    repo = Repo(tmp_path / "my repo")
    (repo.root / "a b" / "c d").mkdir(parents=True)
    (repo.root / "a b" / "c d" / "x y.proto").write_text(PROTO)
    repo.commit("spaces")
    with open_tree(f"{repo.root}#ref=main,subdir=a b") as source:
        assert files_of(source) == {"c d/x y.proto": PROTO.encode()}
        assert source.shown == repo.root / "a b"
    # A folder the commit lacks: git's answer to "C:no such" was "C:no such missing", three words.
    with open_tree(f"{repo.root}#ref=main,subdir=no such") as source:
        assert files_of(source) == {}
    with (
        pytest.raises(GitError, match=r"'a b/c d/x y\.proto' at [0-9a-f]{12} is not a folder"),
        open_tree(f"{repo.root}#ref=main,subdir=a b/c d/x y.proto"),
    ):
        pass
    with Repository(repo.root / "a b") as repository:
        assert repository.where("c d") == ("a b/c d", repo.root / "a b" / "c d")


def test_a_blob_over_the_limit_is_refused_unread_and_reading_goes_on(tmp_path: Path) -> None:
    repo = Repo(tmp_path / "repo")
    big = repo.blob(b"x" * 1001)
    small = repo.blob(b"small")
    with Repository(repo.root) as repository:
        with pytest.raises(
            GitError, match=r"^big\.proto: 1001 bytes, over the limit of 1000 bytes"
        ):
            repository.read(big, 1000, "big.proto")
        assert repository.read(small) == b"small"  # a new cat-file process serves it
        assert repository.read(big, 1001) == b"x" * 1001


def test_a_proto_over_16_mib_stops_a_revision_in_one_line(tmp_path: Path) -> None:
    repo = Repo(tmp_path / "repo")
    (repo.root / "proto").mkdir()
    (repo.root / "proto" / "huge.proto").write_bytes(b"/" * (16 * 1024 * 1024 + 1))
    repo.commit("huge")
    done = erc_lint("check", repo.spec("main"))
    assert done.returncode == 2
    assert done.stderr == (
        f"Error: {repo.root}/proto/huge.proto: 16777217 bytes, over the limit of 16 MiB: refused\n"
    )


def erc_lint(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "erc_lint", *args], capture_output=True, text=True, timeout=120
    )


# Entry names no git command writes, each of which once wrote outside the scratch folder or
# would on some file system (git's fsck: has_full_path, has_dotdot, has_dot, has_empty_name,
# has_dotgit with its case, NTFS and HFS+ spellings); True: the entry is a folder.
HOSTILE = [
    ("{victims}/abs.proto", False),
    ("../../victim.proto", False),
    ("a/b.proto", False),
    ("..", True),
    ("..", False),
    (".", True),
    ("", True),
    (".git", True),
    (".GIT", True),
    (".Git.", True),
    (".git ", True),
    ("git~1", True),
    (".g\u200cit", True),
    (".git::$INDEX_ALLOCATION", True),
]


@pytest.mark.parametrize(("name", "folder"), HOSTILE)
def test_a_hostile_entry_refuses_the_revision_and_writes_nothing(
    tmp_path: Path, name: str, folder: bool
) -> None:
    repo = Repo(tmp_path / "repo")
    victims = tmp_path / "victims"
    victims.mkdir()
    (victims / "abs.proto").write_text("kept\n")
    blob = repo.blob(PROTO)
    inner = repo.tree([("100644", "victim.proto", blob), ("100644", "x.proto", blob)])
    entry = name.format(victims=victims)
    hostile = repo.tree(
        [
            ("100644", "a.proto", blob),
            ("40000", entry, inner) if folder else ("100644", entry, blob),
        ]
    )
    commit = repo.branch("hostile", repo.tree([("40000", "proto", hostile)]))
    before = snapshot(tmp_path)
    with (
        pytest.raises(GitError, match=f"tree {hostile} holds an entry named"),
        open_tree(f"{repo.root}#ref={commit},subdir=proto"),
    ):
        pass
    for args in (
        ["check", repo.spec("hostile")],
        ["ledger", "update", repo.spec("hostile"), "--history", "--ledger", str(tmp_path / "l")],
    ):
        done = erc_lint(*args)
        assert done.returncode == 2, done
        assert done.stderr.count("\n") == 1, done.stderr
        assert f"tree {hostile} holds an entry named {entry!r}" in done.stderr
    assert (victims / "abs.proto").read_text() == "kept\n"
    assert snapshot(tmp_path) == before


def snapshot(folder: Path) -> dict[str, bytes | None]:
    """Every path under ``folder`` but the repository's objects, with each file's bytes."""
    return {
        str(path): None if path.is_dir() else path.read_bytes()
        for path in folder.rglob("*")
        if ".git" not in path.parts
    }


def test_history_never_deletes_outside_its_scratch_folder(tmp_path: Path) -> None:
    """``ledger update --history`` compiled each file in place and unlinked it after: a file
    named ``/abs/x.proto`` was written and then deleted, whatever it had been."""
    repo = Repo(tmp_path / "repo")
    victim = tmp_path / "victim.proto"
    victim.write_text("kept\n")
    blob = repo.blob(PROTO)
    hostile = repo.tree([("100644", str(victim), blob)])
    repo.branch("hostile", repo.tree([("40000", "proto", hostile)]))
    ledger = str(tmp_path / "l")
    done = erc_lint("ledger", "update", repo.spec("hostile"), "--history", "--ledger", ledger)
    assert done.returncode == 2
    assert victim.read_text() == "kept\n"


@pytest.mark.parametrize(
    ("entries", "complaint"),
    [
        (
            [("100644", "a.proto", "{blob}"), ("100644", "a.proto", "{blob}")],
            "holds 'a.proto' twice",
        ),
        ([("40000", "a", "{blob}")], "is a blob, not a tree"),
        ([("100644", "a.proto", "{tree}")], "proto/a.proto: a tree, not a file"),
        ([("60644", "a.proto", "{blob}")], "gives 'a.proto' the mode '60644'"),
        ([("10x644", "a.proto", "{blob}")], "gives 'a.proto' the mode '10x644'"),
        ([("40000", "a", "0" * 40)], "no tree 0000000000000000000000000000000000000000"),
    ],
)
def test_a_tree_git_never_writes_is_refused_in_one_line(
    tmp_path: Path, entries: list[tuple[str, str, str]], complaint: str
) -> None:
    repo = Repo(tmp_path / "repo")
    blob = repo.blob(PROTO)
    sub = repo.tree([("100644", "x.proto", blob)])
    made = [(mode, name, oid.format(blob=blob, tree=sub)) for mode, name, oid in entries]
    repo.branch("odd", repo.tree([("40000", "proto", repo.tree(made))]))
    done = erc_lint("check", repo.spec("odd"))
    assert done.returncode == 2, done
    assert complaint in done.stderr
    assert done.stderr.count("\n") == 1


def test_a_corrupt_tree_is_refused(tmp_path: Path) -> None:
    repo = Repo(tmp_path / "repo")
    cut = bytes.fromhex(repo.blob(PROTO))[:7]
    command = ("hash-object", "-w", "-t", "tree", "--literally", "--stdin")
    for broken in (
        repo.git(*command, data=b"100644 a.proto"),  # no NUL after the name
        repo.git(*command, data=b"100644 a.proto\0" + cut),  # the id cut short
    ):
        with Repository(repo.root) as repository:
            commit = repo.git("commit-tree", broken, "-m", "x")
            with pytest.raises(GitError, match=f"tree {broken} is corrupt at byte 0"):
                repository.files(commit)


def test_a_tree_nesting_to_more_than_max_files_is_refused_small(tmp_path: Path) -> None:
    """Two trees of 400 entries make 160,000 paths: refused while flattened, in a moment."""
    repo = Repo(tmp_path / "repo")
    blob = repo.blob(PROTO)
    leaves = repo.tree([("100644", f"{k:03}.proto", blob) for k in range(400)])
    bomb = repo.tree([("40000", f"d{k:03}", leaves) for k in range(400)])
    assert MAX_FILES < 400 * 400
    commit = repo.branch("bomb", bomb)
    with Repository(repo.root) as repository, pytest.raises(GitError, match="more than 100000"):
        repository.files(commit)


def test_trees_nested_deeper_than_max_depth_are_refused_without_recursion(
    tmp_path: Path,
) -> None:
    repo = Repo(tmp_path / "repo")
    deepest = {}
    tree = loose(repo.root, "tree", git_tree([("100644", "x.proto", repo.blob(PROTO))]))
    for depth in range(1, 3001):
        tree = loose(repo.root, "tree", git_tree([("40000", "d", tree)]))
        if depth in (MAX_DEPTH, MAX_DEPTH + 1, 3000):  # a commit costs two git processes
            deepest[depth] = repo.branch(f"at-{depth}", tree)
    with Repository(repo.root) as repository:
        assert list(repository.files(deepest[MAX_DEPTH])) == ["d/" * MAX_DEPTH + "x.proto"]
        with pytest.raises(GitError, match=f"nests files more than {MAX_DEPTH} folders deep"):
            repository.files(deepest[MAX_DEPTH + 1])
    done = erc_lint("check", f"{repo.root}#ref=at-3000")
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1
    assert f"nests files more than {MAX_DEPTH} folders deep: refused" in done.stderr


def test_the_files_of_a_revision_are_bounded_in_all(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """16 MiB a file, 256 MiB in all (here 1 KiB, to see the sum counted)."""
    monkeypatch.setattr("erc_schema._tree.TREE_LIMIT", 1024)
    repo = Repo(tmp_path / "repo")
    entries = [("100644", f"{k}.proto", repo.blob(f"// {k}\n" + "/" * 300)) for k in range(4)]
    repo.branch("many", repo.tree(entries))
    with (
        pytest.raises(GitError, match=r"the tree's files pass 1 KiB in all at 3\.proto: refused"),
        open_tree(f"{repo.root}#ref=many"),
    ):
        pass


def test_git_errors_are_schema_errors() -> None:
    assert issubclass(GitError, SchemaError)


def shared_tree_bomb(repo: Path, copies: int) -> str:
    """A commit of ``copies`` small distinct trees, each holding one shared tree of 99,000
    files and a file of its own: some 3 MB of objects that flatten to ``copies`` * 99,001
    paths. Flattening each subtree before the limit was checked cost 677 MB at 60 copies."""
    blob = loose(repo, "blob", PROTO.encode())
    shared = loose(
        repo, "tree", git_tree([("100644", f"f{k:06}.proto", blob) for k in range(99_000)])
    )
    tops = []
    for k in range(copies):
        own = loose(repo, "blob", f"{PROTO}// {k}\n".encode())
        inner = git_tree([("40000", "s", shared), ("100644", "u.proto", own)])
        tops.append(("40000", f"d{k:05}", loose(repo, "tree", inner)))
    return loose_commit(repo, loose(repo, "tree", git_tree(tops)))


@pytest.mark.skipif(sys.platform != "linux", reason="the peak is read from Linux's /proc")
def test_a_revision_sharing_one_big_tree_is_refused_in_little_memory(tmp_path: Path) -> None:
    repo = Repo(tmp_path / "repo")
    commit = shared_tree_bomb(repo.root, 30)
    probe = (
        "import sys\n"
        "from pathlib import Path\n"
        "from erc_codec.schema import GitError, Repository\n"
        "with Repository(Path(sys.argv[1])) as repository:\n"
        "    try:\n"
        "        repository.files(sys.argv[2])\n"
        "    except GitError as error:\n"
        "        print(error)\n"
        # this program's own peak (getrusage's ru_maxrss keeps the forking pytest's)
        "peak = [l for l in open('/proc/self/status') if l.startswith('VmHWM:')]\n"
        "print(int(peak[0].split()[1]) // 1024)\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", probe, str(repo.root), commit],
        capture_output=True,
        text=True,
        timeout=120,
        check=True,
    )
    refusal, megabytes = done.stdout.splitlines()
    assert refusal.endswith(f"holds more than {MAX_FILES} .proto and .options files: refused")
    # The shared tree's 99,000 parsed entries, and nothing per copy (it was 340 MB).
    assert int(megabytes) < 150, done.stdout


def test_a_revision_whose_paths_add_up_past_max_path_text_is_refused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Few files, long shared folder names: 100,000 paths of 64 KiB each would be 6.5 GB."""
    monkeypatch.setattr("erc_schema._git.MAX_PATH_TEXT", 4096)
    repo = Repo(tmp_path / "repo")
    inner = repo.tree([("100644", "x.proto", repo.blob(PROTO))])
    long = repo.tree([("40000", "n" * 200, inner)])
    fine = repo.branch("fine", repo.tree([("40000", f"{k:02}", long) for k in range(19)]))
    over = repo.branch("over", repo.tree([("40000", f"{k:02}", long) for k in range(20)]))
    with Repository(repo.root) as repository:
        assert len(repository.files(fine)) == 19  # 19 * 211 characters
        with pytest.raises(GitError, match=r"files add up to more than 4 KiB: refused"):
            repository.files(over)  # 20 * 211


def chain_of_links(repo: Path, entries: int, distinct: bool) -> tuple[str, str]:
    """A commit whose ``entries`` symlinked .proto files each walk a chain of 40 links of
    some 4 KiB of ``a/../`` steps to ``a/z.proto`` (``distinct``: each entry its own chain's
    first link, which no memory of the others can shorten); the commit and z.proto's blob."""
    blob = loose(repo, "blob", PROTO.encode())
    entries_of = [("40000", "a", loose(repo, "tree", git_tree([("100644", "z.proto", blob)])))]
    steps = "a/../" * 800
    for k in range(40, 1, -1):
        target = steps + (f"L{k + 1:02}" if k < 40 else "a/z.proto")
        entries_of.append(("120000", f"L{k:02}", loose(repo, "blob", target.encode())))
    for k in range(entries):
        first = steps + "./" * (k if distinct else 0) + "L02"
        entries_of.append(("120000", f"x{k:06}.proto", loose(repo, "blob", first.encode())))
    top = loose(repo, "tree", git_tree(sorted(entries_of, key=lambda entry: entry[1])))
    return loose_commit(repo, top), blob


def test_symlinks_sharing_a_chain_are_resolved_once(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """200 links each walking 40 links of 1,600 steps took 9.3 s (100,000 would take 77
    minutes): each link's target is found once per folder, within MAX_LINK_STEPS in all."""
    repo = Repo(tmp_path / "repo")
    commit, z = chain_of_links(repo.root, 200, distinct=False)
    monkeypatch.setattr("erc_schema._git.MAX_LINK_STEPS", 2 * 40 * 1601)  # two walks
    with Repository(repo.root) as repository:
        found = repository.files(commit)
    assert found == {"a/z.proto": z} | {f"x{k:06}.proto": z for k in range(200)}


def test_symlinks_taking_more_than_max_link_steps_refuse_the_revision(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    repo = Repo(tmp_path / "repo")
    commit, z = chain_of_links(repo.root, 20, distinct=True)
    with Repository(repo.root) as repository:
        # The chain once (40 * 1,601 steps), then 1,600 steps of each entry's own to it.
        assert repository.files(commit) == {"a/z.proto": z} | {
            f"x{k:06}.proto": z for k in range(20)
        }
        monkeypatch.setattr("erc_schema._git.MAX_LINK_STEPS", 50 * 1601)
        with pytest.raises(
            GitError, match=r"repo: symlinks take more than 80050 steps to resolve: refused"
        ):
            repository.files(commit)


@pytest.mark.parametrize(
    ("name", "shown", "what"),
    [
        (b"a\nb.proto", "a\\nb.proto", "a control character"),
        (b"\x1b[2J.proto", "\\x1b[2J.proto", "a control character"),
        (b"\t.proto", "\\t.proto", "a control character"),
        (b"-I.proto", "-I.proto", "a leading '-'"),
        (b"--plugin=protoc-gen-e=x.proto", "--plugin=protoc-gen-e=x.proto", "a leading '-'"),
        (b"@x.proto", "@x.proto", "a leading '@'"),
    ],
)
def test_a_file_name_protoc_would_misread_refuses_the_revision(
    tmp_path: Path, name: bytes, shown: str, what: str
) -> None:
    """git's fsck allows these names; protoc took ``-I.proto`` for an include folder (its
    errors never reported) and printed a newline raw, splitting its diagnostics."""
    repo = Repo(tmp_path / "repo")
    bad = repo.blob(HEADER + "message B { int32 a = 1 }\n")
    top = repo.tree([("100644", name, bad), ("100644", "ok.proto", repo.blob(PROTO))])
    commit = repo.branch("names", repo.tree([("40000", "proto", top)]))
    refusal = (
        f"{repo.root}: {commit[:12]} holds '{shown}', a file name with {what}, which protoc "
        "would misread: refused"
    )
    with Repository(repo.root) as repository:
        with pytest.raises(GitError) as caught:
            repository.files(commit, "proto")
        assert str(caught.value) == refusal
        if what.startswith("a leading"):  # proto/-I.proto is no option: it is not at the top
            assert sorted(repository.files(commit)) == [f"proto/{shown}", "proto/ok.proto"]
    done = erc_lint("check", repo.spec("names"))
    assert done.returncode == 2, done
    assert done.stderr == f"Error: {refusal}\n"
