"""erc_codec.proton's configuration loader: Proton's YAML read as its generator reads it, and every
mistake one ProtonConfigError naming the file, the line and the key."""

import os
from pathlib import Path

import pytest
from conftest import REPO

import erc_codec
from erc_codec.proton import ProtonConfigError, load_config, parse_config

BASE = """\
nodes:
  - name: pc
    id: 0
    endpoints:
      - {id: 0, type: udp4, ip: 127.0.0.1, port: 11416}
  - name: mcu
    id: 1
    endpoints:
      - {id: 0, type: udp4, ip: 127.0.0.1, port: 11417}
      - {id: 1, type: serial, device: /dev/ttyACM0}

connections:
  - first: {node: pc, id: 0}
    second: {node: mcu, id: 0}

signals:
  - {name: speed, id: 0x101, type: double}
  - {name: label, id: 0x102, type: string, capacity: 8}
  - {name: named, id: 0x103, type: string, value: "foo"}
  - {name: blob, id: 0x104, type: bytes, value: [1, 2], capacity: 4}
  - {name: beat, id: 0x105, type: uint32}

bundles:
  - name: status
    id: 0x100
    producers: [mcu]
    consumers: [pc]
    signals: [0x101, 0x102, 0x103, 0x104]
    period_ms: 100
  - name: heartbeat
    id: 0
    producers: [mcu]
    consumers: [pc]
    signals: [0x105]
    period_ms: 50
"""


def test_the_base_configuration_reads_as_proton_means_it() -> None:
    config = parse_config(BASE, "base.yaml")
    assert [node.name for node in config.nodes] == ["pc", "mcu"]
    assert config.node("mcu").endpoint(1).device == "/dev/ttyACM0"
    assert config.signal("speed").id == 0x101
    assert config.signal("speed").line == 17
    assert config.signal("named").capacity == 4  # "foo" and its NUL, as the generator sizes it
    assert config.signal("blob").default == b"\x01\x02\x00\x00"  # the registry's whole buffer
    assert config.signal("label").default == ""
    status = config.bundle("status")
    assert status.signals == ("speed", "label", "named", "blob")
    assert (status.producers, status.consumers, status.period_ms) == (("mcu",), ("pc",), 100)
    assert config.bundle("heartbeat").line == 30
    (mine, peer, theirs), *others = config.peers("mcu")
    assert (mine.id, peer.name, theirs.port, others) == (0, "pc", 11416, [])


def test_a_configuration_error_is_a_codec_error_on_one_line() -> None:
    with pytest.raises(ProtonConfigError) as caught:
        parse_config(BASE.replace("type: double", "type: float64"), "cfg.yaml")
    error = caught.value
    assert isinstance(error, erc_codec.CodecError)
    assert str(error).startswith(
        "cfg.yaml:17: signals[0].type: 'float64' is not a Proton signal type"
    )
    assert "\n" not in str(error)
    assert (error.source, error.line, error.key) == ("cfg.yaml", 17, "signals[0].type")


