"""erc-lint's git inputs, number ledger and single-tree check, against real git repositories
whose histories the tests script (branches and merges included)."""

import re
import subprocess
import sys
from pathlib import Path

import pytest

import erc_lint
from erc_lint import LedgerError
from erc_lint._git import Repository
from erc_lint._history import History, keys
from erc_lint._inputs import GitInput
from erc_lint._ledger import Entry, Key, Ledger
from erc_lint._loader import load_tree

HEADER = 'syntax = "proto3";\n'


class Repo:
    """A git repository the test writes history into, one commit at a time."""

    def __init__(self, root: Path) -> None:
        self.root = root
        root.mkdir(parents=True, exist_ok=True)
        self.git("init", "-q", "-b", "main")

    def git(self, *args: str) -> str:
        done = subprocess.run(
            ["git", "-c", "user.name=t", "-c", "user.email=t@t.invalid", *args],
            cwd=self.root,
            capture_output=True,
            text=True,
            check=True,
        )
        return done.stdout.strip()

    def commit(self, message: str, **files: str | None) -> str:
        """Write (or, for None, delete) ``proto/<name>.proto`` files and commit; the id."""
        for name, text in files.items():
            path = self.root / "proto" / f"{name}.proto"
            if text is None:
                path.unlink()
            else:
                path.parent.mkdir(parents=True, exist_ok=True)
                path.write_text(HEADER + text)
        self.git("add", "-A")
        self.git("commit", "-q", "--allow-empty", "-m", message)
        return self.git("rev-parse", "HEAD")

    def spec(self, ref: str) -> str:
        return f"{self.root}#ref={ref},subdir=proto"


def walk(repo: Repo, commits: list[str] | None = None) -> tuple[History, Ledger, list[Entry]]:
    """``ledger update --history`` in process over ``repo``'s main (or ``commits``): the walker,
    the ledger it filled and the entries it added."""
    book = Ledger("mem")
    with Repository(repo.root) as repository:
        history = History(repository, GitInput(repo.root, "main", "proto"))
        added = history.update(book, repository.history("main") if commits is None else commits)
    return history, book, added


def erc_lint_cli(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "erc_lint", *args], capture_output=True, text=True, cwd=cwd
    )


@pytest.fixture
def reused(tmp_path: Path) -> tuple[Repo, dict[str, str]]:
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


def test_history_catches_reuse_across_branches_with_the_first_revision(
    reused: tuple[Repo, dict[str, str]], tmp_path: Path
) -> None:
    repo, ids = reused
    ledger = tmp_path / "erc-lint.lock"
    done = erc_lint_cli("ledger", "update", repo.spec("main"), "--history", "--ledger", str(ledger))
    assert done.returncode == 0, done.stderr
    assert "5 revisions" in done.stdout
    entries = [line for line in ledger.read_text().splitlines() if not line.startswith("#")]
    assert entries == [
        f"message Diag 1 board uint32 {ids['add'][:12]}",
        f"message Diag 2 error_count uint32 {ids['reuse'][:12]}",
        f"message Diag 2 temperature float {ids['add'][:12]}",
        f"message Other 1 on bool {ids['other'][:12]}",
    ]
    # The merge against main before it: the diff alone sees an added field; the ledger sees more.
    before = erc_lint_cli(repo.spec(ids["other"]), repo.spec("main"), "--ledger", str(ledger))
    assert before.returncode == 1, before.stderr
    assert before.stdout == (
        f'{repo.root}/proto/diag.proto:2:34: LEDGER_NUMBER_REUSED Field "2" with name '
        f'"error_count" on message "Diag" reuses a number that carried "temperature" ("float") '
        f"since revision {ids['add'][:12]} ({ledger}:6).\n"
    )
    # Once merged, later changes carry the damage as old (a warning); check reports it plainly.
    after = erc_lint_cli(repo.spec("main"), repo.spec("main"), "--ledger", str(ledger))
    assert after.returncode == 0
    assert "LEDGER_NUMBER_REUSED (warning)" in after.stdout
    alone = erc_lint.check(repo.spec("main"), ledger=ledger)
    assert [(f.rule, f.severity) for f in alone] == [("LEDGER_NUMBER_REUSED", "error")]


def test_reserving_or_acknowledging_silences_the_reuse(
    reused: tuple[Repo, dict[str, str]], tmp_path: Path
) -> None:
    repo, _ = reused
    ledger = tmp_path / "erc-lint.lock"
    erc_lint_cli("ledger", "update", repo.spec("main"), "--history", "--ledger", str(ledger))
    fixed = repo.commit("reserve", diag="message Diag { uint32 board = 1; reserved 2; }\n")
    assert erc_lint.check(repo.spec(fixed), ledger=ledger) == []
    lines = [
        f"{line} ack  # no board sends temperature any more" if "error_count" in line else line
        for line in ledger.read_text().splitlines()
    ]
    ledger.write_text("\n".join(lines) + "\n")
    assert erc_lint.check(repo.spec("HEAD~1"), ledger=ledger) == []


