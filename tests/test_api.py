"""erc_codec's public face: ``erc_codec/__init__.py`` re-exports its names, one ``__all__``, each
documented in README.md; the command is reached by a public path."""

import ast
import re
import subprocess
import sys
from pathlib import Path

from conftest import REPO

import erc_codec
import erc_codec.cli


def test_every_public_name_is_there_and_nothing_else_is_public() -> None:
    assert all(hasattr(erc_codec, name) for name in erc_codec.__all__)
    public = {name for name in vars(erc_codec) if not name.startswith("_")}
    assert public - set(erc_codec.__all__) <= {"schema", "strategies", "proton", "cli"}


def test_every_public_name_is_in_the_readme() -> None:
    readme = (REPO / "README.md").read_text()
    missing = [name for name in erc_codec.__all__ if not re.search(rf"\b{name}\b", readme)]
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


def test_a_name_loaded_on_first_use_is_its_modules_own() -> None:
    """A name reached through the package (``from erc_codec import *``, an attribute) is the
    object its module defines, and ``dir`` lists it before its first use."""
    script = (
        "import sys, erc_codec\n"
        "listed = set(dir(erc_codec))\n"
        "from erc_codec import *\n"
        "def own(n, x):  # a class or function of a module of ours is that module's\n"
        "    home = getattr(x, '__module__', '')\n"
        "    return not home.startswith('erc_codec.') or vars(sys.modules[home])[n] is x\n"
        "ok = [n for n in erc_codec.__all__\n"
        "      if getattr(erc_codec, n) is globals()[n] and own(n, globals()[n])]\n"
        "print(sorted(set(erc_codec.__all__) - set(ok)), sorted(set(erc_codec.__all__) - listed))"
    )
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert done.stdout.split() == ["[]", "[]"], done.stderr


def test_the_names_loaded_on_first_use_are_typed_from_their_own_modules() -> None:
    """The table of name -> module the package loads from and the ``TYPE_CHECKING`` imports that
    type checkers read say the same, and with the names imported at once make ``__all__``."""
    source = (Path(erc_codec.__file__).parent / "__init__.py").read_text()
    typed: dict[str, str] = {}
    table: dict[str, str] = {}
    for node in ast.parse(source).body:
        if isinstance(node, ast.If) and ast.unparse(node.test) == "_TYPE_CHECKING":
            for item in node.body:
                assert isinstance(item, ast.ImportFrom)
                assert item.level == 1
                assert item.module
                typed.update((alias.name, item.module) for alias in item.names)
        if isinstance(node, ast.Assign) and ast.unparse(node.targets[0]) == "_LAZY":
            table = ast.literal_eval(node.value)
    assert typed == table
    eager = {"CodecError", "DecodeError", "EncodeError", "SchemaError", "decode", "encode"}
    assert set(erc_codec.__all__) == set(table) | eager
