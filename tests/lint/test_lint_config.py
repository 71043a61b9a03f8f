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


@pytest.mark.parametrize(
    ("table", "line", "complaint"),
    [
        ('use = ["WIRE", "WIER"]\n', 3, "use names no rule or category 'WIER'"),
        ('except = ["FIELD_RENAMD"]\n', 3, "except names no rule or category 'FIELD_RENAMD'"),
        ('ignore = ["NANOPB"]\n', 3, "ignore names no rule 'NANOPB'"),  # rule IDs only
        ('use = "WIRE"\n', 3, "use must be a list of strings"),
        ("budget = { Env = 300 }\n", 3, "budget names 'Env', which is not one of the roots"),
        ("budget = { PBEnvelope = 0 }\n", 3, "must be a positive number of bytes"),
        ("budget = { PBEnvelope = true }\n", 3, "must be a positive number of bytes"),
        ("budget = 300\n", 3, "budget must be a table"),
        (
            'roots = ["PBEnvelope"]\nnanopb_version = "0.4"\n',
            4,
            "nanopb_version must be one of '0.4.9', '1.0.0-dev', not '0.4'",
        ),
        (
            'roots = ["acme.Env"]\nbudget = { acme.Env = 300 }\n',
            4,
            'quote a dotted root name ("acme.…" = bytes)',
        ),
    ],
)
def test_a_wrong_key_is_named_with_its_line(
    tmp_path: Path, table: str, line: int, complaint: str
) -> None:
    old = tree(tmp_path / "old", {"a.proto": "message A { float x = 1; }\n"})
    config = tmp_path / "pyproject.toml"
    config.write_text(f"# the table's keys start on line 3\n[tool.erc-lint]\n{table}")
    done = erc_lint_cli(str(old), str(old), "--config", str(config))
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1
    assert f"{config}:{line}: [tool.erc-lint] " in done.stderr
    assert complaint in done.stderr


RENAMED = {"a.proto": "message A { float x = 1; }\n"}


@pytest.mark.parametrize(
    ("config", "expected"),
    [
        (Config(), [("FIELD_RENAMED", "warning"), ("ENVELOPE_SIZE_GROWN", "warning")]),
        (  # WIRE_JSON: a JSON name change is an error
            Config(use=("WIRE_JSON", "NANOPB")),
            [("FIELD_RENAMED", "error"), ("ENVELOPE_SIZE_GROWN", "warning")],
        ),
        (Config(except_=("NANOPB",)), [("FIELD_RENAMED", "warning")]),
        (Config(use=("ENVELOPE_SIZE_GROWN",)), [("ENVELOPE_SIZE_GROWN", "warning")]),
        (Config(except_=("FIELD_RENAMED",)), [("ENVELOPE_SIZE_GROWN", "warning")]),
        (Config(ignore=frozenset({"FIELD_RENAMED"})), [("ENVELOPE_SIZE_GROWN", "warning")]),
        (Config(use=("WIRE_JSON",), except_=("WIRE",)), []),  # the JSON-only rules
    ],
    ids=["default", "wire-json", "except-category", "use-rule", "except-rule", "ignore", "json"],
)
def test_use_and_except_select_rules_and_categories(
    tmp_path: Path, config: Config, expected: list[tuple[str, str]]
) -> None:
    envelope = "message PBEnvelope {{ oneof p {{ A a = 1; }} }}\nmessage A {{ {} }}\n"
    old = tree(tmp_path / "old", {"a.proto": envelope.format("float x = 1;")})
    new = tree(tmp_path / "new", {"a.proto": envelope.format("float y = 1; float z = 2;")})
    found = erc_lint.lint(old, new, config)
    assert sorted((f.rule, f.severity) for f in found) == sorted(expected)


def test_rpc_rules_run_by_default_when_a_revision_declares_a_service(tmp_path: Path) -> None:
    text = "message A {{ float x = 1; }}\nmessage B {{ float y = 1; }}\n{}"
    service = "service S {{ rpc M({}) returns (A); }}\n"
    old = tree(tmp_path / "old", {"a.proto": text.format(service.format("A"))})
    new = tree(tmp_path / "new", {"a.proto": text.format(service.format("B"))})
    assert rules(erc_lint.lint(old, new)) == ["RPC_REQUEST_TYPE_CHANGED"]
    assert rules(erc_lint.lint(old, new, Config(use=("WIRE",)))) == []
    assert rules(erc_lint.lint(old, new, Config(except_=("RPC",)))) == []