@pytest.mark.parametrize(
    ("declared", "silent"),
    [
        ("uint32 error_count = 2;", True),  # the acknowledged use itself
        ("uint64 error_count = 2;", True),  # widened: reads the same bytes
        ("bool error_count = 2;", True),  # same varint group
        ("sint32 error_count = 2;", False),  # zigzag: not what the acknowledged use wrote
        ("uint32 error_total = 2;", False),  # another name: a new use, not acknowledged
    ],
)
def test_an_acknowledgement_covers_its_use_and_its_compatible_widenings(
    tmp_path: Path, declared: str, silent: bool
) -> None:
    ledger = tmp_path / "erc-lint.lock"
    ledger.write_text(
        "message Diag 2 error_count uint32 - ack  # no board sends temperature any more\n"
        "message Diag 2 temperature float -\n"
    )
    (tmp_path / "proto").mkdir()
    (tmp_path / "proto" / "diag.proto").write_text(HEADER + f"message Diag {{ {declared} }}\n")
    findings = erc_lint.check(tmp_path / "proto", ledger=ledger)
    assert [f.rule for f in findings] == ([] if silent else ["LEDGER_NUMBER_REUSED"])


def test_git_inputs_touch_neither_working_tree_nor_index(
    reused: tuple[Repo, dict[str, str]],
) -> None:
    repo, ids = reused
    (repo.root / "proto" / "diag.proto").write_text(HEADER + "message Diag { sint64 board = 1; }\n")
    status = repo.git("status", "--porcelain")
    index = (repo.root / ".git" / "index").read_bytes()
    # The committed tree is read, not the edited file: no change between add and delete but the
    # deletion of field 2.
    findings = erc_lint.lint(repo.spec(ids["add"]), repo.spec(ids["delete"]))
    assert [(f.rule, f.in_old) for f in findings] == [("FIELD_DELETED", True)]
    # A deleted element points at its old location, named as the repository names the file.
    assert findings[0].path == str(repo.root / "proto" / "diag.proto")
    assert repo.git("status", "--porcelain") == status
    assert (repo.root / ".git" / "index").read_bytes() == index


def test_a_revision_without_the_subdir_records_nothing(tmp_path: Path) -> None:
    repo = Repo(tmp_path / "repo")
    (repo.root / "README").write_text("x")
    repo.commit("no protos yet")
    last = repo.commit("protos", a="message A { int32 x = 1; }\n")
    _, _, added = walk(repo)
    assert [(e.key.name, e.since) for e in added] == [("x", last[:12])]


def test_a_file_is_compiled_again_only_when_it_or_what_it_imports_changed(
    tmp_path: Path,
) -> None:
    repo = Repo(tmp_path / "repo")
    repo.commit(
        "three files",
        base="message Base { int32 x = 1; }\n",
        leaf="message Leaf { int32 y = 1; }\n",
        user='import "base.proto";\nmessage User { Base b = 1; }\n',
    )  # 3 compilations
    for n in range(2, 6):  # 4: the leaf alone
        repo.commit(f"leaf {n}", leaf=f"message Leaf {{ int32 y = 1; int32 y{n} = {n}; }}\n")
    repo.commit("base grows", base="message Base { int32 x = 1; int32 z = 2; }\n")  # 1: base
    repo.commit("nothing")  # 0
    repo.commit("base renames", base="message Core { int32 x = 1; }\n")  # 2: user fails
    last = repo.commit("user follows", user='import "base.proto";\nmessage User { Core b = 1; }\n')
    history, book, _ = walk(repo)
    assert history.compiled == 3 + 4 + 1 + 0 + 2 + 1
    assert book.entries[Key("message", "User", 1, "b", "Core")].since == last[:12]


def test_import_cycles_and_broken_imports_record_nothing_of_what_they_touch(
    tmp_path: Path,
) -> None:
    repo = Repo(tmp_path / "repo")
    repo.commit(
        "cycle",
        a='import "b.proto";\nmessage A { int32 a = 1; }\n',
        b='import "a.proto";\nmessage B { int32 b = 1; }\n',
        c='import "a.proto";\nmessage C { int32 c = 1; }\n',
        d="message D { int32 d = 1; }\n",
        e='import "d.proto";\nmessage E { D d = 1; int32 broken = ; }\n',
        f='import "e.proto";\nmessage F { int32 f = 1; }\n',
    )
    _, book, _ = walk(repo)
    assert sorted(key.container for key in book.entries) == ["D"]


