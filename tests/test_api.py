"""erc_codec's public face: ``erc_codec/__init__.py`` re-exports its names, one ``__all__``, each
documented in README.md; the command is reached by a public path."""

import re
import subprocess
import sys

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
