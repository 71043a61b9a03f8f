"""nanopb's generator inputs wherever a user gives a schema: include folders (``-I``), the options
file (``-f``), generator settings (``-s``) and the generator version whose sizing rules apply
(``--nanopb-version``) on both command lines, in ``[tool.erc-codec]`` and ``[tool.erc-lint]``, and
through ``Codec.from_source``.

Sizes are held to nanopb's generator (PyPI ``nanopb``) run from the tree's root with the same
``-I``, ``-f`` and ``-s`` (``test_any_schema.generator_sizes``), and to a hand-computed number, so
that two "no size" answers never pass as equal. The tree is ``tests/any_trees/include``
(the version's, ``tests/nanopb_trees/pointers``, sized by hand in ``test_nanopb_rules``, which
holds the table to each version's generator):
``main/app.proto`` imports ``shared/units.proto``, found only under ``inc/``, whose options files
(``units.options``, ``units.nanopb``) sit beside it there.
"""

import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path
from types import MappingProxyType

import pytest
from conftest import TESTS
from git_support import Repo
from recording_support import need
from test_any_schema import INCLUDE, generator_sizes

import erc_codec
import erc_lint
from erc_codec import Codec, SchemaError
from erc_codec.codec._discovery import ENVIRONMENT, SchemaSource, find_schema
from erc_schema import NANOPB_VERSIONS

# One file for every .proto, for -f FILE (no %s): App's and Reading's options in one place.
ALL_OPTIONS = (
    "App.label max_size:12\nApp.counts max_count:2\nReading.unit max_size:4\n"
    "Reading.values max_count:1\n"
)
_OVER_BUDGET = re.compile(r'Maximum size of message "App" is (\d+) bytes')


@pytest.fixture(scope="module")
def nanopb() -> None:
    # The package, not its generator module: importing that sets PROTOCOL_BUFFERS_PYTHON_
    # IMPLEMENTATION=python in this worker, and every codec a later test starts would refuse it.
    need("nanopb")


@pytest.fixture
def tree(tmp_path: Path) -> Path:
    """A copy of the include tree (main/ and inc/) with all.options beside them."""
    shutil.copytree(INCLUDE, tmp_path / "t")
    (tmp_path / "t" / "all.options").write_text(ALL_OPTIONS)
    return tmp_path / "t"


