"""The fleet in a box: prost structs for a schema, and the builds of the board and base station.

``prost_source`` writes the Rust a prost user writes by hand (or prost-build generates): one
``#[derive(prost::Message)]`` struct per message, a ``prost::Oneof`` enum for the envelope's
oneof, ``prost::Enumeration`` enums. ``cargo_build`` builds tests/fleet/basestation offline from
the crates Debian installs (``librust-prost-dev``), with the committed Cargo.lock.
"""

import os
import shutil
import subprocess
from pathlib import Path

from google.protobuf.descriptor import (
    Descriptor,
    EnumDescriptor,
    FieldDescriptor,
    OneofDescriptor,
)

from erc_codec import Codec

FLEET = Path(__file__).parent / "fleet"
DEBIAN_CRATES = Path("/usr/share/cargo/registry")  # where librust-*-dev install their crates

_T = FieldDescriptor
_SCALARS = {
    _T.TYPE_FLOAT: ("float", "f32"),
    _T.TYPE_DOUBLE: ("double", "f64"),
    _T.TYPE_INT32: ("int32", "i32"),
    _T.TYPE_INT64: ("int64", "i64"),
    _T.TYPE_UINT32: ("uint32", "u32"),
    _T.TYPE_UINT64: ("uint64", "u64"),
    _T.TYPE_SINT32: ("sint32", "i32"),
    _T.TYPE_SINT64: ("sint64", "i64"),
    _T.TYPE_FIXED32: ("fixed32", "u32"),
    _T.TYPE_FIXED64: ("fixed64", "u64"),
    _T.TYPE_SFIXED32: ("sfixed32", "i32"),
    _T.TYPE_SFIXED64: ("sfixed64", "i64"),
    _T.TYPE_BOOL: ("bool", "bool"),
}


def rust_type(name: str) -> str:
    """prost-build's spelling of a message or enum name: CamelCase, acronyms folded."""
    words, word = [], ""
    for i, char in enumerate(name):
        upper_run = char.isupper() and i and name[i - 1].isupper()
        if upper_run and not (i + 1 < len(name) and name[i + 1].islower()):
            word += char.lower()
        else:
            if char.isupper() and word:
                words.append(word)
                word = ""
            word += char
    return "".join(w[:1].upper() + w[1:] for w in [*words, word])


def prost_source(codec: Codec) -> str:
    """Rust source declaring every message and enum of ``codec``'s schema for prost."""
    messages: dict[str, Descriptor] = {}
    enums: dict[str, EnumDescriptor] = {}

    def visit(message: Descriptor) -> None:
        if message.full_name in messages:
            return
        messages[message.full_name] = message
        for field in message.fields:
            if field.message_type is not None:
                visit(field.message_type)
            if field.enum_type is not None:
                enums[field.enum_type.full_name] = field.enum_type

    root = codec.schema.root
    visit(root)
    lines = ["#![allow(dead_code, non_camel_case_types, clippy::all)]", ""]
    for enum in enums.values():
        lines += _enum(enum)
    for message in messages.values():
        lines += _message(message, message.oneofs[0] if message is root else None)
    return "\n".join(lines)


_ENUM_DERIVES = "Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, ::prost::Enumeration"


def _enum(enum: EnumDescriptor) -> list[str]:
    return [
        f"#[derive({_ENUM_DERIVES})]",
        "#[repr(i32)]",
        f"pub enum {rust_type(enum.name)} {{",
        *(f"    {value.name} = {value.number}," for value in enum.values),
        "}",
        "",
    ]


def _message(message: Descriptor, oneof: OneofDescriptor | None) -> list[str]:
    name = rust_type(message.name)
    lines = ["#[derive(Clone, PartialEq, ::prost::Message)]", f"pub struct {name} {{"]
    for field in message.fields:
        if oneof is None or field.containing_oneof is not oneof:
            lines += [f"    {_attribute(field)}", f"    pub r#{field.name}: {_rust_field(field)},"]
    if oneof is None:
        return [*lines, "}", ""]
    module = _snake(name)
    tags = ", ".join(str(field.number) for field in oneof.fields)
    lines += [
        f'    #[prost(oneof = "{module}::Payload", tags = "{tags}")]',
        f"    pub {oneof.name}: ::core::option::Option<{module}::Payload>,",
        "}",
        "",
        f"pub mod {module} {{",
        "    #[derive(Clone, PartialEq, ::prost::Oneof)]",
        "    pub enum Payload {",
    ]
    for field in oneof.fields:
        assert field.message_type is not None
        lines += [
            f'        #[prost(message, tag = "{field.number}")]',
            f"        {_camel(field.name)}(super::{rust_type(field.message_type.name)}),",
        ]
    return [*lines, "    }", "}", ""]