@pytest.mark.parametrize(
    ("old", "new", "line", "key", "problem"),
    [
        ("type: double", "type: float64", 17, "signals[0].type", "not a Proton signal type"),
        ("id: 0x102,", "id: 0x101,", 18, "signals[1]", "signal id 0x101 is used twice"),
        ("name: label", "name: speed", 18, "signals[1]", "signal name 'speed' is used twice"),
        (
            "    consumers: [pc]\n    signals: [0x101",
            "    signals: [0x101",
            24,
            "bundles[0]",
            "bundle 'status' is consumed by no node",
        ),
        (
            "consumers: [pc]\n    signals: [0x101",
            "consumers: []\n    signals: [0x101",
            27,
            "bundles[0].consumers",
            "is consumed by no node",
        ),
        (
            "producers: [mcu]\n    consumers: [pc]\n    signals: [0x101",
            "producers: [robot]\n    consumers: [pc]\n    signals: [0x101",
            26,
            "bundles[0].producers[0]",
            "no node is called 'robot'",
        ),
        (
            'value: "foo"}',
            'value: "foo", capacity: 2}',
            19,
            "signals[2].value",
            "'foo' is 3 bytes of UTF-8 and its NUL, over capacity 2 (Proton's generator sizes a "
            "default by its characters: 3): give it capacity: 4 or more",
        ),
        (
            "value: [1, 2], capacity: 4",
            "value: [1, 2, 3, 4, 5], capacity: 4",
            20,
            "signals[3].value",
            "is 5 bytes, over its capacity of 4",
        ),
        ("value: [1, 2]", "value: [1, 256]", 20, "signals[3].value", "not a byte (0..255)"),
        ("type: string, capacity: 8}", "type: string}", 18, "signals[1]", "needs a capacity"),
        (
            "type: double}",
            "type: double, capacity: 8}",
            17,
            "signals[0].capacity",
            "a double signal has no capacity",
        ),
        (
            "type: double}",
            "type: double, length: 3}",
            17,
            "signals[0].length",
            "has no length (list types do)",
        ),
        ("type: double}", "type: list_double}", 17, "signals[0]", "needs a length"),
        (
            "type: double}",
            "type: double, value: high}",
            17,
            "signals[0].value",
            "the default 'high' is not a number",
        ),
        (
            "    period_ms: 100",
            "    period: 100",
            29,
            "bundles[0].period",
            "unknown key (expected one of name, id, producers, consumers, signals, period_ms)",
        ),
        (
            "    period_ms: 100",
            "    period_ms: -1",
            29,
            "bundles[0].period_ms",
            "-1 is out of range 0..4294967295",
        ),
        (
            "signals: [0x101, 0x102",
            "signals: [0x101, 0x101",
            28,
            "bundles[0].signals[1]",
            "signal 0x101 is in the bundle twice",
        ),
        (
            "signals: [0x101, 0x102",
            "signals: [0x999, 0x102",
            28,
            "bundles[0].signals[0]",
            "no signal has id 0x999",
        ),
        (
            "    second: {node: mcu, id: 0}",
            "    second: {node: mcu, id: 7}",
            14,
            "connections[0].second.id",
            "node 'mcu' has no endpoint 7",
        ),
        (
            "    second: {node: mcu, id: 0}",
            "    second: {node: pc, id: 0}",
            13,
            "connections[0]",
            "connects node 'pc' to itself",
        ),
        (
            "ip: 127.0.0.1, port: 11416",
            "ip: 127.0.0.300, port: 11416",
            5,
            "nodes[0].endpoints[0].ip",
            "not an IPv4 address",
        ),
        ("port: 11416", "port: 70000", 5, "nodes[0].endpoints[0].port", "out of range 0..65535"),
        (
            "type: serial, device: /dev/ttyACM0",
            "type: serial",
            10,
            "nodes[1].endpoints[1]",
            "needs 'device'",
        ),
        (
            "type: serial, device: /dev/ttyACM0",
            "type: can, device: x",
            10,
            "nodes[1].endpoints[1].type",
            "'can' is not an endpoint type (udp4, serial)",
        ),
        (
            "type: serial, device: /dev/ttyACM0",
            "type: serial, device: x, port: 3",
            10,
            "nodes[1].endpoints[1].port",
            "a serial endpoint has no 'port'",
        ),
        (
            "  - name: mcu\n    id: 1",
            "  - name: mcu\n    id: 0",
            6,
            "nodes[1]",
            "node id 0x0 is used twice",
        ),
        (
            "  - name: mcu\n    id: 1",
            "  - name: mcu\n    id: 1\n    id: 2",
            8,
            "nodes[1].id",
            "given twice (first on line 7)",
        ),
        ("    period_ms: 50\n", "    period_ms: 50\nextra: 1\n", 36, "extra", "unknown key"),
        (
            "  - {name: speed, id: 0x101, type: double}\n",
            "  - {name: speed, id: true}\n",
            17,
            "signals[0].id",
            "True is not an integer",
        ),
        ("signals: [0x101, 0x102, 0x103, 0x104]", "signals: [0x101, [", 30, "", "not valid YAML"),
    ],
)
def test_every_mistake_names_its_line_and_key(
    old: str, new: str, line: int, key: str, problem: str
) -> None:
    assert old in BASE
    with pytest.raises(ProtonConfigError) as caught:
        parse_config(BASE.replace(old, new, 1), "cfg.yaml")
    error = caught.value
    assert (error.line, error.key) == (line, key), str(error)
    assert problem in error.problem, str(error)
    assert "\n" not in str(error)


