"""erc_lint's inputs: a folder, or a git revision in buf's spelling, read without a
checkout and named as the repository names its files."""

import subprocess
from pathlib import Path

import pytest
from lint_support import erc_lint_cli, reused_history, tree

import erc_lint


def test_before_the_first_commit_head_is_an_empty_tree(tmp_path: Path) -> None:
    """The hook runs on a repository's first commit too: nothing came before, nothing broke."""
    repo = tree(tmp_path, {"proto/a.proto": "message A { float x = 1; }\n"})
    subprocess.run(["git", "init", "-q"], cwd=repo, check=True)
    first = erc_lint_cli(".#ref=HEAD,subdir=proto", "proto", cwd=repo)
    assert (first.returncode, first.stdout) == (0, "")
    assert first.stderr == "0 errors, 0 warnings in 1 file\n"
    # Only HEAD: any other name for a missing commit is still a mistake.
    missing = erc_lint_cli(".#branch=main,subdir=proto", "proto", cwd=repo)
    assert missing.returncode == 2
    assert "no commit named 'main'" in missing.stderr
    # The same repository, once it has commits, with HEAD detached from any branch: a real HEAD.
    git = ["git", "-c", "user.name=t", "-c", "user.email=t@t.invalid"]
    for command in (["add", "."], ["commit", "-qm", "one"], ["checkout", "-q", "--detach"]):
        subprocess.run([*git, *command], cwd=repo, check=True)
    (repo / "proto" / "a.proto").write_text("message A { sint32 x = 1; }\n")
    assert erc_lint_cli(".#ref=HEAD,subdir=proto", "proto", cwd=repo).returncode == 1


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
def test_bad_git_inputs_exit_2_in_one_line(tmp_path: Path, args: list[str], complaint: str) -> None:
    repo, _ = reused_history(tmp_path)
    outside = tmp_path / "not-a-repo"
    outside.mkdir()
    filled = [arg.format(repo=repo.root, tmp=outside) for arg in args]
    done = erc_lint_cli(*filled)
    assert done.returncode == 2, done
    assert complaint in done.stderr
    assert done.stderr.count("\n") == 1
    assert "Traceback" not in done.stderr


def test_gitdir_may_be_a_folder_of_the_working_tree_or_its_dot_git(tmp_path: Path) -> None:
    repo, _ = reused_history(tmp_path)
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
