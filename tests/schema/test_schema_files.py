"""The one reader of a tree's files, and what the commands do with files that are not files: a
FIFO, a device, a file over its limit. Every refusal is one line and exit status 2, at once
(each command here has a timeout: before the reader, some hung or grew to 24 GB)."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from erc_codec import SchemaError
from erc_schema import SOURCE_LIMIT, FileError, load_schema, proto_files, read_file, read_text

ENVELOPE = 'syntax = "proto3";\nmessage PBEnvelope { oneof payload { int32 a = 1; } }\n'
DEVICES = [path for path in ("/dev/zero", "/dev/full", "/dev/null") if os.path.exists(path)]


def run(module: str, *args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", module, *args],
        capture_output=True,
        text=True,
        cwd=cwd,
        timeout=120,
        stdin=subprocess.DEVNULL,
    )


def refused(done: subprocess.CompletedProcess[str], complaint: str) -> None:
    assert done.returncode == 2, done
    assert done.stderr == f"Error: {complaint}\n"


def envelope_tree(root: Path) -> Path:
    root.mkdir()
    (root / "envelope.proto").write_text(ENVELOPE)
    return root


def test_a_regular_file_is_read_whole_up_to_its_limit(tmp_path: Path) -> None:
    path = tmp_path / "a.proto"
    path.write_bytes(b"x" * 100)
    assert read_file(path, 100) == b"x" * 100
    with pytest.raises(FileError, match=r"a\.proto: larger than 99 bytes, the limit") as caught:
        read_file(path, 99)
    assert (caught.value.path, caught.value.reason) == (str(path), caught.value.reason)
    assert SOURCE_LIMIT == 16 * 1024 * 1024
    big = tmp_path / "big.proto"
    with big.open("wb") as stream:
        stream.truncate(SOURCE_LIMIT + 1)  # sparse: nothing is written, nothing is read
    with pytest.raises(FileError, match=r"big\.proto: larger than 16 MiB, the limit for this file"):
        read_file(big)


def test_what_is_not_a_regular_file_is_refused_unopened(tmp_path: Path) -> None:
    fifo = tmp_path / "p.proto"
    os.mkfifo(fifo)  # opening it to read would block until a writer came
    with pytest.raises(FileError, match=r"p\.proto: not a regular file \(a FIFO\)"):
        read_file(fifo)
    with pytest.raises(FileError, match=r"not a regular file \(a directory\)"):
        read_file(tmp_path)
    with pytest.raises(FileError, match=r"missing\.proto: cannot read: No such file or directory"):
        read_file(tmp_path / "missing.proto")
    for device in DEVICES:
        link = tmp_path / f"{Path(device).name}.proto"
        link.symlink_to(device)
        with pytest.raises(FileError, match=r"not a regular file \(a character device\)"):
            read_file(link)


def test_text_is_utf8_or_refused(tmp_path: Path) -> None:
    path = tmp_path / "a.options"
    path.write_bytes(b"ok \xff\n")
    with pytest.raises(FileError, match=r"a\.options: not UTF-8 text \(byte 3\)"):
        read_text(path)
    assert read_text(path, errors="replace") == "ok \ufffd\n"
    assert issubclass(FileError, SchemaError)


def test_the_walk_never_enters_a_symlinked_folder(tmp_path: Path) -> None:
    """Python's own ``**`` does not follow symlinked folders on 3.10-3.13; the walk is ours, so
    that holds whatever the version, and listing a FIFO is for the reader to refuse."""
    root = envelope_tree(tmp_path / "tree")
    (root / "sub" / "deeper").mkdir(parents=True)
    (root / "sub" / "deeper" / "b.proto").write_text(ENVELOPE)
    (root / "sub-b.proto").write_text(ENVELOPE)  # sorts after sub/ by parts, before by text
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "far.proto").write_text(ENVELOPE)
    (root / "out").symlink_to(outside)  # a folder outside the tree
    (root / "loop").symlink_to(".")  # a cycle
    (root / "sub" / "up").symlink_to("..")
    (root / "linked.proto").symlink_to(outside / "far.proto")  # a file: it counts
    (root / "dangling.proto").symlink_to("nowhere.proto")
    (root / "folder.proto").mkdir()
    os.mkfifo(root / "fifo.proto")
    assert proto_files(root) == [
        "envelope.proto",
        "fifo.proto",
        "linked.proto",
        "sub/deeper/b.proto",
        "sub-b.proto",
    ]


def test_load_schema_refuses_a_fifo_and_a_device_in_the_tree(tmp_path: Path) -> None:
    root = envelope_tree(tmp_path / "tree")
    os.mkfifo(root / "p.proto")
    with pytest.raises(FileError, match=r"p\.proto: not a regular file \(a FIFO\)"):
        load_schema(root)


@pytest.mark.parametrize("module", ["erc_codec", "erc_lint"])
def test_a_fifo_or_device_among_the_protos_is_exit_2_not_a_hang(
    module: str, tmp_path: Path
) -> None:
    root = envelope_tree(tmp_path / "tree")
    args = ["sizes", "--proto", str(root)] if module == "erc_codec" else ["check", str(root)]
    os.mkfifo(root / "p.proto")
    refused(run(module, *args), f"{root}/p.proto: not a regular file (a FIFO)")
    (root / "p.proto").unlink()
    for device in DEVICES:
        (root / "zero.proto").symlink_to(device)
        refused(run(module, *args), f"{root}/zero.proto: not a regular file (a character device)")
        (root / "zero.proto").unlink()


@pytest.mark.parametrize("module", ["erc_codec", "erc_lint"])
def test_protoc_is_never_given_a_fifo_or_device_to_read(module: str, tmp_path: Path) -> None:
    """protoc reads what an import names wherever its search folders hold it, any name, through
    any symlinked folder: each such file is read first, and refused."""
    root = envelope_tree(tmp_path / "tree")
    args = ["sizes", "--proto", str(root)] if module == "erc_codec" else ["check", str(root)]
    (root / "dev").symlink_to("/dev")
    (root / "envelope.proto").write_text(ENVELOPE.replace(";\n", ';\nimport "dev/zero";\n', 1))
    refused(run(module, *args), f"{root}/dev/zero: not a regular file (a character device)")
    os.mkfifo(root / "pipe")
    (root / "envelope.proto").write_text(ENVELOPE.replace(";\n", ';\nimport "pipe";\n', 1))
    refused(run(module, *args), f"{root}/pipe: not a regular file (a FIFO)")


def test_a_nanopb_options_file_that_is_no_file_is_exit_2(tmp_path: Path) -> None:
    root = envelope_tree(tmp_path / "tree")
    (root / "envelope.proto").write_text(ENVELOPE.replace("int32 a = 1;", "string a = 1;"))
    os.mkfifo(root / "envelope.options")
    complaint = f"{root}/envelope.options: not a regular file (a FIFO)"
    refused(run("erc_codec", "sizes", "--proto", str(root)), complaint)
    refused(run("erc_lint", "check", str(root)), complaint)
    refused(run("erc_lint", str(root), str(root)), complaint)


def test_an_options_file_that_is_no_file_stops_a_size_check_that_stops_early(
    tmp_path: Path,
) -> None:
    """OLD and NEW differ before NEW's options file is compared, and OLD has no size: NEW's
    options file is read all the same."""
    old, new = envelope_tree(tmp_path / "old"), envelope_tree(tmp_path / "new")
    (old / "envelope.proto").write_text(ENVELOPE.replace("int32 a = 1;", "string a = 1;"))
    (new / "envelope.proto").write_text(
        ENVELOPE.replace("int32 a = 1;", "string a = 1;\n  string b = 2;")
    )
    (new / "pyproject.toml").write_text('[tool.erc-lint]\nuse = ["ENVELOPE_SIZE_GROWN"]\n')
    os.mkfifo(new / "envelope.options")
    refused(
        run("erc_lint", str(old), str(new)), f"{new}/envelope.options: not a regular file (a FIFO)"
    )


def test_a_configuration_or_ledger_beside_the_protos_that_is_a_fifo_is_refused(
    tmp_path: Path,
) -> None:
    root = envelope_tree(tmp_path / "tree")
    for name in ("pyproject.toml", "erc-lint.lock"):
        os.mkfifo(root / name)
        refused(run("erc_lint", "check", str(root)), f"{root}/{name}: not a regular file (a FIFO)")
        (root / name).unlink()
        (root / name).mkdir()  # a folder is no configuration, no ledger: there is none
        assert run("erc_lint", "check", str(root)).returncode == 0
        (root / name).rmdir()


@pytest.mark.skipif(not DEVICES, reason="no /dev/zero here")
def test_a_configuration_or_ledger_that_is_a_device_is_refused(tmp_path: Path) -> None:
    root = envelope_tree(tmp_path / "tree")
    zero = "/dev/zero: not a regular file (a character device)"
    refused(run("erc_lint", "check", str(root), "--config", "/dev/zero"), zero)
    for device in DEVICES:
        for args in (["check", str(root)], ["ledger", "update", str(root)]):
            refused(
                run("erc_lint", *args, "--ledger", device),
                f"{device}: not a regular file (a character device)",
            )
        assert Path(device).is_char_device()  # refused, never replaced


def test_a_configuration_or_ledger_over_its_limit_is_refused(tmp_path: Path) -> None:
    root = envelope_tree(tmp_path / "tree")
    big = tmp_path / "pyproject.toml"
    big.write_text("[tool.erc-lint]\n" + "#" * (1024 * 1024))
    check = ["check", str(root)]
    refused(
        run("erc_lint", *check, "--config", str(big)),
        f"{big}: larger than 1 MiB, the limit for this file",
    )
    ledger = tmp_path / "erc-lint.lock"
    with ledger.open("wb") as stream:
        stream.truncate(64 * 1024 * 1024 + 1)
    refused(
        run("erc_lint", *check, "--ledger", str(ledger)),
        f"{ledger}: larger than 64 MiB, the limit for this file",
    )


def _small_files() -> None:
    """In the child: no file may grow past 4 KiB (EFBIG, as a full disk gives ENOSPC)."""
    import resource
    import signal

    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (4096, 4096))


def test_a_ledger_that_cannot_be_written_stays_as_it_was(tmp_path: Path) -> None:
    """Written to a scratch file beside it, then renamed: a failed write leaves the old ledger
    whole, no scratch file behind, and one line."""
    root = envelope_tree(tmp_path / "tree")
    ledger = root / "erc-lint.lock"
    ledger.write_text("".join(f"# a comment kept, line {k}\n" for k in range(200)))
    before = ledger.read_bytes()
    assert len(before) > 4096
    done = subprocess.run(
        [sys.executable, "-m", "erc_lint", "ledger", "update", str(root)],
        capture_output=True,
        text=True,
        timeout=120,
        preexec_fn=_small_files,
    )
    refused(done, f"{ledger}: cannot write: File too large")
    assert ledger.read_bytes() == before
    assert sorted(path.name for path in root.iterdir()) == ["envelope.proto", "erc-lint.lock"]
