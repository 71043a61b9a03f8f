"""erc_lint's public face: ``erc_lint/__init__.py`` imports its names directly, one ``__all__``."""

import ast
import subprocess
import sys

import erc_lint


def test_every_public_name_is_there_and_nothing_else_is_public() -> None:
    assert all(hasattr(erc_lint, name) for name in erc_lint.__all__)
    public = {name for name in vars(erc_lint) if not name.startswith("_")}
    assert public - set(erc_lint.__all__) <= {"cli", "rules"}  # its subpackages


def test_importing_the_package_leaves_the_ledger_unloaded() -> None:
    """The ledger's and the history walker's modules load with a ledger, never with the package:
    its errors live apart (``_errors``), so no name needs loading on first use."""
    script = (
        "import sys\nbefore = set(sys.modules)\nimport erc_lint\n"
        "print(sorted(m for m in set(sys.modules) - before if m.startswith('erc_lint')))"
    )
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, check=True
    )
    loaded = set(ast.literal_eval(done.stdout))
    assert "erc_lint._run" in loaded
    assert not loaded & {"erc_lint._ledger", "erc_lint._history", "erc_lint.cli"}
