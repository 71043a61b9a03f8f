"""The team-repository scenarios, each a scripted git history: a typo in a subdir,
a leftover file whose names collide, a message type renamed with an identical body, two
same-named messages in one revision, and an OLD that does not compile."""

from pathlib import Path

from git_support import Repo
from lint_support import erc_lint_cli, tree

LEFTOVER = '[tool.erc-lint]\nignore_only = { NAME_COLLISION = ["message_types.proto"] }\n'


def test_a_subdir_typo_exits_2_for_diff_and_ledger(tmp_path: Path) -> None:
    repo = Repo(tmp_path / "repo")
    repo.commit("start", a="message A { float x = 1; }\n")
    typo = f"{repo.root}#ref=HEAD,subdir=protos"
    diff = erc_lint_cli(typo, str(repo.root / "proto"))
    assert diff.returncode == 2
    assert "no .proto file in OLD: none in subdir 'protos'" in diff.stderr
    assert "(did you mean 'proto'?)" in diff.stderr
    for extra in ([], ["--check"]):
        ledger = erc_lint_cli("ledger", "update", typo, *extra)
        assert ledger.returncode == 2, ledger.stderr
        assert "(did you mean 'proto'?)" in ledger.stderr


def test_a_leftover_colliding_file_is_silenced_by_ignore_only(tmp_path: Path) -> None:
    repo = Repo(tmp_path / "repo")
    repo.commit(
        "start",
        gps="message SensorBoardGPSInfo { double latitude = 1; }\n",
        message_types="enum PBMessageType { SensorBoardGPSInfo = 0; }\n",
    )
    noisy = erc_lint_cli("check", repo.spec("HEAD"))
    assert noisy.returncode == 1
    assert "NAME_COLLISION" in noisy.stdout
    (repo.root / "proto" / "pyproject.toml").write_text(
        '[tool.erc-lint]\nignore_only = { NAME_COLLISION = ["message_types.proto"] }\n'
    )
    repo.commit("ignore the leftover")
    quiet = erc_lint_cli("check", repo.spec("HEAD"))
    assert (quiet.returncode, quiet.stdout) == (0, ""), quiet.stderr


def test_ignore_only_silences_a_collision_whichever_file_sorts_last(tmp_path: Path) -> None:
    # The leftover sorts before and after the real file: ignoring it silences both.
    for real in ("a_gps.proto", "z_gps.proto"):
        root = tree(
            tmp_path / real,
            {
                real: "message GPS { double lat = 1; }\n",
                "message_types.proto": "enum T { GPS = 0; }\n",
            },
        )
        assert erc_lint_cli("check", str(root)).returncode == 1
        (root / "pyproject.toml").write_text(LEFTOVER)
        quiet = erc_lint_cli("check", str(root))
        assert (quiet.returncode, quiet.stdout) == (0, ""), quiet.stderr


def test_a_leftover_ignore_only_names_keeps_the_ledger_on_for_the_real_definition(
    tmp_path: Path,
) -> None:
    root = tree(tmp_path / "p", {"gps.proto": "message GPS { double lat = 1; double lon = 2; }\n"})
    done = erc_lint_cli("ledger", "update", str(root))
    assert done.returncode == 0, done.stderr
    tree(root, {"message_types.proto": "message GPS { double lat = 1; }\n"})
    (root / "pyproject.toml").write_text(LEFTOVER)
    tree(root, {"gps.proto": "message GPS { double lat = 1; string name = 2; }\n"})
    checked = erc_lint_cli("check", str(root))
    assert checked.returncode == 1, checked.stderr
    assert "gps.proto:2:31: LEDGER_NUMBER_REUSED" in checked.stdout
    assert "LEDGER_NUMBER_REUSED" in checked.stdout
    # The ledger records the real body, not the leftover's: name = 2 is missing from it.
    pending = erc_lint_cli("ledger", "update", str(root), "--check")
    assert pending.returncode == 1
    assert "message GPS 2 name string" in pending.stdout


