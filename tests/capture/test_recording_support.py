"""The recording tests without their tools: the libraries of the test extra hidden from import and
tshark from PATH, the real test modules run in a pytest of their own. Under ERC_REQUIRE_INTEROP=1
(CI) every test that needs a missing tool fails, saying which; without it, the same tests skip,
saying why; the tests that need none pass either way."""

import os
import subprocess
import sys
import xml.etree.ElementTree as ElementTree
from pathlib import Path

import pytest
from conftest import REPO

MODULES = [
    "tests/capture/test_mcap.py",
    "tests/cli/test_cli_record.py",
    "tests/capture/test_foxglove.py",
]
MODULES += ["tests/capture/test_wireshark.py"]
HIDDEN = ["mcap", "mcap_protobuf", "foxglove", "websockets", "dpkt"]
# One test of each tool, which must be among those that need it.
NEEDING = {
    "test_every_kind_in_every_form_reads_back_exactly",  # mcap
    "test_replay_a_capture_at_its_timing",  # dpkt
    "test_the_view_serves_every_kind_the_fix_drops_and_rates",  # foxglove, websockets
    "test_a_fleet_capture_dissects_as_decode_reads_it",  # tshark
}


def outcomes(tmp_path: Path, require: bool) -> dict[str, tuple[str, str]]:
    """Each test's outcome (passed, failed, error, skipped) and message, by name."""
    tmp_path.mkdir()
    plugin = tmp_path / "erc_hide_tools.py"
    plugin.write_text(f"import sys\nfor name in {HIDDEN!r}:\n    sys.modules[name] = None\n")
    report = tmp_path / "report.xml"
    env = {k: v for k, v in os.environ.items() if k != "ERC_REQUIRE_INTEROP"}
    env["PYTHONPATH"] = str(tmp_path)
    env["PATH"] = str(Path(sys.executable).parent)  # no tshark (nor anything but Python)
    env["ERC_HYPOTHESIS_PROFILE"] = "ci-quick"  # outcomes are read here, not searched for
    if require:
        env["ERC_REQUIRE_INTEROP"] = "1"
    pytest_args = ["-q", "-p", "no:cacheprovider", "-p", "erc_hide_tools", "--junitxml"]
    done = subprocess.run(
        [sys.executable, "-m", "pytest", *pytest_args, str(report), *MODULES],
        cwd=REPO,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    assert done.returncode in (0, 1), done.stdout[-3000:] + done.stderr[-3000:]
    found: dict[str, tuple[str, str]] = {}
    for case in ElementTree.parse(report).iter("testcase"):
        name = case.attrib["name"].split("[")[0]
        kinds = [child for child in case if child.tag in ("failure", "error", "skipped")]
        outcome = kinds[0].tag if kinds else "passed"
        message = kinds[0].attrib.get("message", "") if kinds else ""
        previous = found.get(name)
        if previous is None or previous[0] == "passed":  # a test's worst parametrization
            found[name] = (outcome, message)
    return found


@pytest.mark.slow
def test_a_missing_tool_fails_under_require_interop_and_skips_without(tmp_path: Path) -> None:
    required = outcomes(tmp_path / "required", require=True)
    relaxed = outcomes(tmp_path / "relaxed", require=False)
    assert set(required) == set(relaxed)
    needing = {name for name, (outcome, _) in required.items() if outcome != "passed"}
    assert needing >= NEEDING
    for name in needing:
        outcome, message = required[name]
        assert outcome in ("failure", "error"), (name, outcome)
        assert "Failed: ERC_REQUIRE_INTEROP=1 but " in message, (name, message)
        assert relaxed[name][0] == "skipped", (name, relaxed[name])
        assert "is not installed" in relaxed[name][1], (name, relaxed[name])
    assert all(relaxed[name][0] == "passed" for name in set(relaxed) - needing)