def test_files_that_cannot_be_read_or_hold_nothing(tmp_path: Path) -> None:
    with pytest.raises(ProtonConfigError, match=r"missing\.yaml: cannot read it"):
        load_config(tmp_path / "missing.yaml")
    (tmp_path / "empty.yaml").write_text("# nothing\n")
    with pytest.raises(ProtonConfigError, match=r"empty\.yaml:1: the file is empty"):
        load_config(tmp_path / "empty.yaml")
    (tmp_path / "list.yaml").write_text("- 1\n")
    with pytest.raises(ProtonConfigError, match=r"list\.yaml:1: must be a mapping"):
        load_config(tmp_path / "list.yaml")


def test_defaults_and_sizes_follow_protons_generator() -> None:
    text = BASE.replace(
        "  - {name: beat, id: 0x105, type: uint32}\n",
        "  - {name: beat, id: 0x105, type: uint32}\n"
        '  - {name: exact, id: 0x106, type: string, value: "abcd", capacity: 4}\n'
        '  - {name: roomy, id: 0x107, type: string, value: "ab", capacity: 6}\n'
        "  - {name: sized, id: 0x108, type: bytes, value: [7, 8, 9]}\n"
        "  - {name: zeros, id: 0x109, type: bytes, capacity: 3}\n"
        "  - {name: ratio, id: 0x10a, type: float, value: 0.1}\n"
        "  - {name: whole, id: 0x10b, type: double, value: 3}\n"
        "  - {name: temps, id: 0x10c, type: list_float, value: [1.5, 2.5]}\n"
        '  - {name: words, id: 0x10d, type: list_string, value: ["ab", "cde"]}\n'
        "  - {name: flags, id: 0x10e, type: list_bool, length: 3}\n",
    )
    config = parse_config(text)
    assert config.signal("exact").capacity == 5  # a capacity equal to the length gets the NUL
    assert config.signal("roomy").capacity == 6
    assert (config.signal("sized").capacity, config.signal("sized").default) == (3, b"\x07\x08\x09")
    assert config.signal("zeros").default == b"\x00\x00\x00"
    assert config.signal("ratio").default == 0.10000000149011612  # a C float's 0.1
    assert config.signal("whole").default == 3.0
    temps = config.signal("temps")
    assert (temps.length, temps.default) == (2, [1.5, 2.5])
    words = config.signal("words")
    assert (words.length, words.capacity, words.default) == (2, 4, ["ab", "cde"])
    assert config.signal("flags").default == [False, False, False]


def test_protons_own_configurations_load() -> None:
    shared = REPO.parent / "shared" / "peers" / "proton"
    configs = sorted((shared / "2.0-d269668" / "core" / "tests" / "core").glob("*.yaml"))
    if not configs:
        reason = f"Proton's sources are not beside the repository ({shared})"
        if os.environ.get("ERC_REQUIRE_INTEROP") == "1":
            pytest.fail(f"ERC_REQUIRE_INTEROP=1 but {reason}")
        pytest.skip(reason)
    loaded = {path.name: load_config(path) for path in configs}
    test = loaded["test.yaml"]
    assert test.signal("really_long_string").capacity == 45
    assert test.signal("default_bytes").default == b"\x00\x01\x02"
    assert test.bundle("shared_2").signals == ("shared_signal",)
    assert [b.period_ms for b in loaded["periodic_bundle_test.yaml"].bundles] == [100, 120]
    assert loaded["periodic_bundle_test.yaml"].bundle("100_ms").period_ms == 100  # a C name


