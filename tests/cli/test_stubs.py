"""``erc-codec stubs OUT_DIR``: with the stubs on mypy's path, a misspelled field, a wrong type and
a field that does not exist are errors where ``message_class`` gave ``type[Message]`` (``Any``
fields) before; a script that uses the messages rightly passes ``mypy --strict``."""

import subprocess
import sys
from pathlib import Path

import pytest
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


@pytest.fixture(scope="module")
def mypy_cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One mypy cache for this module's runs: the standard library, protobuf's stubs and
    erc_codec are analysed once (a run took 2 s uncached, 0.3 s after), never in the repository;
    each script and its stubs, new to every run, are checked anew."""
    return tmp_path_factory.mktemp("mypy-cache")


def stubs_and_mypy(tmp_path: Path, body: str, cache: Path) -> subprocess.CompletedProcess[str]:
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
    return mypy(script, out, REPO, cache)


def mypy(script: Path, stubs: Path, cwd: Path, cache: Path) -> subprocess.CompletedProcess[str]:
    """``mypy --strict`` of ``script`` run in ``cwd``, with ``stubs`` on its path alone."""
    return subprocess.run(
        [sys.executable, "-m", "mypy", "--strict", "--cache-dir", str(cache), str(script)],
        capture_output=True,
        text=True,
        check=False,
        cwd=cwd,
        env={"MYPYPATH": str(stubs), "PATH": "/usr/bin:/bin"},
    )


def test_mypy_catches_a_misspelled_field_a_wrong_type_and_a_missing_one(
    tmp_path: Path, mypy_cache: Path
) -> None:
    done = stubs_and_mypy(tmp_path, WRONG, mypy_cache)
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


def test_a_script_using_the_messages_rightly_passes_mypy_strict(
    tmp_path: Path, mypy_cache: Path
) -> None:
    done = stubs_and_mypy(tmp_path, RIGHT, mypy_cache)
    assert done.returncode == 0, done.stdout
    stub = (tmp_path / "stubs" / "erc_messages.pyi").read_text()
    assert (
        "class GPSFixQuality(_builtins.int):\n    NO_FIX: _typing.ClassVar[_builtins.int]" in stub
    )


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


def test_fields_named_like_builtins_or_the_receiver_type_check(
    tmp_path: Path, mypy_cache: Path
) -> None:
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
    done = mypy(Path("tool.py"), out, tmp_path, mypy_cache)
    # the one error is the one the script makes: the stub itself is sound
    assert done.stdout.count("error:") == 1, done.stdout
    assert 'tool.py:17: error: Incompatible types in assignment (expression has type "int"' in (
        done.stdout
    )


NAMES = """\
syntax = "proto3";

import "nanopb.proto";

// Messages named like what the stub imports or uses; fields named like those, like builtins, like
// their own class and like other messages; nested types named like top-level ones.
message Mapping { int32 Any = 1; int32 ClassVar = 2; }
message Any { Mapping Mapping = 1; int32 Iterable = 2; }
message ClassVar { int32 ClassVar = 1; Any Mapping = 2; }
message Iterable {
  repeated int32 builtins = 1 [(nanopb).max_count = 2];
  Any Any = 2;
  repeated Mapping Iterable = 3 [(nanopb).max_count = 2];
}
message builtins {
  int32 int = 1;
  string str = 2 [(nanopb).max_size = 8];
  bytes bytes = 3 [(nanopb).max_size = 8];
  float float = 4;
  bool bool = 5;
  Mapping Message = 6;
}
message Message { builtins Message = 1; builtins builtins = 2; int32 erc_codec = 3; }
message Outer {
  message Ping { int32 Literal = 1; Outer_Ping overload = 2; }
  Ping ping = 1;
  Ping Outer_Ping = 2;
  Outer.Ping Any = 3;
}
message Outer_Ping {  // and fields named like what protobuf's Message has
  int32 overload = 1;
  int32 Optional = 2;
  int32 Clear = 3;
  int32 Extensions = 5;  // a field named DESCRIPTOR has no class: erc-codec cannot send it
}
message Ping { int32 s = 1; Outer.Ping Outer = 2; }
message Palette {
  enum Color { ClassVar = 0; builtins = 1; int = 2; Mapping = 3; None = 4; }
  Color Palette = 1;
}
message TypedCodec {
  Palette.Color Color = 1;
  repeated Ping Ping = 2 [(nanopb).max_count = 2];
  map<int32, Ping> MutableMapping = 3 [(nanopb).max_count = 2];
  int32 RepeatedCompositeFieldContainer = 4;
  int32 RepeatedScalarFieldContainer = 5;
  int32 self = 6;
  int32 TypeAlias = 7;
}
message Env {
  oneof payload {
    Mapping mapping = 1;
    Any any = 2;
    ClassVar class_var = 3;
    Iterable iterable = 4;
    builtins builtins = 5;
    Message message = 6;
    Outer outer = 7;
    Outer_Ping outer_ping = 8;
    Ping ping = 9;
    TypedCodec typed_codec = 10;
    Palette palette = 11;
  }
}
"""

NAMES_SCRIPT = """\
from pathlib import Path
from typing import TYPE_CHECKING, cast

