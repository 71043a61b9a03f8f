"""erc_lint's configuration: [tool.erc-lint] in NEW's tree, the working directory or
--config; a configuration that cannot be read stops the run in one line."""

from pathlib import Path

import pytest
from lint_support import erc_lint_cli, rules, tree

import erc_lint
from erc_lint import Config


def test_configuration_in_new_tree(tmp_path: Path) -> None:
    old = tree(tmp_path / "old", {"a.proto": "message A { float x = 1; }\n"})
    new = tree(
        tmp_path / "new",
        {
            "a.proto": "message A { float y = 1; }\n",
            "drafts/broken.proto": "message Broken { Nope x = 1; }\n",
        },
    )
    assert set(rules(erc_lint.lint(old, new))) == {"FIELD_RENAMED", "COMPILE"}
    (new / "pyproject.toml").write_text(
        '[tool.erc-lint]\nignore = ["FIELD_RENAMED"]\nexclude = ["drafts/*"]\n'
    )
    done = erc_lint_cli(str(old), str(new))
    assert (done.returncode, done.stdout) == (0, "")
    bad = tmp_path / "bad.toml"
    bad.write_text('[tool.erc-lint]\nignore = ["NO_SUCH_RULE"]\n')
    refused = erc_lint_cli(str(old), str(new), "--config", str(bad))
    assert refused.returncode == 2
    assert "NO_SUCH_RULE" in refused.stderr


def test_roots_come_from_configuration(tmp_path: Path) -> None:
    files = {
        "env.proto": "message Item { repeated int32 values = 1; }\n"
        "message Env { oneof payload { Item item = 1; } }\n"
    }
    old = tree(tmp_path / "old", {"env.proto": "message Item { int32 value = 1; }\n"})
    new = tree(tmp_path / "new", files)
    assert "EMBEDDED_REPEATED" not in rules(erc_lint.lint(old, new))
    found = erc_lint.lint(old, new, Config(roots=("Env",)))
    (repeated,) = [f for f in found if f.rule == "EMBEDDED_REPEATED"]
    assert "Env.item.values" in repeated.message


@pytest.mark.parametrize(
    ("setup", "complaint"),
    [
        ("empty", "no .proto file in NEW"),
        ("tool = 1\n", ""),
        ("[tool]\nerc-lint = 5\n", "tool.erc-lint must be a table"),
        ("[tool.other]\nx = 1\n", "no [tool.erc-lint] table"),
    ],
)
def test_what_cannot_run_exits_2_in_one_line(tmp_path: Path, setup: str, complaint: str) -> None:
    old = tree(tmp_path / "old", {"a.proto": "message A { float x = 1; }\n"})
    new = tmp_path / "new"
    if setup == "empty":
        new.mkdir()
        done = erc_lint_cli(str(old), str(new))
    else:
        tree(new, {"a.proto": "message A { float x = 1; }\n"})
        config = tmp_path / "config.toml"
        config.write_text(setup)
        done = erc_lint_cli(str(old), str(new), "--config", str(config))
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1
    assert complaint in done.stderr
    assert "Traceback" not in done.stderr
