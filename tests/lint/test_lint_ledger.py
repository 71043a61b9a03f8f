"""The number ledger: its file, `ledger update`, and rule LEDGER_NUMBER_REUSED with its
reservations and acknowledgements."""

import re
from pathlib import Path

import pytest
from git_support import HEADER
from lint_support import erc_lint_cli, reused_history

import erc_lint
from erc_lint import LedgerError
from erc_lint._ledger import Ledger


def test_reserving_or_acknowledging_silences_the_reuse(tmp_path: Path) -> None:
    repo, _ = reused_history(tmp_path)
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
