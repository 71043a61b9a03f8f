"""erc_codec.proton against Proton's own C libraries, byte for byte, both directions, both versions.

The session builds two real peers once, from the sources beside the repository
(``../shared/peers/proton``, Apache-2.0, unmodified):

- Proton 2.0 (``2.0-d269668``): its C core (registry, ``proton_encode_bundle``, ``proton_decode``,
  serial framing helpers) with its vendored nanopb, and the registry its own generator
  (``generator_scripts/generator.py``, which needs jinja2 and pyyaml) writes for node ``mcu`` of
  tests/proton/types.yaml, linked with our tests/proton/driver2.c;
- Proton 1.0 (``1.0-8c898cf``, the rover's first protocol): its C runtime ``protonc``
  (``PROTON_Encode``, ``PROTON_Decode``, its framing helpers) with the nanopb sources that nanopb's
  generator writes from 1.0's own ``proto/`` and ``.options`` (version 0.4.9.1 from the test extra:
  the version of the nanopb runtime Proton vendors, which both builds use). protonc's own generator
  is not published: tests/proton/driver1.c builds at run time, from tests/proton/types_1_0.yaml, the
  ``proton_bundle_t`` and ``proton_signal_t`` structures that generator wrote.

For every bundle of those configurations (every signal type: 2.0's nine, 1.0's nine and nine list
types), hypothesis draws values (full integer ranges, ±0, NaN, ±inf, subnormals, empty and full
strings and bytes, multi-byte UTF-8 to the last byte of a capacity); the C peer sets them through
its own accessors and encodes: its bytes must be erc_codec's, exactly, and decode in Python to the
same values; erc_codec's bytes must decode in C to the same values (the C registry set to other
values first, so a signal C did not apply cannot pass). Serial frames made by each library's helpers
must deframe in the other. ``erc_codec.proton.Node`` must send what 2.0's node manager
(``proton_node_update``) sends, in its order, polled at the same times. Every message of
tests/proton/test_proton_codec.py's decode tables goes to a fresh C peer: what erc_codec decodes, C
reads as the same values; what erc_codec refuses, C refuses or misreads as recorded there. And the
2.0 core, built for a configuration with larger capacities with its own 512-byte scratch buffer and
with a larger one, shows the limit ``BundleCodec``'s ``scratch_buffer_size`` stands for.

Without ``../shared``, gcc or jinja2 the tests skip, saying why, except when ERC_REQUIRE_INTEROP=1
(CI), where they fail.
"""

import importlib.util
import os
import shutil
import struct
import subprocess
import sys
from collections.abc import Iterator, Mapping
from pathlib import Path

import pytest
from conftest import REPO
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from proton_values import HERE, TYPES_1_0, TYPES_2_0, same, values
from test_proton_codec import (
    ACCEPTED_1_0,
    ACCEPTED_2_0,
    LARGE,
    REFUSED_1_0,
    REFUSED_2_0,
    Accepted,
    Refused,
)

import erc_codec
from erc_codec.proton import BundleCodec, Config, Node, SignalConfig, Value, parse_config

pytestmark = pytest.mark.interop

SHARED = REPO.parent / "shared" / "peers" / "proton"
CORE = SHARED / "2.0-d269668"
PROTONC = SHARED / "1.0-8c898cf"
V2 = BundleCodec(TYPES_2_0)
V1 = BundleCodec(TYPES_1_0, "1.0")
_LAYOUTS = {"double": "<d", "float": "<f", "int32": "<i", "int64": "<q"}
_LAYOUTS |= {"uint32": "<I", "uint64": "<Q", "bool": "<?"}
_SETTINGS = settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])


class Peer:
    """A running driver: one request line in, one answer line out."""

    def __init__(self, program: Path) -> None:
        self._process = subprocess.Popen(
            [str(program)], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, bufsize=1
        )

    def ask(self, requests: list[str]) -> list[str]:
        assert self._process.stdin is not None
        assert self._process.stdout is not None
        self._process.stdin.write("".join(f"{request}\n" for request in requests))
        self._process.stdin.flush()
        answers: list[str] = []
        while len(answers) < len(requests):
            line = self._process.stdout.readline()
            assert line, "the C peer stopped"
            if not line.startswith("Error: "):  # protonc prints nanopb's error first, on stdout
                answers.append(line.rstrip("\n"))
        return answers

    def close(self) -> None:
        assert self._process.stdin is not None
        assert self._process.stdout is not None
        self._process.stdin.close()
        assert self._process.wait(timeout=10) == 0
        self._process.stdout.close()