# -- what yaml.safe_load (Proton's generator) reads, and what it cannot -------------------------

NODES = """\
nodes:
  - {name: pc, id: 0, endpoints: [{id: 0, type: udp4, ip: 127.0.0.1, port: 11416}]}
  - {name: mcu, id: 1, endpoints: [{id: 0, type: udp4, ip: 127.0.0.1, port: 11417}]}
  - {name: arm, id: 2, endpoints: [{id: 0, type: udp4, ip: 127.0.0.1, port: 11418}]}
connections:
  - {first: {node: pc, id: 0}, second: {node: mcu, id: 0}}
"""
ONE_SIGNAL = "signals:\n  - {name: a, id: 1, type: uint32}\n"
ONE_BUNDLE = "bundles:\n  - {name: b, id: 2, producers: [pc], consumers: [mcu], signals: [1]}\n"


def test_merge_keys_read_as_yaml_safe_load_reads_them() -> None:
    """Proton's generator reads its configuration with yaml.safe_load, merge keys included:
    every bundle here is what yaml.safe_load makes of it (whatever its rules for a key merged
    twice, which PyYAML's versions do not agree on)."""
    yaml = pytest.importorskip("yaml")
    text = (
        NODES
        + ONE_SIGNAL
        + "bundles:\n"
        + "  - &x {name: b, id: 2, producers: [pc], consumers: [mcu], signals: [1], period_ms: 5}\n"
        + "  - {<<: *x, name: c, id: 3}\n"
        + "  - {<<: [{period_ms: 7}, *x], name: d, id: 4}\n"
        + "  - {<<: [*x, {period_ms: 7}], name: e, id: 5}\n"
        + "  - {<<: *x, name: f, id: 6, period_ms: 9}\n"  # written here: overrides the merge
    )
    config = parse_config(text)
    for expected, bundle in zip(yaml.safe_load(text)["bundles"], config.bundles, strict=True):
        got = bundle._asdict()
        assert {key: got[key] for key in ("name", "id", "period_ms")} == {
            key: expected[key] for key in ("name", "id", "period_ms")
        }
        assert list(bundle.producers) == expected["producers"]
        assert [config.signal(n).id for n in bundle.signals] == expected["signals"]
    assert config.bundle("f").period_ms == 9
    assert config.bundle("c").line == config.bundle("b").line + 1  # the record's own line


def test_a_key_written_twice_beside_a_merge_is_still_an_error() -> None:
    with pytest.raises(ProtonConfigError, match=r"bundles\[1\]\.id: given twice"):
        parse_config(
            NODES
            + ONE_SIGNAL
            + "bundles:\n"
            + "  - &x {name: b, id: 2, producers: [pc], consumers: [mcu], signals: [1]}\n"
            + "  - {<<: *x, name: c, id: 3, id: 4}\n"
        )


