"""The history walker of `ledger update --history`, against real git repositories whose
histories the tests script (branches and merges included)."""

from pathlib import Path

from git_support import Repo
from lint_support import erc_lint_cli, reused_history, walk

import erc_lint
from erc_lint._history import keys
from erc_lint._ledger import Key
from erc_lint._loader import load_tree


def test_history_catches_reuse_across_branches_with_the_first_revision(tmp_path: Path) -> None:
    repo, ids = reused_history(tmp_path)
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
        f"since revision {ids['add'][:12]} ({ledger}:6). Fix: use number 3 (the next free one) "
        "and reserve 2.\n"
    )
    # Once merged, later changes carry the damage as old (a warning); check reports it plainly.
    after = erc_lint_cli(repo.spec("main"), repo.spec("main"), "--ledger", str(ledger))
    assert after.returncode == 0
    assert "LEDGER_NUMBER_REUSED (warning)" in after.stdout
    alone = erc_lint.check(repo.spec("main"), ledger=ledger)
    assert [(f.rule, f.severity) for f in alone] == [("LEDGER_NUMBER_REUSED", "error")]


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


def test_a_revision_records_what_compiling_its_checkout_records(
    tmp_path: Path,
) -> None:
    repo, _ = reused_history(tmp_path)
    repo.commit(
        "spellings",
        user='import "diag.proto";\nimport "proto/other.proto";\n'
        "message User { Diag d = 1; Other o = 2; }\n",
    )
    _, _, walked = walk(repo, [repo.git("rev-parse", "main")])
    checkout = keys(load_tree(repo.root / "proto").files.values())
    assert {entry.key for entry in walked} == checkout
    assert len(checkout) == 5


def test_a_tree_s_own_nanopb_proto_wins_over_the_bundled_one(tmp_path: Path) -> None:
    repo = Repo(tmp_path / "repo")
    repo.commit(
        "vendored",
        nanopb="message Extra { int32 e = 1; }\n",
        a='import "nanopb.proto";\nmessage A { Extra extra = 1; }\n',
    )
    _, book, _ = walk(repo)
    assert Key("message", "A", 1, "extra", "Extra") in book.entries
