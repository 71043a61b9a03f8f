"""``erc-codec stubs OUT_DIR``: with the stubs on mypy's path, a misspelled field, a wrong type and
a field that does not exist are errors where ``message_class`` gave ``type[Message]`` (``Any``
fields) before; a script that uses the messages rightly passes ``mypy --strict``."""

import subprocess
import sys
from pathlib import Path

from conftest import REPO

SCRIPT = """\
from typing import TYPE_CHECKING, cast

import erc_codec

if TYPE_CHECKING:
    from erc_messages import TypedCodec

codec = cast("TypedCodec", erc_codec.Codec.default())
GPSInfo = codec.message_class("gps_info")
{body}
"""

RIGHT = """\
fix = GPSInfo(latitude=52.2, satellites=9, fix_quality="DGPS_FIX")
count: int = fix.satellites
motor = codec.message_class("ArmBoardDiagnostics")(base_motor={"motor_id": 3}).base_motor
rpm: float = motor.rpm
envelope = codec.message_class("PBEnvelope")(gps_info=fix)
print(count, rpm, envelope.gps_info.latitude, codec.message_class("anything else"))
"""

WRONG = """\
bad = GPSInfo(latitude="north", satelites=9)
print(bad.no_such_field)
name: str = bad.latitude
"""


def stubs_and_mypy(tmp_path: Path, body: str) -> subprocess.CompletedProcess[str]:
    out = tmp_path / "stubs"
    written = subprocess.run(
        [sys.executable, "-m", "erc_codec", "stubs", str(out)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert written.returncode == 0, written.stderr
    assert written.stderr == f"wrote {out / 'erc_messages.pyi'}\n"
    script = tmp_path / "tool.py"
    script.write_text(SCRIPT.format(body=body))
    return subprocess.run(
        [sys.executable, "-m", "mypy", "--strict", "--no-incremental", str(script)],
        capture_output=True,
        text=True,
        check=False,
        cwd=REPO,
        env={"MYPYPATH": str(out), "PATH": "/usr/bin:/bin"},
    )


def test_mypy_catches_a_misspelled_field_a_wrong_type_and_a_missing_one(tmp_path: Path) -> None:
    done = stubs_and_mypy(tmp_path, WRONG)
    assert done.returncode == 1
    errors = [
        line.split(": error: ", 1)[1] for line in done.stdout.splitlines() if ": error: " in line
    ]
    assert errors == [
        'Unexpected keyword argument "satelites" for "SensorBoardGPSInfo"; did you mean '
        '"satellites"?  [call-arg]',
        'Argument "latitude" to "SensorBoardGPSInfo" has incompatible type "str"; expected '
        '"float | None"  [arg-type]',
        '"SensorBoardGPSInfo" has no attribute "no_such_field"  [attr-defined]',
        'Incompatible types in assignment (expression has type "float", variable has type '
        '"str")  [assignment]',
    ]


def test_a_script_using_the_messages_rightly_passes_mypy_strict(tmp_path: Path) -> None:
    done = stubs_and_mypy(tmp_path, RIGHT)
    assert done.returncode == 0, done.stdout
    stub = (tmp_path / "stubs" / "erc_messages.pyi").read_text()
    assert "class GPSFixQuality(builtins.int):\n    NO_FIX: ClassVar[builtins.int]" in stub


AWKWARD = """\
syntax = "proto3";

import "nanopb.proto";

message Awkward {
  int32 self = 1;
  int32 int = 2;
  float float = 3;
  bool bool = 4;
  string str = 5 [(nanopb).max_size = 8];
  bytes bytes = 6 [(nanopb).max_size = 8];
  int32 Message = 7;
}

message Env {
  oneof payload {
    Awkward awkward = 1;
  }
}
"""

AWKWARD_SCRIPT = """\
from pathlib import Path
from typing import TYPE_CHECKING, cast

import erc_codec

if TYPE_CHECKING:
    from erc_messages import TypedCodec

codec = cast("TypedCodec", erc_codec.Codec.from_path(Path("tree"), root="Env"))
Awkward = codec.message_class("awkward")
a = Awkward(self=1, int=2, float=1.5, bool=True, str="s", bytes=b"b", Message=3)
number: int = a.int + a.self + a.Message
real: float = a.float
flag: bool = a.bool
text: str = a.str
data: bytes = a.bytes
wrong: str = a.int
"""


def test_fields_named_like_builtins_or_the_receiver_type_check(tmp_path: Path) -> None:
    """A field ``self``, ``int``, ``float``, ``bool``, ``str``, ``bytes`` or ``Message`` broke
    the stub: a duplicate argument, or a name shadowing the type of the fields after it."""
    tree = tmp_path / "tree"
    tree.mkdir()
    (tree / "awkward.proto").write_text(AWKWARD)
    out = tmp_path / "stubs"
    written = subprocess.run(
        [
            sys.executable,
            "-m",
            "erc_codec",
            "stubs",
            str(out),
            "--proto",
            str(tree),
            "--root",
            "Env",
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    assert written.returncode == 0, written.stderr
    (tmp_path / "tool.py").write_text(AWKWARD_SCRIPT)
    done = subprocess.run(
        [sys.executable, "-m", "mypy", "--strict", "--no-incremental", "tool.py"],
        capture_output=True,
        text=True,
        check=False,
        cwd=tmp_path,
        env={"MYPYPATH": str(out), "PATH": "/usr/bin:/bin"},
    )
    # the one error is the one the script makes: the stub itself is sound
    assert done.stdout.count("error:") == 1, done.stdout
    assert 'tool.py:17: error: Incompatible types in assignment (expression has type "int"' in (
        done.stdout
    )