@pytest.mark.parametrize(
    ("text", "line", "key", "problem"),
    [
        (
            NODES + "signals:\n  - {name: a, id: !foo 1, type: uint32}\n" + ONE_BUNDLE,
            8,
            "signals[0].id",
            "cannot be read: could not determine a constructor for the tag '!foo'",
        ),
        (
            NODES + "signals:\n  - {name: a, id: !!python/int 1, type: uint32}\n" + ONE_BUNDLE,
            8,
            "signals[0].id",
            "could not determine a constructor for the tag 'tag:yaml.org,2002:python/int'",
        ),
        (
            NODES
            + "signals:\n  - {name: a, id: 1, type: double, value: 2001-02-30}\n"
            + ONE_BUNDLE,
            8,
            "signals[0].value",
            "cannot be read: day is out of range for month",
        ),
        (
            NODES
            + "signals:\n  - {name: a, id: 1, type: list_int32, value: "
            + "[" * 2000
            + "]" * 2000
            + "}\n"
            + ONE_BUNDLE,
            None,
            "",
            "nested too deeply",
        ),
        (
            NODES + ONE_SIGNAL + "bundles:\n  - {<<: 5, name: b, id: 2}\n",
            10,
            "bundles[0]",
            "a merge key (<<) it cannot use: expected a mapping or list of mappings for merging",
        ),
        (
            NODES + ONE_SIGNAL + "bundles:\n  - !foo {name: b, id: 2}\n",
            10,
            "bundles[0]",
            "a mapping tagged '!foo': write it untagged",
        ),
        (
            NODES + ONE_SIGNAL + "bundles: !!set {a}\n",
            9,
            "bundles",
            "must be a list",
        ),
        (
            NODES + ONE_SIGNAL + "bundles:\n  - {name: b, id: 2, producers: !!omap [{pc: 1}]}\n",
            10,
            "bundles[0].producers",
            "a list tagged 'tag:yaml.org,2002:omap': write it untagged",
        ),
    ],
)
def test_what_yaml_safe_load_cannot_build_is_a_config_error(
    text: str, line: int | None, key: str, problem: str
) -> None:
    with pytest.raises(ProtonConfigError) as caught:
        parse_config(text, "x.yaml")
    error = caught.value
    assert (error.line, error.key) == (line, key), str(error)
    assert problem in error.problem, str(error)
    assert "\n" not in str(error)


# -- what Proton's generator cannot build into a working registry -------------------------------


@pytest.mark.parametrize(
    ("text", "line", "key", "problem"),
    [
        (
            NODES
            + "signals:\n  - {name: speed, id: 1, type: uint32}\n"
            + "  - {name: Speed, id: 2, type: uint32}\n"
            + ONE_BUNDLE,
            9,
            "signals[1]",
            "signal name 'Speed' is used twice (as 'speed', in C) (first on line 8)",
        ),
        (
            NODES + "signals:\n  - {name: my-speed, id: 1, type: uint32}\n" + ONE_BUNDLE,
            8,
            "signals[0].name",
            "'my-speed' is not a name C can hold (ASCII letters, digits and _)",
        ),
        (
            NODES.replace("name: arm", "name: bras_é") + ONE_SIGNAL + ONE_BUNDLE,
            4,
            "nodes[2].name",
            "'bras_é' is not a name C can hold",
        ),
        (
            NODES + ONE_SIGNAL + ONE_BUNDLE.replace("consumers: [mcu]", "consumers: [mcu, arm]"),
            10,
            "bundles[0].consumers[1]",
            "node 'arm' is a consumer of bundle 'b' with no connection to 'pc': it has no one "
            "to receive it from",
        ),
        (
            NODES + ONE_SIGNAL + ONE_BUNDLE.replace("producers: [pc]", "producers: [pc, arm]"),
            10,
            "bundles[0].producers[1]",
            "node 'arm' is a producer of bundle 'b' with no connection to 'mcu': it has no one "
            "to send it to",
        ),
        (
            NODES + ONE_SIGNAL + ONE_BUNDLE.replace("consumers: [mcu]", "consumers: [pc]"),
            10,
            "bundles[0].consumers[0]",
            "node 'pc' is a consumer of bundle 'b' with no connection to no other node",
        ),
        (
            NODES + "signals:\n  - {name: a, id: 1, type: bool, value: true}\n" + ONE_BUNDLE,
            8,
            "signals[0].value",
            "Proton's generator writes the default True into C as Python spells it",
        ),
        (
            NODES + "signals:\n  - {name: a, id: 1, type: float, value: .nan}\n" + ONE_BUNDLE,
            8,
            "signals[0].value",
            "writes the default nan into C as nan, which C does not know",
        ),
        (
            NODES
            + "signals:\n  - {name: a, id: 1, type: string, value: 'say \"hi\"'}\n"
            + ONE_BUNDLE,
            8,
            "signals[0].value",
            "the default 'say \"hi\"' holds '\"' at index 4: Proton's generator writes it "
            'between quotes in C ("..."), where it would end the string or start an escape',
        ),
        (
            NODES + "signals:\n  - {name: a, id: 1, type: string, value: 'a\\\\n'}\n" + ONE_BUNDLE,
            8,
            "signals[0].value",
            "holds '\\\\' at index 1",
        ),
        (
            NODES.replace("127.0.0.1, port: 11418", "127.0.0.\u0661, port: 11418")
            + ONE_SIGNAL
            + ONE_BUNDLE,
            4,
            "nodes[2].endpoints[0].ip",
            "'127.0.0.\u0661' is not an IPv4 address",
        ),
    ],
)
def test_what_protons_generator_cannot_build_is_a_config_error(
    text: str, line: int, key: str, problem: str
) -> None:
    with pytest.raises(ProtonConfigError) as caught:
        parse_config(text, "x.yaml")
    error = caught.value
    assert (error.line, error.key) == (line, key), str(error)
    assert problem in error.problem, str(error)