import erc_codec

if TYPE_CHECKING:
    from erc_messages import Palette_Color, TypedCodec

codec = cast("TypedCodec", erc_codec.Codec.from_path(Path("tree"), root="Env"))
m = codec.message_class("mapping")(Any=1, ClassVar=2)
a = codec.message_class("Any")(Mapping=m, Iterable=3)
c = codec.message_class("class_var")(ClassVar=1, Mapping={"Iterable": 2})
it = codec.message_class("iterable")(builtins=[1, 2], Any=a, Iterable=[m, {"Any": 1}])
b = codec.message_class("builtins")(int=1, str="s", bytes=b"b", float=1.5, bool=True, Message=m)
msg = codec.message_class("message")(Message=b, builtins=b, erc_codec=4)
o = codec.message_class("outer")(ping={"Literal": 1}, Any={"overload": {"overload": 2}})
p = codec.message_class("ping")(s=1, Outer=o.ping)
t = codec.message_class("typed_codec")(Color="Mapping", Ping=[p], MutableMapping={1: p}, self=5)
numbers: list[int] = [
    a.Mapping.Any + a.Iterable + c.ClassVar + c.Mapping.Iterable,
    it.builtins[0] + it.Iterable[0].ClassVar + it.Iterable[1].Any + it.Any.Mapping.ClassVar,
    b.int + b.Message.Any + msg.erc_codec,
    o.ping.Literal + o.Any.overload.overload + o.Outer_Ping.Literal,
    codec.message_class("outer_ping")(Clear=3, Extensions=4).Extensions + p.Outer.Literal,
    t.Ping[0].s + t.MutableMapping[1].s + t.self + t.Color + t.TypeAlias,
    codec.message_class("palette")(Palette="int").Palette,
]
texts: list[str] = [b.str, msg.Message.str, msg.builtins.str]
rest: tuple[bytes, float, bool] = (b.bytes, b.float, b.bool)
print(numbers, texts, rest)
if TYPE_CHECKING:
    shades: int = Palette_Color.ClassVar + Palette_Color.builtins + Palette_Color.int
    wrong_text: str = b.int
    codec.message_class("Any")(Mapping=5)
    print(t.Ping[0].no_such_field)
    wrong_number: int = o.Outer_Ping
"""


def test_names_like_what_the_stub_uses_shadow_nothing(tmp_path: Path, mypy_cache: Path) -> None:
    """Messages, fields and enum values named ``Mapping``, ``Any``, ``ClassVar``, ``Iterable``,
    ``builtins``, ``int``, ``Message``, ``TypedCodec``, a field named like its own class, like
    what protobuf's Message has (``Clear``, ``Extensions``) and a nested type named like a
    top-level one: the stub passes mypy --strict, every field keeps its
    type, and the script runs."""
    tree = tmp_path / "tree"
    tree.mkdir()
    (tree / "names.proto").write_text(NAMES)
    out = tmp_path / "stubs"
    written = subprocess.run(
        [sys.executable, "-m", "erc_codec", "stubs", str(out), "--proto", "tree", "--root", "Env"],
        capture_output=True,
        text=True,
        check=False,
        cwd=tmp_path,
    )
    assert written.returncode == 0, written.stderr
    (tmp_path / "tool.py").write_text(NAMES_SCRIPT)
    done = mypy(Path("tool.py"), out, tmp_path, mypy_cache)
    # the errors are the four the script makes, each typed through the right class
    assert done.stdout.splitlines() == [
        'tool.py:33: error: Incompatible types in assignment (expression has type "int", '
        'variable has type "str")  [assignment]',
        'tool.py:34: error: Argument "Mapping" to "Any" has incompatible type "int"; expected '
        '"erc_messages.Mapping | typing.Mapping[str, Any] | None"  [arg-type]',
        'tool.py:35: error: "Ping" has no attribute "no_such_field"  [attr-defined]',
        "tool.py:36: error: Incompatible types in assignment (expression has type "
        '"Outer_Ping_", variable has type "int")  [assignment]',
        "Found 4 errors in 1 file (checked 1 source file)",
    ]
    ran = subprocess.run(
        [sys.executable, "tool.py"], capture_output=True, text=True, check=False, cwd=tmp_path
    )
    assert ran.returncode == 0, ran.stderr
    assert ran.stdout == "[7, 6, 6, 3, 5, 10, 2] ['s', 's', 's'] (b'b', 1.5, True)\n"
    stub = (out / "erc_messages.pyi").read_text()
    assert "class TypedCodec(_erc_codec.Codec):" in stub  # the message so named gave way
    assert "class TypedCodec_(_message.Message):" in stub
    assert "    None:" not in stub  # an enum value named like a keyword cannot be an attribute


RESERVED = """\
syntax = "proto3";

