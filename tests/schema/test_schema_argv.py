"""Nothing a tree holds reaches protoc as one of its options: a file named ``-I.proto`` or
``@x.proto``, folders named ``--plugin=protoc-gen-e=scripts`` and ``--e_out=out``, a search folder
holding ``=`` or ``:``, a name with a control character. protoc has no end of options, and once
ran a program of the tree's choosing (the reviewer's reproducer, here with real protoc)."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from erc_schema import FileError, compile_files

OK = 'syntax = "proto3";\nmessage Ok { int32 a = 1; }\n'


def erc_lint(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "erc_lint", *args],
        capture_output=True,
        text=True,
        cwd=cwd,
        timeout=120,
        stdin=subprocess.DEVNULL,
    )


def test_folders_named_as_protoc_options_never_run_a_program(tmp_path: Path) -> None:
    marker = tmp_path / "PWNED"
    (tmp_path / "scripts").mkdir()
    script = tmp_path / "scripts" / "evil.proto"
    script.write_text(f"#!/bin/sh\necho pwned > {marker}\n")
    script.chmod(0o755)
    plugin = tmp_path / "proto" / "--plugin=protoc-gen-e=scripts"
    out = tmp_path / "proto" / "--e_out=out"
    plugin.mkdir(parents=True)
    out.mkdir()
    (plugin / "evil.proto").write_text('syntax = "proto3";\n')
    (out / "x.proto").write_text('syntax = "proto3";\n')
    (tmp_path / "proto" / "ok.proto").write_text(OK)
    done = erc_lint("check", "proto", cwd=tmp_path)
    assert not marker.exists()  # protoc ran scripts/evil.proto as a plugin: it wrote this
    assert done.returncode == 2, done
    assert done.stderr == (
        "Error: proto/--e_out=out/x.proto: a file name beginning with '-', which protoc reads "
        "as an option: refused\n"
    )


@pytest.mark.parametrize("name", ["-I.proto", "--fatal_warnings.proto", "@x.proto"])
def test_a_file_protoc_would_read_as_an_option_is_refused(tmp_path: Path, name: str) -> None:
    """``-I.proto`` was taken for an include folder: its syntax error never reported (exit 0);
    ``@x.proto`` for a response file."""
    (tmp_path / "hide").mkdir()
    (tmp_path / "hide" / name).write_text("syntax = oops\n")
    (tmp_path / "hide" / "ok.proto").write_text(OK)
    (tmp_path / "x.proto").write_text("--plugin=protoc-gen-e=/bin/true\n")
    done = erc_lint("check", "hide", cwd=tmp_path)
    assert done.returncode == 2, done
    assert done.stderr == (
        f"Error: hide/{name}: a file name beginning with {name[0]!r}, which protoc reads as "
        "an option: refused\n"
    )
    with pytest.raises(FileError, match="which protoc reads as an option: refused") as caught:
        compile_files(tmp_path / "hide", ["ok.proto", name])
    assert caught.value.path == str(tmp_path / "hide" / name)


def test_such_a_name_below_a_folder_is_no_option_and_compiles(tmp_path: Path) -> None:
    (tmp_path / "sub" / "-I").mkdir(parents=True)
    (tmp_path / "sub" / "-I" / "@a.proto").write_text(OK)
    compiled = compile_files(tmp_path, ["sub/-I/@a.proto"])
    assert [file.name for file in compiled.file] == ["sub/-I/@a.proto"]


def test_a_search_folder_holding_an_equals_sign_is_that_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``--proto_path=a=b`` maps the virtual folder ``a`` to the folder ``b`` when both exist."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "a=b").mkdir()
    (tmp_path / "b").mkdir()
    (tmp_path / "a=b" / "x.proto").write_text('syntax = "proto3";\nmessage InAB {}\n')
    (tmp_path / "b" / "x.proto").write_text('syntax = "proto3";\nmessage InB {}\n')
    (tmp_path / "main").mkdir()
    (tmp_path / "main" / "m.proto").write_text('syntax = "proto3";\nimport "x.proto";\n')
    compiled = compile_files(Path("a=b"), ["x.proto"])
    assert [m.name for m in compiled.file[-1].message_type] == ["InAB"]
    compiled = compile_files(Path("main"), ["m.proto"], [Path("a=b")])
    assert [m.name for file in compiled.file for m in file.message_type] == ["InAB"]


def test_a_search_folder_holding_a_colon_is_refused(tmp_path: Path) -> None:
    """protoc splits ``--proto_path=a:b`` into two folders, and has no way to quote one."""
    (tmp_path / "a:b").mkdir()
    (tmp_path / "a:b" / "x.proto").write_text(OK)
    with pytest.raises(FileError, match="a folder name holding ':', which protoc reads as a"):
        compile_files(tmp_path / "a:b", ["x.proto"])
    (tmp_path / "main").mkdir()
    (tmp_path / "main" / "m.proto").write_text(OK)
    with pytest.raises(FileError, match=r"a:b: a folder name holding ':'"):
        compile_files(tmp_path / "main", ["m.proto"], [tmp_path / "a:b"])


@pytest.mark.parametrize(
    ("name", "shown"),
    [("a\nb.proto", "a\\nb.proto"), ("\x1b[2J.proto", "\\x1b[2J.proto"), ("\t.proto", "\\t.proto")],
)
def test_a_name_with_a_control_character_is_refused_escaped(
    tmp_path: Path, name: str, shown: str
) -> None:
    """protoc prints names raw: a newline split its diagnostics into findings of their own."""
    (tmp_path / "proto").mkdir()
    (tmp_path / "proto" / name).write_text('syntax = "proto3";\nmessage B { int32 a = 1 }\n')
    (tmp_path / "proto" / "ok.proto").write_text(OK)
    done = erc_lint("check", "proto", cwd=tmp_path)
    assert done.returncode == 2, done
    assert done.stderr == (
        f"Error: proto/{shown}: a file name holding a control character: refused\n"
    )
    imports = tmp_path / "imports"
    imports.mkdir()
    (imports / "i.proto").write_text(
        f'syntax = "proto3";\nimport "{name.encode("unicode_escape").decode()}";\n'
    )
    os.link(tmp_path / "proto" / name, imports / name)
    with pytest.raises(FileError, match=f"{imports}/.*: a file name holding a control"):
        compile_files(imports, ["i.proto"])