def test_a_configuration_made_in_code_is_checked_too(tmp_path: Path) -> None:
    old = tree(tmp_path / "old", RENAMED)
    with pytest.raises(erc_lint.ConfigError, match="'WIER'"):
        erc_lint.lint(old, old, Config(use=("WIER",)))


BUDGET = {
    "env.proto": "message PBEnvelope { oneof p { S s = 1; } }\n"
    "message S { fixed64 a = 1; fixed64 b = 2; }\n",
}


def test_check_reports_a_root_over_its_budget_with_the_headroom(tmp_path: Path) -> None:
    root = tree(tmp_path / "t", BUDGET)  # PBEnvelope_size: 2 + 18 = 20
    (root / "pyproject.toml").write_text(
        '[tool.erc-lint]\nroots = ["PBEnvelope"]\nbudget = { PBEnvelope = 19 }\n'
    )
    done = erc_lint_cli("check", str(root))
    assert done.returncode == 1, done.stderr
    assert done.stdout.endswith(
        'ENVELOPE_OVER_BUDGET Maximum size of message "PBEnvelope" is 20 bytes, over its budget '
        "of 19 bytes: headroom -1 bytes.\n"
    )
    (root / "pyproject.toml").write_text("[tool.erc-lint]\nbudget = { PBEnvelope = 20 }\n")
    assert erc_lint_cli("check", str(root)).returncode == 0
    # Over budget in OLD already: old damage, a warning.
    old = tree(tmp_path / "old", BUDGET)
    (root / "pyproject.toml").write_text("[tool.erc-lint]\nbudget = { PBEnvelope = 12 }\n")
    diff = erc_lint_cli(str(old), str(root))
    assert diff.returncode == 0
    assert "ENVELOPE_OVER_BUDGET (warning)" in diff.stdout


def test_a_budget_for_a_root_the_tree_lacks_is_reported_at_its_line(tmp_path: Path) -> None:
    root = tree(tmp_path / "t", {"a.proto": "message A { float x = 1; }\n"})
    (root / "pyproject.toml").write_text("[tool.erc-lint]\n\nbudget = { PBEnvelope = 300 }\n")
    done = erc_lint_cli("check", str(root))
    assert done.returncode == 1
    assert done.stdout.startswith(f"{root / 'pyproject.toml'}:3:1: EMBEDDED_ROOT_MISSING")


@pytest.mark.parametrize(
    ("budget", "complaint"),
    [
        ({"Ghost": 5}, "Config: budget names 'Ghost', which is not one of the roots (PBEnvelope)"),
        ({"PBEnvelope": 0}, "Config: budget for 'PBEnvelope' must be a positive number of bytes"),
        ({"PBEnvelope": -5}, "Config: budget for 'PBEnvelope' must be a positive number of bytes"),
    ],
)
def test_a_config_built_in_code_is_checked_as_a_table_is(
    tmp_path: Path, budget: dict[str, int], complaint: str
) -> None:
    """The API refuses what ``[tool.erc-lint]`` refuses, in the same words: a budget for no
    root would check nothing, in silence."""
    root = tree(tmp_path / "t", {"a.proto": "message PBEnvelope { float x = 1; }\n"})
    config = Config(budget=budget)
    with pytest.raises(erc_lint.ConfigError) as raised:
        erc_lint.check(root, config)
    assert str(raised.value) == complaint
    with pytest.raises(erc_lint.ConfigError) as raised:
        erc_lint.lint(root, root, config)
    assert str(raised.value) == complaint


@pytest.mark.parametrize(
    "selection", ['use = ["WIRE"]', 'except = ["TREE"]', 'except = ["ENVELOPE_OVER_BUDGET"]']
)
def test_a_budget_whose_rule_is_left_out_is_a_warning_on_stderr(
    tmp_path: Path, selection: str
) -> None:
    """As ruff warns of settings that contradict each other: one line, and the run goes on."""
    root = tree(tmp_path / "t", BUDGET)  # PBEnvelope_size 20: over a budget of 12
    config = root / "pyproject.toml"
    config.write_text(f"[tool.erc-lint]\n{selection}\nbudget = {{ PBEnvelope = 12 }}\n")
    done = erc_lint_cli("check", str(root))
    assert done.returncode == 0, done.stdout
    assert done.stderr.splitlines()[0] == (
        f"{config}:3: warning: budget is set, but use/except leave out ENVELOPE_OVER_BUDGET: "
        "no budget is checked"
    )
    config.write_text("[tool.erc-lint]\nbudget = { PBEnvelope = 12 }\n")
    done = erc_lint_cli("check", str(root))
    assert done.returncode == 1
    assert "warning: budget" not in done.stderr