def test_update_adds_lines_and_keeps_every_other_one(tmp_path: Path) -> None:
    proto = tmp_path / "proto"
    proto.mkdir()
    (proto / "a.proto").write_text(HEADER + "message A { int32 x = 1; }\n")
    assert erc_lint_cli("ledger", "update", str(proto)).returncode == 0
    ledger = proto / "erc-lint.lock"
    first = ledger.read_text()
    assert first.splitlines()[-1] == "message A 1 x int32 -"
    ledger.write_text(
        first + "# why this one is fine:\nmessage A 1 old_x float 1234567890ab ack  # retired\n"
    )
    kept = ledger.read_text()
    (proto / "a.proto").write_text(HEADER + "message A { int32 x = 1; int32 w = 2; }\n")
    stale = erc_lint_cli("ledger", "update", str(proto), "--check")
    assert stale.returncode == 1
    assert stale.stdout == f"{ledger}: missing entry: message A 2 w int32 -\n"
    assert ledger.read_text() == kept
    assert erc_lint_cli("ledger", "update", str(proto)).returncode == 0
    assert ledger.read_text().splitlines()[3:] == [
        "# why this one is fine:",  # a comment stays above the entry that followed it
        "message A 1 old_x float 1234567890ab ack  # retired",
        "message A 1 x int32 -",
        "message A 2 w int32 -",
    ]
    again = ledger.read_text()
    assert erc_lint_cli("ledger", "update", str(proto)).returncode == 0
    assert ledger.read_text() == again


@pytest.mark.parametrize(
    ("text", "complaint"),
    [
        ("message A 1 x int32\n", "ledger.lock:1: expected KIND CONTAINER NUMBER"),
        ("message A one x int32 -\n", "ledger.lock:1: number 'one' is not an integer"),
        ("message A +1 x int32 -\n", "ledger.lock:1: number '+1' is not an integer"),
        ("message A 1 x int32 ack\n", "ledger.lock:1: revision 'ack' is neither a commit id"),
        ("field A 1 x int32 -\n", "ledger.lock:1: kind must be message or enum"),
        ("enum E 1 X int32 -\n", "ledger.lock:1: the type of an enum value is -"),
        (
            "message A 1 x int32 -\n\nmessage A 1 x int32 abcd1234 ack\n",
            "ledger.lock:3: entry given twice (first on line 1)",
        ),
        (
            "<<<<<<< ours\nmessage A 1 x int32 -\n=======\nmessage A 1 y int32 -\n>>>>>>> b\n",
            "ledger.lock:1: unresolved merge conflict",
        ),
    ],
)
def test_a_corrupt_or_conflicting_ledger_exits_2_naming_the_line(
    tmp_path: Path, text: str, complaint: str
) -> None:
    (tmp_path / "a.proto").write_text(HEADER + "message A { int32 x = 1; }\n")
    (tmp_path / "ledger.lock").write_text(text)
    with pytest.raises(LedgerError, match=re.escape(complaint.split(": ", 1)[1])):
        Ledger.read(tmp_path / "ledger.lock")
    for args in (["check", "."], ["ledger", "update", "."]):
        done = erc_lint_cli(*args, "--ledger", "ledger.lock", cwd=tmp_path)
        assert done.returncode == 2, done
        assert done.stderr.startswith(f"Error: {complaint}"), done.stderr
        assert done.stderr.count("\n") == 1


@pytest.mark.parametrize(
    ("args", "complaint"),
    [
        (["check", "{repo}#ref=nowhere"], "no commit named 'nowhere'"),
        (["check", "{repo}#ref=main,depth=3"], "not the option 'depth=3'"),
        (["check", "{repo}#subdir=proto"], "give exactly one of ref=, branch= or tag="),
        (["check", "{repo}#ref=main,subdir=../x"], "subdir must be a plain path"),
        (["check", "{repo}#ref=main,subdir=missing"], "no .proto file in TREE"),
        (["check", "{tmp}#ref=main"], "not a git repository"),
        (["ledger", "update", "{repo}/proto", "--history"], "--history needs a git input"),
    ],
)
def test_bad_git_inputs_exit_2_in_one_line(
    reused: tuple[Repo, dict[str, str]], tmp_path: Path, args: list[str], complaint: str
) -> None:
    repo, _ = reused
    outside = tmp_path / "not-a-repo"
    outside.mkdir()
    filled = [arg.format(repo=repo.root, tmp=outside) for arg in args]
    done = erc_lint_cli(*filled)
    assert done.returncode == 2, done
    assert complaint in done.stderr
    assert done.stderr.count("\n") == 1
    assert "Traceback" not in done.stderr


def test_a_revision_records_what_compiling_its_checkout_records(
    reused: tuple[Repo, dict[str, str]],
) -> None:
    repo, _ = reused
    repo.commit(
        "spellings",
        user='import "diag.proto";\nimport "proto/other.proto";\n'
        "message User { Diag d = 1; Other o = 2; }\n",
    )
    _, _, walked = walk(repo, [repo.git("rev-parse", "main")])
    checkout = keys(load_tree(repo.root / "proto").files.values())
    assert {entry.key for entry in walked} == checkout
    assert len(checkout) == 5


