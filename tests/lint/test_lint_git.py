"""erc_lint's reader of git objects: nothing in the repository changes, symlinks are
followed inside the commit."""

from pathlib import Path

from git_support import HEADER, Repo
from lint_support import reused_history, walk

import erc_lint


def test_git_inputs_touch_neither_working_tree_nor_index(
    tmp_path: Path,
) -> None:
    repo, ids = reused_history(tmp_path)
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