def _missing() -> str:
    if not SHARED.is_dir():
        return f"Proton's sources beside the repository ({SHARED})"
    if shutil.which("gcc") is None:
        return "gcc"
    for module, package in (("jinja2", "jinja2"), ("yaml", "pyyaml"), ("nanopb", "nanopb")):
        if importlib.util.find_spec(module) is None:
            return f"{package} (the test extra: pip install -e '.[test]')"
    return ""


def _gcc(*args: str | Path) -> None:
    done = subprocess.run(["gcc", "-O1", *map(str, args)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr


def _needed() -> None:
    missing = _missing()
    if missing:
        reason = f"Proton interop tests need {missing}"
        if os.environ.get("ERC_REQUIRE_INTEROP") == "1":
            pytest.fail(f"ERC_REQUIRE_INTEROP=1 but {reason}")
        pytest.skip(reason)


def _driver2(config: Path, build: Path, name: str, *defines: str) -> Path:
    """tests/proton/driver2.c with Proton 2.0's core and the registry its generator writes for
    node mcu of ``config``."""
    nanopb = CORE / "external" / "nanopb"
    generated = build / f"{name}-mcu"
    subprocess.run(
        [
            sys.executable,
            str(CORE / "generator_scripts" / "generator.py"),
            *("-c", str(config), "-t", "mcu", "-d", str(generated)),
        ],
        check=True,
        capture_output=True,
    )
    core = [
        *sorted((CORE / "core" / "src").glob("*.c")),
        *sorted((CORE / "core" / "src" / "generated").glob("*.c")),
        *sorted((CORE / "core" / "src" / "transport").glob("*.c")),
    ]
    include = CORE / "core" / "include"
    _gcc(
        *defines,
        *("-std=c11", "-I", include, "-I", include / "proton" / "generated", "-I", nanopb),
        *("-I", generated, "-o", build / name, HERE / "driver2.c"),
        *(generated / "target_registry.c", generated / "target_node.c", *core),
        *sorted(nanopb.glob("pb_*.c")),
    )
    return build / name


@pytest.fixture(scope="session")
def programs(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """The two drivers, built once per session."""
    _needed()
    build = tmp_path_factory.mktemp("proton")
    nanopb = CORE / "external" / "nanopb"
    runtime = sorted(nanopb.glob("pb_*.c"))
    # 2.0: the registry for node mcu, as Proton's generator writes it, and the core around it.
    _driver2(HERE / "types.yaml", build, "driver2")
    # 1.0: protonc, with nanopb's sources for 1.0's own .proto and .options.
    headers = build / "protonc-generated"
    (headers / "protonc").mkdir(parents=True)
    subprocess.run(
        [
            *(sys.executable, "-m", "nanopb.generator.nanopb_generator", "-q", "-I", "."),
            *("-D", str(headers / "protonc"), "bundle.proto", "signal.proto"),
        ],
        cwd=PROTONC / "proto",
        check=True,
        capture_output=True,
    )
    _gcc(
        *("-std=c11", "-I", headers, "-I", PROTONC / "protonc" / "include", "-I", nanopb),
        *("-o", build / "driver1", HERE / "driver1.c"),
        *sorted((PROTONC / "protonc" / "src").glob("*.c")),
        *sorted((headers / "protonc").glob("*.pb.c")),
        *runtime,
    )
    return build / "driver2", build / "driver1"


@pytest.fixture(scope="session")
def core(programs: tuple[Path, Path]) -> Iterator[Peer]:
    """Proton 2.0's core, its registry shared by every test that talks to it."""
    peer = Peer(programs[0])
    yield peer
    peer.close()


@pytest.fixture(scope="session")
def protonc(programs: tuple[Path, Path]) -> Iterator[Peer]:
    """Proton 1.0's protonc, with every bundle of types_1_0.yaml described to it."""
    peer = Peer(programs[1])
    described = peer.ask(
        [f"B {bundle.id} {_specs(bundle.signals)}" for bundle in TYPES_1_0.bundles]
    )
    assert described == ["OK"] * len(TYPES_1_0.bundles)
    yield peer
    peer.close()


def _specs(names: tuple[str, ...]) -> str:
    specs = []
    for name in names:
        signal = TYPES_1_0.signal(name)
        specs.append(f"{signal.type}:{signal.length}:{signal.capacity}")
    return " ".join(specs)


def c_value(signal: SignalConfig, value: Value) -> str:
    """A value as the drivers take and print it: the C variable's bytes, in hex."""
    element = signal.type.removeprefix("list_")
    if isinstance(value, list):
        return ",".join(_c_item(element, item) for item in value)
    return _c_item(element, value)


def _c_item(element: str, value: object) -> str:
    if isinstance(value, str):
        data = value.encode("utf-8")
    elif isinstance(value, bytes):
        data = value
    else:
        data = struct.pack(_LAYOUTS[element], value)
    return data.hex() or "-"


def decoded_line(bundle_id: int, items: list[str]) -> str:
    return " ".join(["OK", str(bundle_id), *items])


def _values(codec: BundleCodec, bundle: str, data: st.DataObject) -> dict[str, Value]:
    config = codec.config
    return {
        name: codec.check(name, data.draw(values(config.signal(name), codec.version), label=name))
        for name in config.bundle(bundle).signals
    }


def _same_values(got: dict[str, Value], sent: dict[str, Value]) -> bool:
    return list(got) == list(sent) and all(same(got[name], sent[name]) for name in sent)


@pytest.mark.parametrize("bundle", [bundle.name for bundle in TYPES_2_0.bundles])
@given(data=st.data())
@_SETTINGS
def test_bundles_byte_for_byte_with_protons_c_core(
    core: Peer, bundle: str, data: st.DataObject
) -> None:
    config = TYPES_2_0.bundle(bundle)
    sent = _values(V2, bundle, data)
    ours = V2.encode(bundle, sent)
    signals = [TYPES_2_0.signal(name) for name in config.signals]
    *set_, encoded = core.ask(
        [f"S {s.id} {c_value(s, sent[s.name])}" for s in signals] + [f"E {config.id}"]
    )
    assert set_ == ["OK"] * len(signals)
    # 1. The C core's encoding of these values is erc_codec's, byte for byte.
    assert encoded == f"OK {ours.hex()}"
    # 2. erc_codec decodes the C core's bytes to the values it was given.
    assert _same_values(V2.decode(bytes.fromhex(encoded[3:])).signals, sent)
    # 3. The C core decodes erc_codec's bytes to the same values, read back through its getters:
    # its registry set to other values first, so a signal it did not apply cannot pass.
    *reset, decoded = core.ask(
        [f"S {s.id} {c_value(s, _other(s, sent[s.name]))}" for s in signals] + [f"D {ours.hex()}"]
    )
    assert reset == ["OK"] * len(signals)
    assert decoded == decoded_line(
        config.id, [f"{s.id}={c_value(s, sent[s.name])}" for s in signals]
    )


def _other(signal: SignalConfig, value: Value) -> Value:
    """A value of ``signal`` other than ``value`` (but for a string of capacity 1: only "")."""
    if isinstance(value, bool):
        return not value
    if isinstance(value, float):
        return 2.0 if same(value, 1.0) else 1.0
    if isinstance(value, int):
        return 2 if value == 1 else 1
    if isinstance(value, str):
        return "" if value or signal.capacity == 1 else "x"
    assert isinstance(value, bytes)
    return b"" if value else b"\x01"


def test_other_values_differ() -> None:
    """_other never hands back the value it was given, but where a type allows one value only."""
    for signal in TYPES_2_0.signals:
        for value in (signal.default, V2.check(signal.name, signal.default)):
            if signal.type == "string" and signal.capacity == 1:
                continue
            assert not same(_other(signal, value), value), signal.name


def test_the_c_registry_starts_where_the_configuration_says(programs: tuple[Path, Path]) -> None:
    """Until a signal is first set, the generated registry sends string and bytes signals at their
    whole capacity (a string padded with NULs): erc_codec reads each as the configured default."""
    peer = Peer(programs[0])
    try:
        answers = peer.ask([f"E {bundle.id}" for bundle in TYPES_2_0.bundles])
    finally:
        peer.close()
    for bundle, answer in zip(TYPES_2_0.bundles, answers, strict=True):
        assert answer.startswith("OK ")
        decoded = V2.decode(bytes.fromhex(answer[3:]))
        defaults = {name: TYPES_2_0.signal(name).default for name in bundle.signals}
        assert _same_values(decoded.signals, defaults), bundle.name
    assert "text_300" in TYPES_2_0.bundle("strings").signals  # whose 300 bytes were mostly NULs
    assert TYPES_2_0.signal("text_511").capacity == 511  # the most the C core decodes


def test_node_sends_what_protons_node_manager_sends_when_it_does(
    programs: tuple[Path, Path],
) -> None:
    """Node and Proton's node manager (``proton_node_update``, called until it has nothing left),
    polled at the same uptimes (every 7 ms: on time, late, early) with the same triggers, send the
    same bundles in the same order, as the same bytes, but for the heartbeat's counter: the C node
    leaves counting it to its application."""
    node = Node(TYPES_2_0, "mcu")
    peer = Peer(programs[0])
    triggers = {0: ["bools"], 203: ["doubles", "strings"], 469: ["everything", "blobs"]}
    triggers |= {728: ["slow", "bools", "heartbeat"], 1001: ["int32s"]}
    try:
        # The same registry in both: the C one's strings and bytes start at their whole capacity.
        setting = [f"S {s.id} {c_value(s, node.get(s.name))}" for s in TYPES_2_0.signals]
        assert peer.ask(setting) == ["OK"] * len(setting)
        sent = 0
        for ms in range(0, 2001, 7):
            names = triggers.get(ms, [])
            for name in names:
                node.trigger(name)
            *triggered, polled = peer.ask(
                [f"T {TYPES_2_0.bundle(name).id}" for name in names] + [f"P {ms}"]
            )
            assert triggered == ["OK"] * len(names)
            theirs = [bytes.fromhex(message) for message in polled.split()[1:]]
            ours = node.poll(ms / 1000)
            assert [V2.decode(m).name for m in theirs] == [s.bundle for s in ours], ms
            for mine, message in zip(ours, theirs, strict=True):
                assert mine.bundle == "heartbeat" or mine.data == message, (ms, mine.bundle)
            sent += len(ours)
    finally:
        peer.close()
    assert sent > 60  # 40 heartbeats, 20 of everything, 16 slow and the triggered ones


@pytest.mark.parametrize("bundle", [bundle.name for bundle in TYPES_1_0.bundles])
@given(data=st.data())
@_SETTINGS
def test_bundles_byte_for_byte_with_protonc(
    protonc: Peer, bundle: str, data: st.DataObject
) -> None:
    config = TYPES_1_0.bundle(bundle)
    sent = _values(V1, bundle, data)
    ours = V1.encode(bundle, sent)
    signals = [TYPES_1_0.signal(name) for name in config.signals]
    *set_, encoded, decoded = protonc.ask(
        [f"S {config.id} {i} {c_value(s, sent[s.name])}" for i, s in enumerate(signals)]
        + [f"E {config.id}", f"D {ours.hex()}"]
    )
    assert set_ == ["OK"] * len(signals)
    assert encoded == f"OK {ours.hex()}"
    assert _same_values(V1.decode(bytes.fromhex(encoded[3:])).signals, sent)
    assert decoded == decoded_line(config.id, [c_value(s, sent[s.name]) for s in signals])


def _frames_agree(peers: tuple[Peer, ...], payload: bytes) -> None:
    ours = erc_codec.runtime.frame(payload)
    for peer in peers:
        # One request at a time: two long ones in a row would fill both pipes (a deadlock).
        (framed,) = peer.ask([f"F {payload.hex() or '-'}"])
        (unframed,) = peer.ask([f"U {ours.hex()}"])
        assert framed == f"OK {ours.hex()}"  # Proton's helpers frame as erc_codec does
        assert unframed == f"OK {payload.hex() or '-'}"  # and accept erc_codec's frame
        deframer = erc_codec.runtime.Deframer(max_length=0xFFFF)
        stream = bytes.fromhex(framed[3:])
        assert deframer.feed(stream[:3]) + deframer.feed(stream[3:]) == [payload]


@given(payload=st.binary(max_size=1024))
@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_serial_frames_deframe_in_the_other_library(
    core: Peer, protonc: Peer, payload: bytes
) -> None:
    _frames_agree((core, protonc), payload)


@pytest.mark.parametrize("length", [255, 256, 65534, 65535])
def test_the_longest_frames_too(core: Peer, protonc: Peer, length: int) -> None:
    """Lengths whose two bytes both matter, up to Proton's maximum (a uint16)."""
    _frames_agree((core, protonc), bytes(range(256)) * (length // 256) + bytes(length % 256))


def test_a_bad_crc_is_refused_by_both(core: Peer, protonc: Peer) -> None:
    broken = bytearray(erc_codec.runtime.frame(b"\x0a\x00"))
    broken[-1] ^= 0x01
    assert core.ask([f"U {broken.hex()}"]) == [f"ERR {11}"]  # PROTON_CRC16_ERROR
    assert protonc.ask([f"U {broken.hex()}"]) == ["ERR crc"]
    assert erc_codec.runtime.Deframer(max_length=16).feed(bytes(broken)) == []


# -- what erc_codec refuses, Proton's C libraries refuse or misread -----------------------------


def _verdict(program: Path, requests: list[str]) -> list[str]:
    """A fresh driver's answers to ``requests``: fewer than asked where it crashed."""
    done = subprocess.run(
        [str(program)], input="".join(f"{r}\n" for r in requests), capture_output=True, text=True
    )
    return [line for line in done.stdout.splitlines() if not line.startswith("Error: ")]


def _c_line(config: Config, version: str, bundle: str, values_: Mapping[str, object]) -> str:
    """What a driver prints for ``bundle`` holding its defaults but ``values_``."""
    found = config.bundle(bundle)
    items = []
    for name in found.signals:
        signal = config.signal(name)
        value = values_.get(name, signal.default)
        shown = c_value(signal, value)  # type: ignore[arg-type]
        items.append(f"{signal.id}={shown}" if version == "2.0" else shown)
    return decoded_line(found.id, items)


def _described() -> list[str]:
    return [f"B {bundle.id} {_specs(bundle.signals)}" for bundle in TYPES_1_0.bundles]


@pytest.mark.parametrize("case", REFUSED_2_0)
def test_what_erc_codec_refuses_the_c_core_refuses_or_misreads(
    programs: tuple[Path, Path], case: Refused
) -> None:
    requests = [f"D {case.before.hex()}"] if case.before else []
    *_, answer = _verdict(programs[0], [*requests, f"D {case.data.hex() or '-'}"])
    if isinstance(case.c, str):
        assert answer == case.c
    else:
        bundle, read = case.c
        assert answer == _c_line(TYPES_2_0, "2.0", bundle, read)


@pytest.mark.parametrize("case", ACCEPTED_2_0)
def test_what_erc_codec_decodes_the_c_core_reads_the_same(
    programs: tuple[Path, Path], case: Accepted
) -> None:
    (answer,) = _verdict(programs[0], [f"D {case.data.hex()}"])
    assert answer == _c_line(TYPES_2_0, "2.0", case.bundle, case.signals)


@pytest.mark.parametrize("case", REFUSED_1_0)
def test_what_erc_codec_refuses_protonc_refuses_or_misreads(
    programs: tuple[Path, Path], case: Refused
) -> None:
    described = _described()
    answers = _verdict(programs[1], [*described, f"D {case.data.hex()}"])
    assert answers[: len(described)] == ["OK"] * len(described)
    answer = answers[len(described)] if len(answers) > len(described) else ""  # "": it crashed
    if isinstance(case.c, str):
        assert answer == case.c
    else:
        bundle, read = case.c
        assert answer == _c_line(TYPES_1_0, "1.0", bundle, read)


@pytest.mark.parametrize("case", ACCEPTED_1_0)
def test_what_erc_codec_decodes_protonc_reads_the_same(
    programs: tuple[Path, Path], case: Accepted
) -> None:
    described = _described()
    *_, answer = _verdict(programs[1], [*described, f"D {case.data.hex()}"])
    assert answer == _c_line(TYPES_1_0, "1.0", case.bundle, case.signals)


# -- the scratch buffer ---------------------------------------------------------------------------


@pytest.fixture(scope="session")
def large(tmp_path_factory: pytest.TempPathFactory) -> tuple[Config, Path, Path]:
    """A configuration with a string of capacity 600 and bytes of 513, and Proton's core built
    for it twice: with its own scratch buffer (512 bytes) and with one of 1024."""
    _needed()
    build = tmp_path_factory.mktemp("proton-large")
    (build / "large.yaml").write_text(LARGE)
    default = _driver2(build / "large.yaml", build, "default")
    bigger = _driver2(build / "large.yaml", build, "bigger", "-DPROTON_SCRATCH_BUFFER_SIZE=1024")
    return parse_config(LARGE, "large.yaml"), default, bigger


def test_the_c_core_decodes_no_more_than_its_scratch_buffer_whatever_the_capacity(
    large: tuple[Config, Path, Path],
) -> None:
    """Why BundleCodec refuses such a configuration for 2.0 unless told the board's size."""
    config, default, bigger = large
    codec = BundleCodec(config, scratch_buffer_size=1024)
    for text, blob, fits in (
        ("x" * 510, bytes(512), True),  # 511 bytes with the NUL, and 512: the most 512 takes
        ("x" * 511, bytes(512), False),
        ("x" * 510, bytes(513), False),
    ):
        message = codec.encode("long", {"text": text, "blob": blob})
        (answer,) = _verdict(default, [f"D {message.hex()}"])
        assert answer.startswith("OK") is fits, (len(text), len(blob), answer)
        (answer,) = _verdict(bigger, [f"D {message.hex()}"])
        assert answer == f"OK 1 1={text.encode().hex()} 2={blob.hex()}"
    full = codec.encode("long", {"text": "x" * 599, "blob": bytes(513)})
    assert _verdict(bigger, [f"D {full.hex()}"]) == [f"OK 1 1={'78' * 599} 2={'00' * 513}"]
