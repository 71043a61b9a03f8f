"""Schema discovery, the same for every command and for ``Codec.default()``: ``--proto TREE`` >
``ERC_CODEC_PROTO`` > ``[tool.erc-codec]`` in the nearest pyproject.toml from the working folder
up > the packaged schema; a tree may be a git revision, read without a checkout."""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import PROTO
from git_support import Repo

import erc_codec
from erc_codec.codec._discovery import ENVIRONMENT, SchemaSource, find_schema, packaged_tree


def run(
    *args: str, cwd: Path, env: dict[str, str] | None = None
) -> subprocess.CompletedProcess[str]:
    environment = {k: v for k, v in os.environ.items() if k != ENVIRONMENT}
    return subprocess.run(
        [sys.executable, "-m", "erc_codec", *args],
        capture_output=True,
        text=True,
        check=False,
        cwd=cwd,
        env={**environment, **(env or {})},
    )


def configured(folder: Path, table: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "pyproject.toml").write_text(f"[project]\nname = 'x'\n\n[tool.erc-codec]\n{table}\n")
    return folder


def test_the_order_is_proto_then_environment_then_pyproject_then_packaged(tmp_path: Path) -> None:
    project = configured(tmp_path / "p", 'proto = "tree"\nroot = "Envelope"\ninclude = ["extra"]')
    below = project / "a" / "b"
    below.mkdir(parents=True)
    nothing: dict[str, str] = {}
    assert find_schema(start=below, environ=nothing) == SchemaSource(
        str(project / "tree"),
        "Envelope",
        (str(project / "extra"),),
        str(project / "pyproject.toml"),
    )
    assert find_schema(start=below, environ={ENVIRONMENT: "env"}) == SchemaSource(
        "env", "PBEnvelope", (), ENVIRONMENT
    )
    assert find_schema("given", start=below, environ={ENVIRONMENT: "env"}) == SchemaSource(
        "given", "PBEnvelope", (), "--proto"
    )
    assert find_schema(root="Other", start=below, environ=nothing).root == "Other"
    assert find_schema(start=tmp_path, environ=nothing) == SchemaSource(
        str(packaged_tree()), "PBEnvelope", (), "packaged"
    )


def test_a_pyproject_without_the_table_is_passed_by(tmp_path: Path) -> None:
    project = configured(tmp_path, 'proto = "tree"')
    inner = project / "inner"
    inner.mkdir()
    (inner / "pyproject.toml").write_text("[project]\nname = 'inner'\n")
    assert find_schema(start=inner, environ={}).origin == str(project / "pyproject.toml")


def test_a_git_revision_in_the_configuration_is_relative_to_it(tmp_path: Path) -> None:
    project = configured(tmp_path, 'proto = "repo#ref=main,subdir=proto"')
    assert (
        find_schema(start=project, environ={}).tree == f"{project / 'repo'}#ref=main,subdir=proto"
    )


@pytest.mark.parametrize(
    ("table", "problem"),
    [
        ('proto = ""', "proto must be a tree"),
        ("proto = 3", "proto must be a tree"),
        ('proto = "t"\nroot = 5', "root must be a message name"),
        ('proto = "t"\ninclude = "x"', "include must be a list of folders"),
        ('proto = "t"\nprotos = "x"', "has no key 'protos'"),
        ('proto = "t', "pyproject.toml: "),
    ],
)
def test_a_bad_configuration_is_a_schema_error_naming_the_file(
    tmp_path: Path, table: str, problem: str
) -> None:
    configured(tmp_path, table)
    with pytest.raises(erc_codec.SchemaError, match=problem) as raised:
        find_schema(start=tmp_path, environ={})
    assert str(tmp_path / "pyproject.toml") in str(raised.value)
    done = run("sizes", cwd=tmp_path)
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1
    assert problem in done.stderr