// Fields, oneof members, enum values and a message named like what Python reserves (__*__) or
// keeps as a keyword, and enum values named like int's attributes.
enum Reserved { __init__ = 0; __class__ = 1; to_bytes = 2; real = 3; PLAIN = 4; }
message Dunder {
  int32 __init__ = 1;
  int32 __slots__ = 2;
  int32 __class__ = 3;
  int32 __getattr__ = 4;
  int32 __eq__ = 5;
  int32 None = 6;
  int32 __private = 7;
  int32 plain = 8;
  Reserved reserved = 9;
}
message __doc__ { int32 plain = 1; }
message Env {
  oneof payload {
    Dunder dunder = 1;
    Dunder __init__ = 2;
    Dunder __slots__ = 3;
    Dunder __class__ = 4;
    Dunder __getattr__ = 5;
    __doc__ doc = 6;
  }
}
"""

RESERVED_SCRIPT = """\
from pathlib import Path
from typing import TYPE_CHECKING, cast

import erc_codec

if TYPE_CHECKING:
    from erc_messages import Reserved, TypedCodec

codec = cast("TypedCodec", erc_codec.Codec.from_path(Path("tree"), root="Env"))
Dunder = codec.message_class("__init__")
names = ("__init__", "__slots__", "__class__", "__getattr__", "__eq__", "None")
d = Dunder(**dict.fromkeys(names, 1), plain=2, __private=3, reserved="to_bytes")
for name in names:
    setattr(d, name, names.index(name) + 1)
env = codec.message_class("Env")()
getattr(env, "__class__").CopyFrom(d)
numbers: list[int] = [getattr(d, name) for name in names]
numbers += [d.plain, d.__private, d.reserved, getattr(env, "__class__").plain]
numbers.append(codec.message_class("doc")(plain=9).plain)
print(numbers, env.WhichOneof("payload"), codec.message_class("__slots__") is Dunder)
if TYPE_CHECKING:
    shades: int = Reserved.PLAIN + Reserved.real + Reserved.to_bytes
    wrong_text: str = codec.message_class("__getattr__")().plain
    codec.message_class("__doc__")(plain="nine")
    Dunder(__init__=1)
"""


def test_names_python_reserves_are_left_out_and_reached_by_getattr(
    tmp_path: Path, mypy_cache: Path
) -> None:
    """Fields and oneof members named ``__init__``, ``__slots__``, ``__class__``,
    ``__getattr__`` or ``__eq__``, enum values so named, a message named ``__doc__`` and enum
    values named like int's ``to_bytes`` and ``real``: the stub passes mypy --strict, leaves the
    reserved names out (a comment says which) and the script reaches them by getattr."""
    tree = tmp_path / "tree"
    tree.mkdir()
    (tree / "reserved.proto").write_text(RESERVED)
    out = tmp_path / "stubs"
    written = subprocess.run(
        [sys.executable, "-m", "erc_codec", "stubs", str(out), "--proto", "tree", "--root", "Env"],
        capture_output=True,
        text=True,
        check=False,
        cwd=tmp_path,
    )
    assert written.returncode == 0, written.stderr
    (tmp_path / "tool.py").write_text(RESERVED_SCRIPT)
    done = mypy(Path("tool.py"), out, tmp_path, mypy_cache)
    # the errors are the three the script makes, each typed through the right class
    assert done.stdout.splitlines() == [
        'tool.py:23: error: Incompatible types in assignment (expression has type "int", '
        'variable has type "str")  [assignment]',
        'tool.py:24: error: Argument "plain" to "Message__doc__" has incompatible type "str"; '
        'expected "int | None"  [arg-type]',
        'tool.py:25: error: Unexpected keyword argument "__init__" for "Dunder"  [call-arg]',
        'tool.py:25: note: "Dunder" defined in "erc_messages"',
        "Found 3 errors in 1 file (checked 1 source file)",
    ]
    ran = subprocess.run(
        [sys.executable, "tool.py"], capture_output=True, text=True, check=False, cwd=tmp_path
    )
    assert ran.returncode == 0, ran.stderr
    assert ran.stdout == "[1, 2, 3, 4, 5, 6, 2, 3, 2, 2, 9] __class__ True\n"
    stub = (out / "erc_messages.pyi").read_text()
    left_out = "    # Left out (a keyword, or a name Python reserves)"
    fields = f"{left_out}, getattr reaches them: __init__, __slots__, __class__, __getattr__"
    assert f"{fields}, __eq__, None\n" in stub
    assert f"{fields}\n" in stub  # Env's members
    assert f"class Reserved(_builtins.int):\n{left_out}: __init__, __class__\n" in stub
    assert "class Message__doc__(_message.Message):" in stub