def test_gitdir_may_be_a_folder_of_the_working_tree_or_its_dot_git(
    reused: tuple[Repo, dict[str, str]], tmp_path: Path
) -> None:
    repo, _ = reused
    ledger = tmp_path / "erc-lint.lock"
    erc_lint_cli("ledger", "update", repo.spec("main"), "--history", "--ledger", str(ledger))
    expected = str(repo.root / "proto" / "diag.proto")
    for spec in (f"{repo.root}/proto#ref=main", f"{repo.root}/.git#ref=main,subdir=proto"):
        found = erc_lint.check(spec, ledger=ledger)
        assert [(f.rule, f.path) for f in found] == [("LEDGER_NUMBER_REUSED", expected)], spec
    # From inside the folder, "." is that folder: names are relative to it, as typed.
    inside = erc_lint_cli("check", ".#ref=main", "--ledger", str(ledger), cwd=repo.root / "proto")
    assert inside.stdout.startswith("diag.proto:2:34: LEDGER_NUMBER_REUSED"), inside
    # Written beside the protos of the working tree, never into .git.
    done = erc_lint_cli("ledger", "update", f"{repo.root}/.git#ref=main,subdir=proto")
    assert done.returncode == 0, done.stderr
    assert (repo.root / "proto" / "erc-lint.lock").is_file()
    assert not (repo.root / ".git" / "erc-lint.lock").exists()


def test_symlinked_protos_are_read_through_their_links(tmp_path: Path) -> None:
    repo = Repo(tmp_path / "repo")
    shared = repo.root / "shared"
    shared.mkdir()
    (shared / "common.proto").write_text(HEADER + "message Common { int32 x = 1; }\n")
    (repo.root / "proto").mkdir()
    (repo.root / "proto" / "common.proto").symlink_to("../shared/common.proto")
    repo.commit("linked", user='import "common.proto";\nmessage User { Common c = 1; }\n')
    assert erc_lint.check(repo.root / "proto") == []
    assert erc_lint.check(repo.spec("main")) == []
    _, book, _ = walk(repo)
    assert sorted(key.container for key in book.entries) == ["Common", "User"]


def test_a_field_keeping_a_renamed_type_reuses_nothing(tmp_path: Path) -> None:
    old, new = tmp_path / "old", tmp_path / "new"
    for folder, name in ((old, "Foo"), (new, "Bar")):
        folder.mkdir()
        (folder / "m.proto").write_text(
            HEADER + f"message {name} {{ int32 a = 1; }}\nmessage M {{ {name} x = 1; }}\n"
        )
    assert (
        erc_lint_cli("ledger", "update", str(old), "--ledger", str(tmp_path / "l")).returncode == 0
    )
    found = erc_lint.lint(old, new, ledger=tmp_path / "l")
    assert [f.rule for f in found] == ["MESSAGE_RENAMED"]


def test_a_tree_s_own_nanopb_proto_wins_over_the_bundled_one(tmp_path: Path) -> None:
    repo = Repo(tmp_path / "repo")
    repo.commit(
        "vendored",
        nanopb="message Extra { int32 e = 1; }\n",
        a='import "nanopb.proto";\nmessage A { Extra extra = 1; }\n',
    )
    _, book, _ = walk(repo)
    assert Key("message", "A", 1, "extra", "Extra") in book.entries


def test_check_wants_the_canonical_form_and_keeps_line_endings(tmp_path: Path) -> None:
    (tmp_path / "a.proto").write_text(HEADER + "message A { int32 x = 1; int32 y = 2; }\n")
    ledger = tmp_path / "erc-lint.lock"
    assert erc_lint_cli("ledger", "update", str(tmp_path)).returncode == 0
    lines = ledger.read_text().splitlines()
    header, entries = lines[:3], lines[3:]
    shuffled = ["# kept at the top", "", *reversed(entries)]
    ledger.write_bytes("\r\n".join([*header, *shuffled, ""]).encode())
    stale = erc_lint_cli("ledger", "update", str(tmp_path), "--check")
    assert stale.returncode == 1
    assert "not in canonical form" in stale.stdout
    (tmp_path / "b.proto").write_text(HEADER + "message B { int32 z = 1; }\n")
    assert erc_lint_cli("ledger", "update", str(tmp_path)).returncode == 0
    assert ledger.read_bytes().decode().split("\r\n")[3:] == [
        "# kept at the top",
        "message A 1 x int32 -",
        "message A 2 y int32 -",
        "message B 1 z int32 -",
        "",
    ]
    assert erc_lint_cli("ledger", "update", str(tmp_path), "--check").returncode == 0
