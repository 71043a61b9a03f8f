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
    assert erc_codec.cli.__all__ == ["OneLineGroup", "generator_options", "main"]


def test_importing_the_cli_package_leaves_the_commands_unloaded() -> None:
    """erc-lint imports erc_codec.cli for its group; the commands load with ``main`` only."""
    script = "import sys, erc_codec.cli; print('erc_codec.cli._decode' in sys.modules)"
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert done.stdout.strip() == "False"


def test_the_schema_layer_loads_without_the_codec() -> None:
    """``erc_codec.schema`` runs the package first; the package loads a name's module on the
    name's first use, so the schema layer (all erc-lint takes of this package) costs itself and
    the errors alone (bench_lint's ratio to buf)."""
    script = (
        "import sys, erc_codec.schema\n"
        "print(sorted(m for m in sys.modules if m.startswith('erc_codec.')))"
    )
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    loaded = set(ast.literal_eval(done.stdout))
    assert "erc_codec.schema._protoc" in loaded
    assert {m for m in loaded if not m.startswith("erc_codec.schema")} == {"erc_codec._errors"}


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


def test_the_cli_package_lists_its_own_names_main_among_them() -> None:
    """``main`` loads on first use; ``dir`` shows it, and no import of the package's own."""
    done = subprocess.run(
        [sys.executable, "-c", "import erc_codec.cli as c; print(dir(c), callable(c.main))"],
        capture_output=True,
        text=True,
    )
    assert done.stdout == "['OneLineGroup', 'generator_options', 'main'] True\n", done.stderr
