"""The erc-codec command line, run as a user would (a subprocess)."""

import json
import re
import subprocess
import sys
from pathlib import Path

from conftest import PROTO


def run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "erc_codec", *args], capture_output=True, text=True, check=False
    )


def test_sizes_prints_the_envelope_table() -> None:
    done = run("sizes")
    assert done.returncode == 0, done.stderr
    assert "PBEnvelope_size 262" in done.stdout
    row = r"^\s+12\s+gps_info\s+SensorBoardGPSInfo\s+71\s+Hardware -> ROS2$"
    assert re.search(row, done.stdout, re.MULTILINE)
    assert re.search(r"^\s+MotorInformation\s+23$", done.stdout, re.MULTILINE)


def test_sizes_json_lists_members_and_messages() -> None:
    done = run("sizes", "--proto", str(PROTO), "--format", "json")
    assert done.returncode == 0, done.stderr
    document = json.loads(done.stdout)
    assert document["root"] == "PBEnvelope"
    assert document["max_size"] == 262
    assert [m["number"] for m in document["members"]] == list(range(1, 22))
    assert document["members"][16] == {
        "number": 17,
        "kind": "detected_object",
        "type": "BasestationDetectedObject",
        "max_size": 60,
        "direction": "ROS2 -> BS",
    }
    assert document["messages"]["DrivingBoardDiagnostics"] == 252


def test_a_tree_that_does_not_load_is_one_line_and_exit_2(tmp_path: Path) -> None:
    done = run("sizes", "--proto", str(tmp_path))
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1
    assert "no .proto file defines message PBEnvelope" in done.stderr
    assert "Traceback" not in done.stderr


def test_usage_errors_exit_2() -> None:
    done = run("sizes", "--format", "xml")
    assert done.returncode == 2
    assert "Traceback" not in done.stderr