def test_sizes_reports_305_with_the_fleet_tree_in_pyproject(tmp_path: Path, fleet: Path) -> None:
    shutil.copytree(fleet, tmp_path / "ERC-Protobufs")
    configured(tmp_path, 'proto = "ERC-Protobufs"')
    (tmp_path / "tools").mkdir()
    done = run("sizes", cwd=tmp_path / "tools")
    assert done.returncode == 0, done.stderr
    assert "PBEnvelope_size 305" in done.stdout
    assert "manual_arm_velocity" in done.stdout
    shown = run("schema", "--format", "json", cwd=tmp_path / "tools")
    document = json.loads(shown.stdout)
    assert document["origin"] == str(tmp_path / "pyproject.toml")
    assert (document["members"], document["max_size"]) == (26, 305)
    # and the packaged one where no configuration is found
    source = SchemaSource(str(packaged_tree()), "PBEnvelope", (), "packaged")
    packaged = erc_codec.Codec.from_source(source)  # whatever size the packaged schema has
    expected = f"PBEnvelope_size {packaged.max_size(packaged.root)}"
    assert expected in run("sizes", cwd=tmp_path.parent).stdout


def test_the_environment_variable_names_the_tree(tmp_path: Path, fleet: Path) -> None:
    done = run("sizes", cwd=tmp_path, env={ENVIRONMENT: str(fleet)})
    assert "PBEnvelope_size 305" in done.stdout
    text = run("schema", cwd=tmp_path, env={ENVIRONMENT: str(fleet)}).stdout
    assert f"from the environment variable {ENVIRONMENT}" in text
    assert "26 members, PBEnvelope_size 305" in text


def test_codec_default_finds_the_configured_schema(tmp_path: Path, fleet: Path) -> None:
    configured(tmp_path, f'proto = "{fleet}"')
    script = "import erc_codec; c = erc_codec.Codec.default(); print(c.max_size(c.root))"
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, cwd=tmp_path, check=True
    )
    assert done.stdout.strip() == "305"