def _camel(name: str) -> str:
    return "".join(part.capitalize() for part in name.split("_"))


def _snake(name: str) -> str:
    return "".join(f"_{c.lower()}" if c.isupper() and i else c.lower() for i, c in enumerate(name))


def _attribute(field: FieldDescriptor) -> str:
    if field.message_type is not None:
        return f'#[prost(message, optional, tag = "{field.number}")]'
    if field.enum_type is not None:
        return (
            f'#[prost(enumeration = "{rust_type(field.enum_type.name)}", tag = "{field.number}")]'
        )
    return f'#[prost({_SCALARS[field.type][0]}, tag = "{field.number}")]'


def _rust_field(field: FieldDescriptor) -> str:
    assert not field.is_repeated, "the envelope contract has no repeated fields"
    if field.message_type is not None:
        return f"::core::option::Option<{rust_type(field.message_type.name)}>"
    if field.enum_type is not None:
        return "i32"
    return _SCALARS[field.type][1]


def cargo_missing() -> str:
    """What the Rust build needs and this machine lacks; empty when nothing is missing."""
    cargo = shutil.which("cargo", path="/usr/bin:/bin")
    if cargo is None:
        return "Debian's cargo (apt-get install cargo)"
    if not any(DEBIAN_CRATES.glob("prost-0.11.*")):
        return f"prost 0.11 in {DEBIAN_CRATES} (apt-get install librust-prost-dev)"
    return ""


def cargo_build(codec: Codec, build: Path) -> Path:
    """Build the base station in ``build`` (offline, Debian's crates); the program's path."""
    project = build / "basestation"
    shutil.copytree(FLEET / "basestation", project)
    (project / "src" / "envelope.rs").write_text(prost_source(codec))
    home = build / "cargo-home"
    home.mkdir()
    (home / "config.toml").write_text(
        '[source.crates-io]\nreplace-with = "debian"\n\n'
        f'[source.debian]\ndirectory = "{DEBIAN_CRATES}"\n\n[net]\noffline = true\n'
    )
    # Debian's toolchain, not a rustup one a user may have on PATH.
    env = {
        **os.environ,
        "PATH": "/usr/bin:/bin",
        "CARGO_HOME": str(home),
        "RUSTC": "/usr/bin/rustc",
    }
    subprocess.run(
        ["cargo", "build", "--quiet", "--offline", "--locked", "--release"],
        cwd=project,
        env=env,
        check=True,
        capture_output=True,
        text=True,
    )
    # CARGO_TARGET_DIR (set by .ci/run for all its Pythons) keeps the compiled crates between
    # runs: prost and its dependencies are most of the build's time.
    target = os.environ.get("CARGO_TARGET_DIR") or project / "target"
    return Path(target) / "release" / "basestation"


def nanopb_missing() -> tuple[str, Path | None]:
    """What the board's build lacks (empty if nothing), and nanopb's generator matching the
    installed headers (Debian's ``nanopb`` with ``libnanopb-dev``, as
    tests/interop/test_interop.py)."""
    import re

    if shutil.which("gcc") is None:
        return "gcc", None
    probe = subprocess.run(
        ["gcc", "-M", "-x", "c", "-"], input="#include <pb.h>\n", capture_output=True, text=True
    )
    header = re.search(r"(\S*/pb\.h)", probe.stdout)
    if probe.returncode != 0 or header is None:
        return "nanopb's C headers (libnanopb-dev)", None
    version = re.search(r'#define NANOPB_VERSION "(.*?)"', Path(header[1]).read_text())
    for folder in os.environ.get("PATH", "").split(os.pathsep):
        for name in ("nanopb_generator.py", "nanopb_generator"):
            candidate = Path(folder) / name
            if os.access(candidate, os.X_OK):
                said = subprocess.run([str(candidate), "--version"], capture_output=True, text=True)
                if version and said.stdout.strip() == version[1]:
                    return "", candidate
    return "nanopb's generator matching the headers (Debian package nanopb)", None


def gcc_build(proto: Path, generator: Path, build: Path) -> Path:
    """Build tests/fleet/board.c against nanopb's C library from ``proto``; the program."""
    subprocess.run(
        [
            str(generator),
            *("-q", "-I", ".", "-D", str(build)),
            *sorted(path.relative_to(proto).as_posix() for path in proto.rglob("*.proto")),
        ],
        cwd=proto,
        check=True,
    )
    program = build / "board"
    subprocess.run(
        [
            *("gcc", "-std=gnu11", "-Wall", "-Wextra", "-Werror", "-O1", "-I", str(build)),
            *("-o", str(program), str(FLEET / "board.c")),
            *sorted(str(path) for path in build.rglob("*.pb.c")),
            "-lprotobuf-nanopb",
        ],
        check=True,
    )
    return program