def run(tool: str, *args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    """``erc-codec ARGS`` or ``erc-lint ARGS`` as a user runs it, with no schema in the
    environment."""
    environment = {k: v for k, v in os.environ.items() if k != ENVIRONMENT}
    return subprocess.run(
        [sys.executable, "-m", tool, *args],
        capture_output=True,
        text=True,
        cwd=cwd,
        env=environment,
    )


def codec_size(done: subprocess.CompletedProcess[str]) -> int | None:
    """App's size as ``erc-codec sizes --format json`` printed it."""
    assert done.returncode == 0, done.stderr
    size: int | None = json.loads(done.stdout)["messages"]["App"]
    return size


def lint_size(done: subprocess.CompletedProcess[str]) -> int:
    """App's size as erc-lint's ENVELOPE_OVER_BUDGET finding (budget 1 byte) says it."""
    found = _OVER_BUDGET.search(done.stdout)
    assert found is not None, done.stdout + done.stderr
    return int(found[1])


def budget(folder: Path, extra: str = "") -> None:
    """A ``[tool.erc-lint]`` in ``folder`` giving root App a budget of one byte."""
    table = f'[tool.erc-lint]\nroots = ["App"]\nbudget = {{ App = 1 }}\n{extra}'
    (folder / "pyproject.toml").write_text(table)


# (the generator's -f and -s, App's size by hand): units.options found on the include folder;
# -s settings; -f a pattern (app.nanopb beside app.proto, units.nanopb on the include folder);
# -f one file for every .proto.
CASES = [
    pytest.param([], None, id="include-folder-options"),
    pytest.param(["-s", "max_size=20", "-s", "max_count=3"], 74, id="settings"),
    pytest.param(["-f", "%s.nanopb", "-s", "max_count:3"], 69, id="options-file-pattern"),
    # reading (its unit 1 + 1 + 3, its one value 1 + 5 and 1 more), label 1 + 1 + 11, counts 2 * 6
    pytest.param(["-f", "../all.options"], (2 + 5 + 7) + 13 + 2 * 6, id="one-options-file"),
]


@pytest.mark.parametrize(("args", "expected"), CASES)
def test_erc_codec_sizes_with_include_options_and_settings_are_nanopbs(
    nanopb: None, tree: Path, tmp_path: Path, args: list[str], expected: int | None
) -> None:
    main = tree / "main"
    theirs = generator_sizes(tmp_path, main, ["app.proto"], "-I", ".", "-I", "../inc", *args)
    common = ["--proto", ".", "--root", "App", "-I", "../inc", "--format", "json"]
    done = run("erc_codec", "sizes", *common, *args, cwd=main)
    if expected is None:  # no size: a root the codec refuses, naming the field nanopb cannot size
        assert theirs["App"] is None
        assert done.returncode == 2
        assert "App.label: string field without nanopb max_size" in done.stderr
        return
    assert codec_size(done) == theirs["App"] == expected
    # given before the command, they hold for it
    before = run(
        "erc_codec",
        "-I",
        "../inc",
        *args,
        "sizes",
        "--proto",
        ".",
        "--root",
        "App",
        "--format",
        "json",
        cwd=main,
    )
    assert codec_size(before) == expected


# Without a setting App has no size, whether or not units.options is found: the sizes with one
# (Reading.unit 8 from units.options on the -I folder, not the setting's 20) tell.
@pytest.mark.parametrize(("args", "expected"), CASES[1:])
def test_erc_lint_sizes_with_include_options_and_settings_are_nanopbs(
    nanopb: None, tree: Path, tmp_path: Path, args: list[str], expected: int
) -> None:
    main = tree / "main"
    theirs = generator_sizes(tmp_path, main, ["app.proto"], "-I", ".", "-I", "../inc", *args)
    budget(main)
    done = run("erc_lint", "check", ".", "-I", "../inc", *args, cwd=main)
    assert done.returncode == 1  # the budget finding: an error
    assert lint_size(done) == theirs["App"] == expected


def test_the_configurations_give_include_options_file_and_settings(
    nanopb: None, tree: Path, tmp_path: Path
) -> None:
    main = tree / "main"
    args = ["-f", "%s.nanopb", "-s", "max_count:3"]
    theirs = generator_sizes(tmp_path, main, ["app.proto"], "-I", ".", "-I", "../inc", *args)
    generator = 'include = ["inc"]\noptions_file = "%s.nanopb"\nsettings = ["max_count=3"]\n'
    (tree / "pyproject.toml").write_text(
        f'[tool.erc-codec]\nproto = "main"\nroot = "App"\n{generator}'
    )
    assert codec_size(run("erc_codec", "sizes", "--format", "json", cwd=tree)) == theirs["App"]
    shown = json.loads(run("erc_codec", "schema", "--format", "json", cwd=tree).stdout)
    assert shown["include"] == [str(tree / "inc")]
    assert (shown["options_file"], shown["settings"]) == ("%s.nanopb", ["max_count=3"])
    assert shown["max_size"] == theirs["App"] == 69
    # the command line's replace the configuration's
    replaced = run("erc_codec", "sizes", "--format", "json", "-s", "max_count=2", cwd=tree)
    assert codec_size(replaced) == 69 - 6
    # erc-lint: the include folder relative to the configuration, beside the tree's protos
    budget(main, generator.replace('"inc"', '"../inc"'))
    assert lint_size(run("erc_lint", "check", "main", cwd=tree)) == theirs["App"]


def test_a_git_revisions_configuration_takes_its_folders_from_the_checkout(
    nanopb: None, tree: Path, tmp_path: Path
) -> None:
    repo = Repo(tree)
    budget(tree / "main", 'include = ["../inc"]\nsettings = ["max_size=20", "max_count=3"]\n')
    repo.git("add", "-A")
    repo.git("commit", "-q", "-m", "a tree, its include folder and its configuration")
    args = ["-I", ".", "-I", "../inc", "-s", "max_size=20", "-s", "max_count=3"]
    theirs = generator_sizes(tmp_path, tree / "main", ["app.proto"], *args)
    done = run("erc_lint", "check", f"{tree}#ref=main,subdir=main", cwd=tmp_path)
    assert lint_size(done) == theirs["App"] == 74


def test_the_ledger_update_takes_the_configurations_include_folders(tree: Path) -> None:
    budget(tree / "main", 'include = ["../inc"]\n')
    done = run("erc_lint", "ledger", "update", "main", cwd=tree)
    assert done.returncode == 0, done.stderr
    assert "does not compile" not in done.stderr
    assert "message App 1 reading Reading -" in (tree / "main" / "erc-lint.lock").read_text()


def test_one_options_file_in_a_configuration_is_relative_to_it(tree: Path) -> None:
    (tree / "pyproject.toml").write_text(
        '[tool.erc-codec]\nproto = "main"\nroot = "App"\ninclude = ["inc"]\n'
        'options_file = "all.options"\n'
    )
    source = find_schema(start=tree / "main", environ={})
    assert source.options_file == str(tree / "all.options")
    assert erc_codec.Codec.from_source(source).max_size("App") == 39


def test_from_source_keeps_the_options_file_and_the_settings() -> None:
    source = SchemaSource(
        str(INCLUDE / "main"),
        "App",
        (str(INCLUDE / "inc"),),
        "--proto",
        options_file="%s.nanopb",
        settings=("max_count:3",),
    )
    codec = erc_codec.Codec.from_source(source)
    assert codec.max_size("App") == 69
    assert codec.max_size("Reading") == (2 + 29) + 2 * (1 + 5)  # units.nanopb, on the -I folder


def test_one_options_file_found_nowhere_is_a_schema_error() -> None:
    settings = ["max_size:20", "max_count:3"]  # a size without any options file
    assert Codec.from_path(INCLUDE / "main", "App", [INCLUDE / "inc"], settings=settings)
    with pytest.raises(SchemaError, match=r"options file nope\.options: not found \(looked in "):
        Codec.from_path(
            INCLUDE / "main",
            "App",
            [INCLUDE / "inc"],
            options_file="nope.options",
            settings=settings,
        )


def test_given_inputs_replace_the_configurations(tmp_path: Path) -> None:
    (tmp_path / "pyproject.toml").write_text(
        '[tool.erc-codec]\nproto = "t"\ninclude = ["a"]\noptions_file = "%s.x"\n'
        'settings = ["max_size=3"]\n'
    )
    found = find_schema(start=tmp_path, environ={})
    assert (found.include, found.options_file, found.settings) == (
        (str(tmp_path / "a"),),
        "%s.x",
        ("max_size=3",),
    )
    given = find_schema(
        start=tmp_path, environ={}, include=["b"], options_file="%s.y", settings=["max_count=1"]
    )
    assert (given.include, given.options_file, given.settings) == (("b",), "%s.y", ("max_count=1",))
    kept = find_schema(start=tmp_path, environ={}, include=None, settings=None)
    assert kept == found
    assert find_schema("t", environ={}, settings=["max_count=1"]).settings == ("max_count=1",)


def test_the_lint_api_takes_the_inputs_in_its_configuration(nanopb: None, tmp_path: Path) -> None:
    main = INCLUDE / "main"
    args = ["-I", ".", "-I", "../inc", "-s", "max_size=20", "-s", "max_count=3"]
    theirs = generator_sizes(tmp_path, main, ["app.proto"], *args)
    config = erc_lint.Config(
        roots=("App",),
        budget=MappingProxyType({"App": 1}),
        include=(str(INCLUDE / "inc"),),
        settings=("max_size=20", "max_count=3"),
    )
    found = [f.message for f in erc_lint.check(main, config) if f.rule == "ENVELOPE_OVER_BUDGET"]
    assert found == [
        f'Maximum size of message "App" is {theirs["App"]} bytes, over its budget of 1 bytes: '
        f"headroom {1 - 74} bytes."
    ]


# -- the generator version whose sizing rules apply ---------------------------------------------

# Pointers (bounded FT_POINTER fields) has no size by 0.4.x's rules, 97 bytes by master's;
# HoldsPointers, which holds it, 99 (test_nanopb_rules sums them by hand).
POINTERS = TESTS / "nanopb_trees" / "pointers"
NEWER = NANOPB_VERSIONS[1]


@pytest.fixture
def pointers(tmp_path: Path) -> Path:
    shutil.copytree(POINTERS, tmp_path / "p")
    return tmp_path / "p"


def sizes_of(done: subprocess.CompletedProcess[str]) -> dict[str, int | None]:
    assert done.returncode == 0, done.stderr
    messages: dict[str, int | None] = json.loads(done.stdout)["messages"]
    return messages


def test_the_nanopb_version_flag_changes_erc_codec_sizes(pointers: Path) -> None:
    args = ["--proto", ".", "--root", "Leaf", "--format", "json"]
    default = sizes_of(run("erc_codec", "sizes", *args, cwd=pointers))
    assert (default["Pointers"], default["HoldsPointers"]) == (None, None)
    newer = sizes_of(run("erc_codec", "sizes", *args, "--nanopb-version", NEWER, cwd=pointers))
    assert (newer["Pointers"], newer["HoldsPointers"], newer["Leaf"]) == (97, 99, 11)
    assert sizes_of(
        run("erc_codec", "sizes", *args, "--nanopb-version", "0.4.9", cwd=pointers)
    ) == (default)
    # before the command too, as every schema option
    before = run("erc_codec", "--nanopb-version", NEWER, "sizes", *args, cwd=pointers)
    assert sizes_of(before) == newer
    text = run(
        "erc_codec",
        "sizes",
        "--proto",
        ".",
        "--root",
        "HoldsPointers",
        "--nanopb-version",
        NEWER,
        cwd=pointers,
    )
    assert text.returncode == 0, text.stderr
    assert "HoldsPointers_size 99" in text.stdout


def test_the_configurations_nanopb_version_sizes_and_schema_shows_it(pointers: Path) -> None:
    (pointers / "pyproject.toml").write_text(
        f'[tool.erc-codec]\nproto = "."\nroot = "Leaf"\nnanopb_version = "{NEWER}"\n'
    )
    assert sizes_of(run("erc_codec", "sizes", "--format", "json", cwd=pointers))["Pointers"] == 97
    shown = json.loads(run("erc_codec", "schema", "--format", "json", cwd=pointers).stdout)
    assert shown["nanopb_version"] == NEWER
    text = run("erc_codec", "schema", cwd=pointers).stdout
    assert f"nanopb   {NEWER} sizing rules" in text.splitlines()
    # the command line's replaces the configuration's
    given = run("erc_codec", "sizes", "--format", "json", "--nanopb-version", "0.4.9", cwd=pointers)
    assert sizes_of(given)["Pointers"] is None
    shown = json.loads(
        run(
            "erc_codec", "schema", "--format", "json", "--nanopb-version", "0.4.9", cwd=pointers
        ).stdout
    )
    assert shown["nanopb_version"] == "0.4.9"


def test_the_source_carries_the_nanopb_version_and_codec_default_keys_on_it(
    pointers: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    config = pointers / "pyproject.toml"
    config.write_text(f'[tool.erc-codec]\nproto = "."\nroot = "Leaf"\nnanopb_version = "{NEWER}"\n')
    found = find_schema(start=pointers, environ={})
    assert found.nanopb_version == NEWER
    assert find_schema(start=pointers, environ={}, nanopb_version="0.4.9").nanopb_version == "0.4.9"
    assert find_schema(start=pointers, environ={}, nanopb_version=None) == found
    assert find_schema("t", environ={}).nanopb_version == "0.4.9"
    assert Codec.from_source(found).nanopb.all()["Pointers"] == 97
    assert (
        Codec.from_source(found._replace(nanopb_version="0.4.9")).nanopb.all()["Pointers"] is None
    )
    monkeypatch.delenv(ENVIRONMENT, raising=False)
    monkeypatch.chdir(pointers)
    newer = Codec.default()
    assert (newer.nanopb.nanopb_version, newer.nanopb.all()["Pointers"]) == (NEWER, 97)
    # only the configuration changes (no .proto file): another source, another codec
    config.write_text('[tool.erc-codec]\nproto = "."\nroot = "Leaf"\nnanopb_version = "0.4.9"\n')
    older = Codec.default()
    assert (older.nanopb.nanopb_version, older.nanopb.all()["Pointers"]) == ("0.4.9", None)


BUDGETED = '[tool.erc-lint]\nroots = ["HoldsPointers"]\nbudget = { HoldsPointers = 50 }\n'
NO_SIZE = 'Message "HoldsPointers" has no fixed size: its budget of 50 bytes cannot hold'
OVER = 'Maximum size of message "HoldsPointers" is 99 bytes, over its budget of 50 bytes'


def budget_finding(done: subprocess.CompletedProcess[str]) -> str:
    assert done.returncode == 1, done.stderr  # the budget finding: an error
    found = [line for line in done.stdout.splitlines() if "ENVELOPE_OVER_BUDGET" in line]
    assert len(found) == 1, done.stdout
    return found[0]


def test_erc_lint_sizes_follow_the_nanopb_version_flag_and_key(pointers: Path) -> None:
    (pointers / "pyproject.toml").write_text(BUDGETED)
    assert NO_SIZE in budget_finding(run("erc_lint", "check", ".", cwd=pointers))
    flagged = run("erc_lint", "check", ".", "--nanopb-version", NEWER, cwd=pointers)
    assert OVER in budget_finding(flagged)
    (pointers / "pyproject.toml").write_text(BUDGETED + f'nanopb_version = "{NEWER}"\n')
    assert OVER in budget_finding(run("erc_lint", "check", ".", cwd=pointers))
    # the command line's replaces the configuration's
    given = run("erc_lint", "check", ".", "--nanopb-version", "0.4.9", cwd=pointers)
    assert NO_SIZE in budget_finding(given)


def test_erc_lint_diff_sees_a_size_grow_only_by_the_rules_that_size_it(
    pointers: Path, tmp_path: Path
) -> None:
    new = tmp_path / "new"
    shutil.copytree(pointers, new)
    proto = new / "pointers.proto"
    proto.write_text(proto.read_text().replace("uint32 plain = 8;", "uint64 plain = 8;"))
    (new / "pyproject.toml").write_text('[tool.erc-lint]\nroots = ["HoldsPointers"]\n')
    grown = 'Maximum size of message "HoldsPointers" grew from 99 to 104 bytes'
    older = run("erc_lint", str(pointers), str(new), cwd=tmp_path)
    assert "ENVELOPE_SIZE_GROWN" not in older.stdout, older.stdout + older.stderr
    newer = run("erc_lint", str(pointers), str(new), "--nanopb-version", NEWER, cwd=tmp_path)
    assert grown in newer.stdout, newer.stdout + newer.stderr


def test_the_lint_api_takes_the_nanopb_version_in_its_configuration() -> None:
    config = erc_lint.Config(
        roots=("HoldsPointers",), budget=MappingProxyType({"HoldsPointers": 50})
    )
    by_version = {
        version: [
            f.message
            for f in erc_lint.check(POINTERS, config._replace(nanopb_version=version))
            if f.rule == "ENVELOPE_OVER_BUDGET"
        ]
        for version in NANOPB_VERSIONS
    }
    assert [NO_SIZE in m for m in by_version["0.4.9"]] == [True]
    assert [OVER in m for m in by_version[NEWER]] == [True]
    with pytest.raises(
        erc_lint.ConfigError, match=r"nanopb_version '0\.5'.*0\.4\.9 and 1\.0\.0-dev"
    ):
        erc_lint.check(POINTERS, config._replace(nanopb_version="0.5"))


# -- what cannot be used: one line, exit status 2 --------------------------------------------

CODEC = ["sizes", "--proto", "main", "--root", "App", "-I", "inc"]
LINT = ["check", "main", "-I", "inc"]


@pytest.mark.parametrize(
    ("tool", "args", "complaint"),
    [
        ("erc_codec", [*CODEC, "-I", "nowhere"], "Directory 'nowhere' does not exist"),
        ("erc_codec", [*CODEC, "-f", "missing.options"], "options file missing.options: not found"),
        ("erc_codec", [*CODEC, "-s", "max_size"], "generator setting 'max_size'"),
        ("erc_codec", [*CODEC, "-s", "max_size=lots"], "generator setting 'max_size=lots'"),
        ("erc_codec", [*CODEC, "-s", "no_such=1"], 'has no field named "no_such"'),
        ("erc_lint", [*LINT, "-f", "missing.options"], "options file missing.options: not found"),
        ("erc_lint", [*LINT, "-s", "max_size"], "generator setting 'max_size'"),
        ("erc_lint", [*LINT, "-s", "no_such:1"], 'has no field named "no_such"'),
        ("erc_codec", [*CODEC, "--nanopb-version", "0.5"], "'0.5' is not one of '0.4.9', "),
        ("erc_lint", [*LINT, "--nanopb-version", "0.5"], "'0.5' is not one of '0.4.9', "),
    ],
)
def test_a_bad_generator_input_is_one_line_and_exit_2(
    tree: Path, tool: str, args: list[str], complaint: str
) -> None:
    done = run(tool, *args, cwd=tree)
    assert done.returncode == 2, done.stdout + done.stderr
    assert done.stderr.count("\n") == 1, done.stderr
    assert complaint in done.stderr
    assert "Traceback" not in done.stderr


VERSIONS_NOT = "nanopb_version must be one of '0.4.9', '1.0.0-dev', not "


@pytest.mark.parametrize(
    ("tool", "table", "complaint"),
    [
        ("erc-codec", 'options_file = "missing.options"', "options file missing.options"),
        ("erc-codec", 'settings = ["max_size"]', "generator setting 'max_size'"),
        ("erc-codec", "settings = [61]", "settings must be a list of generator settings"),
        ("erc-lint", 'include = ["nowhere"]', "nowhere is not a folder"),
        ("erc-lint", 'options_file = "missing.options"', "options file missing.options"),
        ("erc-lint", 'settings = ["max_size"]', "generator setting 'max_size'"),
        ("erc-lint", "settings = [61]", "settings must be a list of strings"),
        ("erc-codec", 'nanopb_version = "0.5"', VERSIONS_NOT + "'0.5'"),
        ("erc-codec", "nanopb_version = 1", VERSIONS_NOT + "1"),
        ("erc-lint", 'nanopb_version = "1.0"', VERSIONS_NOT + "'1.0'"),
        ("erc-lint", 'nanopb_version = ["0.4.9"]', VERSIONS_NOT + "['0.4.9']"),
    ],
)
def test_a_bad_generator_input_in_a_configuration_is_one_line_and_exit_2(
    tree: Path, tool: str, table: str, complaint: str
) -> None:
    if tool == "erc-codec":
        (tree / "pyproject.toml").write_text(
            f'[tool.erc-codec]\nproto = "main"\nroot = "App"\ninclude = ["inc"]\n{table}\n'
        )
        done = run("erc_codec", "sizes", cwd=tree)
    else:
        budget(tree / "main", table + "\n")
        done = run("erc_lint", "check", "main", "-I", "inc", cwd=tree)
    assert done.returncode == 2, done.stdout + done.stderr
    assert done.stderr.count("\n") == 1, done.stderr
    assert complaint in done.stderr
    assert "Traceback" not in done.stderr