def test_a_git_revision_decodes_without_a_checkout(tmp_path: Path) -> None:
    repo = Repo(tmp_path / "repo")
    shutil.copytree(PROTO / "components", repo.root / "proto" / "components")
    first = repo.commit("the packaged tree")
    shutil.rmtree(repo.root / "proto")  # the working tree no longer holds it
    repo.commit("removed")
    spec = repo.spec(first)
    done = run("--proto", spec, "decode", "620b09d8817346941e4a404802", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["message"]["latitude"] == 52.2389
    shown = run("schema", "--proto", spec, cwd=tmp_path).stdout
    assert f"at commit {first}" in shown
    missing = run("sizes", "--proto", repo.spec("nosuchref"), cwd=tmp_path)
    assert missing.returncode == 2
    assert missing.stderr.count("\n") == 1


def test_a_folder_inside_the_import_root_is_a_one_line_hint(tmp_path: Path) -> None:
    done = run("sizes", "--proto", str(PROTO / "components"), cwd=tmp_path)
    assert done.returncode == 2
    assert done.stderr == (
        f"Error: {PROTO / 'components'}: its files import each other as components/..., so "
        f"the import root is the folder above it: give {PROTO} (root PBEnvelope)\n"
    )


def test_a_folder_above_the_import_root_is_a_one_line_hint(tmp_path: Path) -> None:
    """--proto X, the tree in X/vendor/ERC-Protobufs importing ERC-Protobufs/...: protoc's lines."""
    tree = tmp_path / "X" / "vendor" / "ERC-Protobufs"
    tree.mkdir(parents=True)
    (tree / "b.proto").write_text('syntax = "proto3";\nmessage Ping { uint32 s = 1; }\n')
    (tree / "a.proto").write_text(
        'syntax = "proto3";\nimport "ERC-Protobufs/b.proto";\n'
        "message Env { oneof payload { Ping ping = 1; } }\n"
    )
    done = run("sizes", "--proto", "X", "--root", "Env", cwd=tmp_path)
    assert done.returncode == 2
    assert done.stderr == (
        "Error: X: its files import each other as ERC-Protobufs/..., so the import root is the "
        f"folder above {Path('vendor', 'ERC-Protobufs')}: give {Path('X', 'vendor')} (root Env)\n"
    )
    assert run("sizes", "--proto", "X/vendor", "--root", "Env", cwd=tmp_path).returncode == 0


def test_a_folder_holding_the_tree_in_a_subfolder_is_a_one_line_hint(tmp_path: Path) -> None:
    """--proto X, the team's tree in X/ERC-Protobufs (components/*/*.proto, importing
    components/...): no folder holds a file directly where the imports begin, and protoc's
    every line (about 5,000 characters) came out instead of the hint."""
    shutil.copytree(PROTO / "components", tmp_path / "X" / "ERC-Protobufs" / "components")
    done = run("sizes", "--proto", "X", cwd=tmp_path)
    assert done.returncode == 2
    assert done.stderr == (
        "Error: X: its files import each other as components/..., so the import root is the "
        f"folder above {Path('ERC-Protobufs', 'components')}: give {Path('X', 'ERC-Protobufs')} "
        "(root PBEnvelope)\n"
    )
    assert run("sizes", "--proto", "X/ERC-Protobufs", cwd=tmp_path).returncode == 0


def test_a_git_revision_inside_the_import_root_gets_the_git_spelling(tmp_path: Path) -> None:
    """--proto 'REPO#ref=main,subdir=proto/components': the hint is a git spelling to give."""
    repo = Repo(tmp_path / "repo")
    shutil.copytree(PROTO / "components", repo.root / "proto" / "components")
    repo.commit("the packaged tree")
    shutil.rmtree(repo.root / "proto")  # only the commit holds it: no folder to point at
    given = f"{repo.root}#ref=main,subdir=proto/components"
    done = run("sizes", "--proto", given, cwd=tmp_path)
    assert done.returncode == 2
    assert done.stderr == (
        f"Error: {given}: its files import each other as components/..., so the import root "
        f"is the folder above it: give {repo.root}#ref=main,subdir=proto (root PBEnvelope)\n"
    )
    fixed = run("sizes", "--proto", f"{repo.root}#ref=main,subdir=proto", cwd=tmp_path)
    assert fixed.returncode == 0, fixed.stderr


def test_a_git_revision_above_the_import_root_gets_the_git_spelling(tmp_path: Path) -> None:
    """--proto 'REPO#ref=main', the tree in REPO/vendor/ERC-Protobufs: a subdir= to add."""
    repo = Repo(tmp_path / "repo")
    tree = repo.root / "vendor" / "ERC-Protobufs"
    tree.mkdir(parents=True)
    (tree / "b.proto").write_text('syntax = "proto3";\nmessage Ping { uint32 s = 1; }\n')
    (tree / "a.proto").write_text(
        'syntax = "proto3";\nimport "ERC-Protobufs/b.proto";\n'
        "message Env { oneof payload { Ping ping = 1; } }\n"
    )
    repo.commit("vendored")
    done = run("sizes", "--proto", f"{repo.root}#ref=HEAD", "--root", "Env", cwd=tmp_path)
    assert done.returncode == 2
    assert done.stderr == (
        f"Error: {repo.root}#ref=HEAD: its files import each other as ERC-Protobufs/..., so "
        f"the import root is the folder above {Path('vendor', 'ERC-Protobufs')}: give "
        f"{repo.root}#ref=HEAD,subdir=vendor (root Env)\n"
    )
    fixed = f"{repo.root}#ref=HEAD,subdir=vendor"
    assert run("sizes", "--proto", fixed, "--root", "Env", cwd=tmp_path).returncode == 0


def test_include_folders_from_the_configuration_are_searched(tmp_path: Path) -> None:
    (tmp_path / "tree").mkdir()
    (tmp_path / "shared").mkdir()
    (tmp_path / "shared" / "common.proto").write_text(
        'syntax = "proto3";\nmessage Ping { uint32 sequence = 1; }\n'
    )
    (tmp_path / "tree" / "envelope.proto").write_text(
        'syntax = "proto3";\nimport "common.proto";\n'
        "message Envelope { oneof payload { Ping ping = 1; } }\n"
    )
    configured(tmp_path, 'proto = "tree"\nroot = "Envelope"\ninclude = ["shared"]')
    source = find_schema(start=tmp_path, environ={})
    codec = erc_codec.Codec.from_source(source)
    assert codec.root == "Envelope"
    assert codec.kinds() == {1: "ping"}
    assert codec.max_size("Envelope") == 8
    assert [m.full_name for m in codec.schema.messages()] == ["Envelope"]  # the tree's own


def test_codec_default_sees_a_new_commit_on_a_moving_ref(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    repo = Repo(tmp_path / "repo")
    ping = "message Ping { uint32 s = 1; }\n"
    first = repo.commit("one", envelope=ping + "message PBEnvelope { oneof p { Ping ping = 1; } }")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv(ENVIRONMENT, repo.spec("main"))
    codec = erc_codec.Codec.default()
    assert codec.kinds() == {1: "ping"}
    assert erc_codec.Codec.default() is codec  # nothing moved: the loaded one
    repo.commit(
        "two", envelope=ping + "message PBEnvelope { oneof p { Ping ping = 1; Ping pong = 2; } }"
    )
    assert erc_codec.Codec.default().kinds() == {1: "ping", 2: "pong"}
    monkeypatch.setenv(ENVIRONMENT, repo.spec("HEAD"))
    assert erc_codec.Codec.default().kinds() == {1: "ping", 2: "pong"}
    monkeypatch.setenv(ENVIRONMENT, repo.spec(first))  # the same commit, spelled by its id
    assert erc_codec.Codec.default() is codec


def test_codec_default_sees_an_edited_folder_and_configuration(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv(ENVIRONMENT, raising=False)
    for name in ("one", "two"):
        (tmp_path / name).mkdir()
        (tmp_path / name / "envelope.proto").write_text(
            'syntax = "proto3";\nmessage Ping { uint32 s = 1; }\n'
            f"message Env {{ oneof p {{ Ping {name} = 1; }} }}\n"
        )
    configured(tmp_path, 'proto = "one"\nroot = "Env"')
    monkeypatch.chdir(tmp_path)
    codec = erc_codec.Codec.default()
    assert codec.kinds() == {1: "one"}
    assert erc_codec.Codec.default() is codec
    (tmp_path / "one" / "envelope.proto").write_text(
        'syntax = "proto3";\nmessage Ping { uint32 s = 1; }\n'
        "message Env { oneof p { Ping one = 1; Ping added = 2; } }\n"
    )
    assert erc_codec.Codec.default().kinds() == {1: "one", 2: "added"}
    assert erc_codec.Codec.default().max_size("Ping") == 6
    (tmp_path / "one" / "envelope.options").write_text("Ping.s int_size:IS_8\n")
    assert erc_codec.Codec.default().max_size("Ping") == 3  # a tag, 255 in two bytes
    configured(tmp_path, 'proto = "two"\nroot = "Env"')  # the configuration edited
    assert erc_codec.Codec.default().kinds() == {1: "two"}


def test_codec_default_sees_an_edited_include_folder_beside_a_git_revision(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv(ENVIRONMENT, raising=False)
    repo = Repo(tmp_path / "repo")
    repo.commit(
        "one", envelope='import "common.proto";\nmessage Env { oneof p { Ping ping = 1; } }'
    )
    shared = tmp_path / "shared"
    shared.mkdir()
    (shared / "common.proto").write_text('syntax = "proto3";\nmessage Ping { uint32 s = 1; }\n')
    configured(tmp_path, 'proto = "repo#ref=HEAD,subdir=proto"\nroot = "Env"\ninclude = ["shared"]')
    monkeypatch.chdir(tmp_path)
    assert erc_codec.Codec.default().max_size("Ping") == 6
    (shared / "common.proto").write_text(
        'syntax = "proto3";\nmessage Ping { uint32 s = 1; uint32 t = 2; }\n'
    )
    assert erc_codec.Codec.default().max_size("Ping") == 12


def test_the_packaged_codec_stays_the_same_whatever_else_is_loaded(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Its message classes are the same objects all along: a module's ``Codec.default()``
    classes work with a later ``Codec.default()``, after other schemas filled the cache."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv(ENVIRONMENT, raising=False)
    packaged = erc_codec.Codec.default()
    assert packaged.schema.root.full_name == "PBEnvelope"
    for k in range(10):  # more than the eight other schemas kept
        folder = tmp_path / f"tree{k}"
        folder.mkdir()
        (folder / "envelope.proto").write_text(
            f'syntax = "proto3";\nmessage Ping {{ uint32 s = 1; }}\n'
            f"message PBEnvelope {{ oneof p {{ Ping ping{k} = 1; }} }}\n"
        )
        monkeypatch.setenv(ENVIRONMENT, str(folder))
        assert erc_codec.Codec.default().kinds() == {1: f"ping{k}"}
    monkeypatch.delenv(ENVIRONMENT)
    assert erc_codec.Codec.default() is packaged
