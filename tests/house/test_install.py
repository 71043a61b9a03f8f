"""The packaged schema works from an installed wheel, with no checkout anywhere in sight.

The wheel is built from the repository (hatchling, no build isolation: no network needed),
installed with ``pip install --target`` into a temporary folder, and exercised by a fresh
interpreter whose working directory and import path are outside the repository. The editable
install of the development environment is kept out of that interpreter's path (its own
environment's packages stay, even when the venv sits inside the checkout), and the script checks
that what it imported really is the installed copy.
"""

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path
from typing import Any

import pytest
from conftest import REPO

SCRIPT = textwrap.dedent(
    """
    import json
    import os
    import sys

    def inside(entry, folder):
        entry = os.path.realpath(entry)
        return entry == folder or entry.startswith(folder + os.sep)

    repo = os.path.realpath(sys.argv[1])
    environment = os.path.realpath(sys.prefix)  # a venv's site-packages: the dependencies
    hidden = [
        entry for entry in sys.path
        if entry and inside(entry, repo) and not inside(entry, environment)
    ]
    sys.path[:] = [entry for entry in sys.path if entry not in hidden]

    import erc_codec
    from erc_codec.codec._codec import default_tree

    codec = erc_codec.Codec.default()
    progress = codec.message_class("DrivingBoardMotorPeriodicProgress")
    payload = progress(distance_left=1e-40)
    stripped = erc_codec.encode(payload)
    kind, message = erc_codec.decode(stripped)
    padded = codec.encode(payload, "pad")
    feedback = codec.message_class("ArmBoardMovementFeedback")()
    print(json.dumps({
        "file": erc_codec.__file__,
        "tree": str(default_tree()),
        "hidden": hidden,
        "modules": sorted(
            name for name, module in sys.modules.items()
            if name.startswith(("erc_codec", "erc_schema")) and getattr(module, "__file__", None)
            and inside(module.__file__, repo)
        ),
        "max_size": codec.max_size("PBEnvelope"),
        "kinds": codec.kinds(),
        "exact": codec.encode(payload, "exact").hex(),
        "stripped": stripped.hex(),
        "padded_length": len(padded),
        "kind": kind,
        "equal": message == payload,
        "padded_kind": codec.decode(padded).kind,
        "feedback": codec.encode(feedback).hex(),
        "feedback_decoded": codec.decode(b"\\x22").kind,
        "shipped": [  # beside the modules: what type checkers, the Lua dissector and protoc read
            os.path.isfile(os.path.join(os.path.dirname(package.__file__), name))
            for package, name in (
                (erc_codec, "py.typed"),
                (sys.modules["erc_schema"], "py.typed"),
                (erc_codec.capture, "_dissector.lua"),
                (sys.modules["erc_schema"], os.path.join("_include", "nanopb.proto")),
            )
        ],
    }))
    """
)


def run(*args: str, cwd: Path, env: dict[str, str] | None = None) -> str:
    result = subprocess.run(
        args, cwd=cwd, env=env, capture_output=True, text=True, timeout=300, check=False
    )
    assert result.returncode == 0, f"{args}\nstdout:\n{result.stdout}\nstderr:\n{result.stderr}"
    return result.stdout


@pytest.mark.slow
def test_packaged_schema_works_from_an_installed_wheel(tmp_path: Path) -> None:
    wheels = tmp_path / "wheels"
    site = tmp_path / "site"
    work = tmp_path / "elsewhere"
    work.mkdir()
    python = sys.executable
    run(
        python,
        "-m",
        "pip",
        "wheel",
        "--no-deps",
        "--no-build-isolation",
        "--no-cache-dir",
        "-w",
        str(wheels),
        str(REPO),
        cwd=tmp_path,
    )
    (wheel,) = wheels.glob("erc_codec-*.whl")
    run(
        python,
        "-m",
        "pip",
        "install",
        "--no-deps",
        "--no-cache-dir",
        "--target",
        str(site),
        str(wheel),
        cwd=tmp_path,
    )
    assert (site / "erc_codec" / "proto" / "components" / "common" / "envelope.proto").is_file()

    env = {
        key: value
        for key, value in os.environ.items()
        if not key.startswith("PYTHON") and str(REPO) not in value
    }
    env["PYTHONPATH"] = str(site)
    env["PYTHONNOUSERSITE"] = "1"
    env["PYTHONDONTWRITEBYTECODE"] = "1"
    output = run(python, "-c", SCRIPT, str(REPO), cwd=work, env=env)
    report: dict[str, Any] = json.loads(output)

    installed = site.resolve()
    assert Path(report["file"]).resolve().is_relative_to(installed), report["file"]
    assert Path(report["tree"]).resolve() == installed / "erc_codec" / "proto"
    assert report["modules"] == []
    assert report["max_size"] == 262
    assert report["kinds"]["1"] == "ph_info"
    assert report["kinds"]["21"] == "rover_localization"
    assert len(report["kinds"]) == 21
    assert report["exact"] == "52050dc2160100"
    assert report["stripped"] == "52050dc21601"
    assert report["padded_length"] == 262
    assert report["kind"] == report["padded_kind"] == "drive_progress"
    assert report["equal"] is True
    assert report["feedback"] == "22"
    assert report["feedback_decoded"] == "arm_feedback"
    assert report["shipped"] == [True, True, True, True]  # py.typed twice, the Lua, nanopb.proto
