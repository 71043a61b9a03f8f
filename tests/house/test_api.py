"""erc_codec's public face: ``erc_codec/__init__.py`` re-exports its names, one ``__all__``, each
documented in README.md; the command is reached by a public path."""

import ast
import re
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import REPO

import erc_codec
import erc_codec.cli

ROOMS = (erc_codec, erc_codec.codec, erc_codec.runtime, erc_codec.transport, erc_codec.capture)


def test_every_public_name_is_there_and_nothing_else_is_public() -> None:
    for room in ROOMS:
        assert all(hasattr(room, name) for name in room.__all__), room.__name__
        public = {name for name in vars(room) if not name.startswith("_")}
        modules = {name for name in public if type(getattr(room, name)) is type(erc_codec)}
        assert public - modules == set(room.__all__), room.__name__
    rooms = {"schema", "codec", "runtime", "transport", "capture", "strategies", "proton", "cli"}
    assert {n for n in vars(erc_codec) if type(getattr(erc_codec, n)) is type(erc_codec)} <= rooms


def test_each_name_is_its_own_modules_and_the_face_the_codec_rooms() -> None:
    """A room's names are the objects its modules define; the top level re-exports the codec
    room's and the errors, nothing else."""
    for room in ROOMS:
        for name in room.__all__:
            value = getattr(room, name)
            home = getattr(value, "__module__", "")
            if home.startswith("erc_codec."):
                assert vars(sys.modules[home])[name] is value, f"{room.__name__}.{name}"
    codec_names = set(erc_codec.codec.__all__)
    errors = {"CodecError", "DecodeError", "EncodeError", "SchemaError", "UnreadableKind"}
    room_only = {"in_form", "UnkeptFields", "MAX_UNKEPT_NUMBERS"}
    assert set(erc_codec.__all__) == codec_names - room_only | errors | {"encode", "decode"}


def test_every_public_name_is_in_the_readme() -> None:
    readme = (REPO / "README.md").read_text()
    missing = [
        f"{room.__name__}.{name}"
        for room in ROOMS
        for name in room.__all__
        if not re.search(rf"\b{name}\b", readme)
    ]
    assert missing == []


def test_the_command_is_reached_by_a_public_path() -> None:
    if sys.version_info >= (3, 11):
        import tomllib
    else:  # tomllib is tomli, joined to the standard library in 3.11
        import tomli as tomllib
    scripts = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["scripts"]
    module, _, name = scripts["erc-codec"].partition(":")
    assert not any(part.startswith("_") for part in module.split("."))
    assert getattr(erc_codec.cli, name) is erc_codec.cli.main
    assert erc_codec.cli.__all__ == ["main"]


def test_the_schema_layer_loads_without_the_codec() -> None:
    """``erc_schema``, what erc-lint stands on, imports nothing of ``erc_codec``."""
    script = "import sys, erc_schema, erc_schema.cli\nprint(sorted(sys.modules))"
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    loaded = set(ast.literal_eval(done.stdout))
    assert "erc_schema._protoc" in loaded
    assert {m for m in loaded if m.split(".")[0] == "erc_codec"} == set()


def test_erc_codec_schema_is_the_schema_layer() -> None:
    import erc_codec.schema
    import erc_schema

    assert erc_codec.schema.__all__ == erc_schema.__all__
    assert all(getattr(erc_codec.schema, n) is getattr(erc_schema, n) for n in erc_schema.__all__)


def test_a_moved_name_is_an_error_to_a_type_checker_and_says_where_at_run_time(
    tmp_path: Path,
) -> None:
    """The hint for 0.1.0's top-level names is for people at run time; mypy still reports them
    (and any misspelling) as missing, which a module ``__getattr__`` it could see would hide."""
    script = tmp_path / "old.py"
    script.write_text("import erc_codec\n\nerc_codec.Router\nerc_codec.Codecc\n")
    done = subprocess.run(
        [sys.executable, "-m", "mypy", "--strict", "--cache-dir", str(tmp_path / "cache"), script],
        capture_output=True,
        text=True,
        check=False,
        cwd=REPO,
    )
    assert done.returncode == 1, done.stdout
    assert 'Module has no attribute "Router"' in done.stdout
    assert 'Module has no attribute "Codecc"' in done.stdout
    with pytest.raises(AttributeError, match=r"erc_codec\.Router is erc_codec\.runtime\.Router"):
        erc_codec.Router  # type: ignore[attr-defined]  # noqa: B018


def test_no_name_is_listed_twice() -> None:
    for room in ROOMS:
        assert len(room.__all__) == len(set(room.__all__)), room.__name__