def test_an_unresolved_collision_is_checked_in_every_definition_and_not_recorded(
    tmp_path: Path,
) -> None:
    root = tree(tmp_path / "q", {"a.proto": "message GPS { double lat = 1; }\n"})
    assert erc_lint_cli("ledger", "update", str(root)).returncode == 0
    tree(root, {"b.proto": "message GPS { string name = 1; }\n"})
    checked = erc_lint_cli("check", str(root))
    assert "b.proto:2:15: LEDGER_NUMBER_REUSED" in checked.stdout
    fresh = tree(
        tmp_path / "fresh",
        {
            "a.proto": "message GPS { double lat = 1; }\n",
            "b.proto": "message GPS { string name = 1; }\n",
        },
    )
    pending = erc_lint_cli("ledger", "update", str(fresh), "--check")
    assert pending.returncode == 1
    assert "GPS is defined more than once (NAME_COLLISION); none of its numbers recorded" in (
        pending.stderr
    )
    update = erc_lint_cli("ledger", "update", str(fresh))
    assert update.returncode == 0
    assert "0 entries added" in update.stdout
    assert "none of its numbers recorded" in update.stderr


def test_the_ledger_sees_a_renamed_type_and_duplicates_as_what_they_are(tmp_path: Path) -> None:
    repo = Repo(tmp_path / "repo")
    body = "{ float ph = 1; float temperature = 2; }\n"
    repo.commit(
        "ph",
        ph=f"message PHSensorInformation {body}",
        env='import "ph.proto";\nmessage Env { PHSensorInformation ph = 1; }\n',
    )
    repo.commit(
        "rename",
        ph=f"message SensorBoardPHInfo {body}",
        env='import "ph.proto";\nmessage Env { SensorBoardPHInfo ph = 1; }\n',
    )
    repo.commit("duplicate", copy="message Env { float other = 1; }\n")
    repo.commit("resolved", copy=None)
    ledger = tmp_path / "erc-lint.lock"
    done = erc_lint_cli("ledger", "update", repo.spec("main"), "--history", "--ledger", str(ledger))
    assert done.returncode == 0, done.stderr
    assert "message Env 1 other" not in ledger.read_text()  # a collision records neither body
    check = erc_lint_cli("check", repo.spec("main"), "--ledger", str(ledger))
    assert (check.returncode, check.stdout) == (0, ""), check.stdout


def test_a_pure_rename_in_the_ledger_is_graded_as_diff_grades_it(tmp_path: Path) -> None:
    repo = Repo(tmp_path / "repo")
    first = repo.commit("a", a="message A { float speed = 1; }\n")
    repo.commit("b", a="message A { float velocity = 1; }\n")
    ledger = tmp_path / "erc-lint.lock"
    erc_lint_cli("ledger", "update", repo.spec(first), "--ledger", str(ledger))
    check = erc_lint_cli("check", repo.spec("main"), "--ledger", str(ledger))
    diff = erc_lint_cli(repo.spec(first), repo.spec("main"))
    assert "FIELD_RENAMED (warning)" in diff.stdout
    assert "LEDGER_NUMBER_REUSED (warning)" in check.stdout
    assert check.returncode == diff.returncode == 0


def test_an_old_that_does_not_compile_still_compares_the_rest(tmp_path: Path) -> None:
    repo = Repo(tmp_path / "repo")
    broken = repo.commit(
        "broken", a="message A { float x = 1 }\n", b="message B { float y = 1; uint32 z = 2; }\n"
    )
    repo.commit("fixed", a="message A { float x = 1; }\n", b="message B { float y = 1; }\n")
    done = erc_lint_cli(repo.spec(broken), repo.spec("main"))
    assert done.returncode == 1  # B's deleted field is still found
    assert "FIELD_DELETED" in done.stdout
    assert "OLD's a.proto does not compile, so its messages could not be compared" in done.stdout
    assert "the element is gone from NEW" not in done.stdout
    ledger = erc_lint_cli(
        "ledger", "update", repo.spec(broken), "--check", "--ledger", str(tmp_path / "l.lock")
    )
    assert ledger.returncode == 1
    assert "a.proto does not compile" in ledger.stderr