def test_a_bundle_0_of_any_shape_loads_and_the_heartbeat_is_bundle_0_with_one_uint32() -> None:
    """Proton 2.0 reserves no bundle id: 0 is a bundle like any other (1.0's BundleCodec
    refuses one that is not a heartbeat, tests/proton/test_proton_codec.py)."""
    config = parse_config(
        NODES
        + "signals:\n  - {name: a, id: 1, type: double}\n"
        + "bundles:\n  - {name: b, id: 0, producers: [pc], consumers: [mcu], signals: [1]}\n"
    )
    assert config.bundle("b").id == 0


@pytest.mark.parametrize(
    ("signal", "capacity"),
    [
        ('{name: a, id: 1, type: string, value: "abc"}', 4),  # len + 1, as normalize.py
        ('{name: a, id: 1, type: string, value: "abc", capacity: 3}', 4),  # == len: + 1
        ('{name: a, id: 1, type: string, value: "é", capacity: 3}', 3),  # given: kept as given
        ('{name: a, id: 1, type: string, value: "é", capacity: 8}', 8),
    ],
)
def test_string_capacities_are_the_generators(signal: str, capacity: int) -> None:
    config = parse_config(NODES + f"signals:\n  - {signal}\n" + ONE_BUNDLE)
    assert config.signal("a").capacity == capacity


@pytest.mark.parametrize(
    ("signal", "needed"),
    [
        ('{name: a, id: 1, type: string, value: "é"}', 3),  # the generator: capacity 2
        ('{name: a, id: 1, type: string, value: "é", capacity: 1}', 3),  # == len: 2
        ('{name: a, id: 1, type: string, value: "é", capacity: 2}', 3),  # not silently 3
        ('{name: a, id: 1, type: string, value: "añob"}', 6),
    ],
)
def test_a_multibyte_default_needs_its_capacity_given(signal: str, needed: int) -> None:
    """Proton's generator sizes a string default by its characters (len(value) + 1), and writes
    it into a C buffer of that size: "é" (two bytes) into char[2] loses its NUL. Whatever
    capacity was given is never changed to fit: the error says what to write."""
    with pytest.raises(ProtonConfigError, match=f"give it capacity: {needed} or more"):
        parse_config(NODES + f"signals:\n  - {signal}\n" + ONE_BUNDLE)


def test_an_endpoint_lookup_names_what_is_missing() -> None:
    config = parse_config(BASE)
    with pytest.raises(KeyError, match="node 'pc' has no endpoint 7"):
        config.node("pc").endpoint(7)
    with pytest.raises(KeyError, match="no node is called 'base'"):
        config.node("base")
