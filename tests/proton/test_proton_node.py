"""erc_codec.proton.Node: a sans-IO Proton node under an injected clock. Its periodic and triggered
sending follows period_ms and Proton's node manager's priorities; heartbeats count and are
watched; received bundles reach the registry and their handlers."""

import math
from typing import cast

import pytest
from proton_values import TYPES_1_0, TYPES_2_0

import erc_codec
from erc_codec.proton import (
    Bundle,
    BundleCodec,
    Config,
    Node,
    ProtonConfigError,
    Sent,
    parse_config,
)
from erc_codec.runtime import Liveness

PERIODIC = parse_config(
    """\
nodes:
  - {name: producer, id: 0, endpoints: [{id: 0, type: udp4, ip: 127.0.0.1, port: 11416}]}
  - {name: consumer, id: 1, endpoints: [{id: 0, type: udp4, ip: 127.0.0.1, port: 11417}]}
  - {name: bystander, id: 2, endpoints: [{id: 0, type: udp4, ip: 127.0.0.1, port: 11418}]}
connections:
  - first: {node: producer, id: 0}
    second: {node: consumer, id: 0}
  - first: {node: producer, id: 0}
    second: {node: bystander, id: 0}
signals:
  - {name: value, id: 0x1000, type: double}
  - {name: beat, id: 0x1001, type: uint32}
  - {name: command, id: 0x1002, type: int32}
bundles:
  - {name: fast, id: 0x100, producers: [producer], consumers: [consumer], signals: [0x1000],
     period_ms: 100}
  - {name: slow, id: 0x120, producers: [producer], consumers: [consumer, bystander],
     signals: [0x1000], period_ms: 120}
  - {name: event, id: 0x130, producers: [producer], consumers: [consumer], signals: [0x1000]}
  - {name: order, id: 0x200, producers: [consumer], consumers: [producer], signals: [0x1002]}
  - {name: heartbeat, id: 0, producers: [producer, consumer], consumers: [producer, consumer],
     signals: [0x1001], period_ms: 50}
""",
    "periodic.yaml",
)


def sends(node: Node, times: list[float]) -> dict[str, list[float]]:
    """When each bundle went out, polling at each of ``times``."""
    seen: dict[str, list[float]] = {}
    for now in times:
        for sent in node.poll(now):
            seen.setdefault(sent.bundle, []).append(round(now, 6))
    return seen


def test_periodic_bundles_follow_period_ms() -> None:
    node = Node(PERIODIC, "producer")
    seen = sends(node, [ms / 1000 for ms in range(0, 1001)])  # every millisecond for a second
    assert seen["fast"] == [ms / 1000 for ms in range(100, 1001, 100)]  # the first poll: boot
    assert seen["slow"] == [ms / 1000 for ms in range(120, 1001, 120)]
    assert seen["heartbeat"] == [ms / 1000 for ms in range(50, 1001, 50)]
    assert "event" not in seen  # period_ms 0: sent only when triggered


def test_a_clock_in_seconds_that_does_not_add_up_exactly() -> None:
    node = Node(PERIODIC, "producer")
    times, now = [], 0.0
    for _ in range(30):
        times.append(now)
        now += 0.01  # 0.1 is never exactly ten of these
    assert sends(node, times)["fast"] == [0.1, 0.2]


def test_the_first_poll_is_the_nodes_boot_and_the_most_overdue_goes_first() -> None:
    node = Node(PERIODIC, "producer")
    assert node.poll(5.0) == []  # uptime 0: everything counts as just sent
    assert [s.bundle for s in node.poll(5.05)] == ["heartbeat"]
    assert [s.bundle for s in node.poll(5.1)] == ["fast", "heartbeat"]  # both on time: ids
    assert [s.bundle for s in node.poll(5.12)] == ["slow"]
    late = node.poll(5.4)  # heartbeat 250 ms overdue, fast 200, slow 160
    assert [s.bundle for s in late] == ["heartbeat", "fast", "slow"]
    assert [s.bundle for s in node.poll(5.45)] == ["heartbeat"]  # counted from 5.4, not 5.35
    assert [s.bundle for s in node.poll(5.5)] == ["fast", "heartbeat"]


def test_triggered_bundles_go_first_and_restart_the_period() -> None:
    node = Node(PERIODIC, "producer")
    node.poll(0.0)
    node.trigger("event")
    node.trigger("fast")
    node.trigger("event")  # twice before a poll: sent once
    assert [s.bundle for s in node.poll(0.06)] == ["event", "fast", "heartbeat"]
    assert node.poll(0.1) == []  # fast was sent at 0.06: due again at 0.16
    assert [s.bundle for s in node.poll(0.16)] == ["heartbeat", "slow", "fast"]


def test_a_clock_that_steps_back_never_sends_early() -> None:
    node = Node(PERIODIC, "producer")
    node.poll(10.0)
    assert node.poll(3.0) == []  # the schedule starts again from here
    assert [s.bundle for s in node.poll(3.05)] == ["heartbeat"]
    assert [s.bundle for s in node.poll(3.1)] == ["fast", "heartbeat"]


def test_what_is_sent_is_the_registry_encoded_for_its_consumers() -> None:
    node = Node(PERIODIC, "producer")
    node.set("value", 2.5)
    node.poll(0.0)
    by_name = {sent.bundle: sent for sent in node.poll(0.12)}
    codec = BundleCodec(PERIODIC)
    assert by_name["fast"] == Sent("fast", codec.encode("fast", {"value": 2.5}), ("consumer",))
    assert by_name["slow"].peers == ("consumer", "bystander")  # its consumers, connected
    assert by_name["heartbeat"].peers == ("consumer",)  # bystander does not consume it
    assert codec.decode(by_name["heartbeat"].data).signals == {"beat": 1}
    assert node.get("value") == 2.5


def test_heartbeats_count_and_peers_go_active_and_inactive() -> None:
    changes: list[tuple[str, Liveness]] = []
    producer = Node(PERIODIC, "producer")
    consumer = Node(PERIODIC, "consumer", on_peer=lambda peer, state: changes.append((peer, state)))
    assert consumer.peer_state("producer") is Liveness.INACTIVE  # watched, nothing heard yet
    beats = []
    for ms in range(0, 201, 10):
        now = ms / 1000
        for sent in producer.poll(now):
            if sent.bundle == "heartbeat":
                beats.append(consumer.receive(sent.data, now).signals["beat"])
        consumer.poll(now)
    assert beats == [1, 2, 3, 4]  # at 50, 100, 150 and 200 ms
    assert consumer.peer_state("producer") is Liveness.ACTIVE
    assert changes == [("producer", Liveness.ACTIVE)]
    consumer.poll(0.35)  # 150 ms since the last: still within three periods
    assert consumer.peer_state("producer") is Liveness.ACTIVE
    consumer.poll(0.351)
    assert consumer.peer_state("producer") is Liveness.INACTIVE
    assert changes[-1] == ("producer", Liveness.INACTIVE)
    (beat,) = [s for s in producer.poll(0.4) if s.bundle == "heartbeat"]
    consumer.receive(beat.data, 0.4)
    assert changes[-1] == ("producer", Liveness.ACTIVE)
    assert len(changes) == 3


def test_a_node_keeps_counting_its_own_heartbeats() -> None:
    node = Node(PERIODIC, "consumer")
    peer = Node(PERIODIC, "producer")
    node.poll(0.0)
    peer.poll(0.0)
    (mine,) = [s for s in node.poll(0.05) if s.bundle == "heartbeat"]
    for now in (0.05, 0.1, 0.15):
        (theirs,) = [s for s in peer.poll(now) if s.bundle == "heartbeat"]
        node.receive(theirs.data, now)
    assert BundleCodec(PERIODIC).decode(mine.data).signals == {"beat": 1}
    assert node.get("beat") == 1  # the peer's counter (3) reached the peer's state, not ours


UNWATCHED = parse_config(
    """\
nodes:
  - {name: a, id: 0, endpoints: [{id: 0, type: udp4, ip: 127.0.0.1, port: 11416}]}
  - {name: b, id: 1, endpoints: [{id: 0, type: udp4, ip: 127.0.0.1, port: 11417}]}
connections:
  - first: {node: a, id: 0}
    second: {node: b, id: 0}
signals:
  - {name: x, id: 0x1000, type: int32}
bundles:
  - {name: once, id: 0x100, producers: [a], consumers: [b], signals: [0x1000]}
""",
    "unwatched.yaml",
)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -1.0, 0, True, "1"])
@pytest.mark.parametrize(("config", "name"), [(UNWATCHED, "b"), (PERIODIC, "producer")])
def test_a_peer_timeout_that_is_no_duration_is_refused(
    config: Config, name: str, bad: object
) -> None:
    """Whether or not a peer is watched (b watches none: a sends it nothing periodic)."""
    with pytest.raises(
        ValueError,
        match=rf"^peer_timeout must be a positive, finite number of seconds, not {bad!r}$",
    ):
        Node(config, name, peer_timeout=bad)  # type: ignore[arg-type]
    assert Node(config, name, peer_timeout=0.5).name == name


def test_heartbeat_timeout_and_peers_without_heartbeats() -> None:
    config = TYPES_2_0
    pc = Node(config, "pc", peer_timeout=0.2)
    mcu = Node(config, "mcu")
    mcu.poll(0.0)
    (beat,) = [s for s in mcu.poll(0.05) if s.bundle == "heartbeat"]
    pc.receive(beat.data, 0.05)
    pc.poll(0.2)
    assert pc.peer_state("mcu") is Liveness.ACTIVE
    pc.poll(0.26)
    assert pc.peer_state("mcu") is Liveness.INACTIVE
    assert mcu.peer_state("pc") is Liveness.UNCONFIGURED  # pc sends only triggered bundles
    with pytest.raises(KeyError, match="'robot' is not a peer of node 'mcu'"):
        mcu.peer_state("robot")


def test_received_bundles_reach_the_registry_and_their_handler() -> None:
    pc = Node(TYPES_2_0, "pc")
    mcu = Node(TYPES_2_0, "mcu")
    heard: list[Bundle] = []

    @mcu.on("command")
    def on_command(bundle: Bundle) -> None:
        heard.append(bundle)
        assert mcu.get("set_speed") == 4.0  # applied before the handler runs

    pc.set("set_speed", 4.0)
    pc.set("set_name", "ares")
    pc.trigger("command")
    (sent,) = pc.poll(1.0)
    assert sent.peers == ("mcu",)
    received = mcu.receive(sent.data, 1.0, peer="pc")
    assert received == Bundle(
        "command", 0x200, {"set_speed": 4.0, "set_name": "ares", "set_mask": b"\x01\x02\x00\x00"}
    )
    assert heard == [received]
    assert (mcu.get("set_name"), mcu.get("set_mask")) == ("ares", b"\x01\x02\x00\x00")


def test_what_does_not_decode_or_is_not_consumed_changes_nothing() -> None:
    pc = Node(TYPES_2_0, "pc")
    mcu = Node(TYPES_2_0, "mcu")
    mcu.set("a_double", 1.5)
    mcu.poll(0.0)
    (everything,) = [s for s in mcu.poll(0.1) if s.bundle == "everything"]
    with pytest.raises(erc_codec.DecodeError) as caught:
        mcu.receive(everything.data, 0.0)  # mcu produces "everything", it does not consume it
    assert caught.value.reason == "not_consumed"
    assert mcu.get("a_double") == 1.5
    with pytest.raises(erc_codec.DecodeError):
        pc.receive(everything.data[:-2], 0.0)
    assert pc.get("a_double") == 0.0
    assert pc.receive(everything.data, 0.0).signals["a_double"] == 1.5


def test_misuse_is_a_typed_error_naming_what() -> None:
    """One kind of error per kind of mistake: a name the configuration (or the node's part in
    it) does not have is a KeyError, a value that cannot be sent an EncodeError."""
    node = Node(TYPES_2_0, "pc")
    with pytest.raises(KeyError, match="no signal is called 'speed'"):
        node.set("speed", 1.0)
    with pytest.raises(KeyError, match="no signal is called 'speed'"):
        node.get("speed")
    with pytest.raises(KeyError, match="'command' is in no bundle node 'bystander' produces or"):
        Node(PERIODIC, "bystander").get("command")
    with pytest.raises(erc_codec.EncodeError, match=r"signal 'set_speed' \(double\): 'x'"):
        node.set("set_speed", "x")
    with pytest.raises(KeyError, match="node 'pc' produces no bundle 'doubles'"):
        node.trigger("doubles")
    with pytest.raises(KeyError, match="no bundle is called 'orders'"):
        node.trigger("orders")
    with pytest.raises(KeyError, match="node 'pc' consumes no bundle 'command'"):
        node.register("command", print)
    with pytest.raises(KeyError, match="no bundle is called 'orders'"):
        node.register("orders", print)
    with pytest.raises(KeyError, match="no node is called 'base'"):
        Node(TYPES_2_0, "base")
    with pytest.raises(ProtonConfigError, match=r"list_double \(signal 'doubles'\) is a Proton 1"):
        Node(TYPES_1_0, "pc")
    values = Node(TYPES_1_0, "mcu", "1.0")
    lists = values.get("floats")
    assert isinstance(lists, list)
    lists.clear()  # a copy: the registry does not change
    assert values.get("floats") == [0.0] * 4


def test_protocol_1_0_heartbeat_is_bundle_0_with_one_counter() -> None:
    mcu = Node(TYPES_1_0, "mcu", "1.0")
    pc = Node(TYPES_1_0, "pc", "1.0")
    times = (0.0, 0.05, 0.1, 0.15)
    beats = [s for now in times for s in mcu.poll(now) if s.bundle == "heartbeat"]
    assert [s.data.hex() for s in beats] == ["12022801", "12022802", "12022803"]
    assert pc.receive(beats[0].data, 0.0) == Bundle("heartbeat", 0, {"beat": 1})
    assert pc.peer_state("mcu") is Liveness.ACTIVE


def test_a_clock_that_is_not_a_finite_number_is_refused_and_changes_nothing() -> None:
    """A NaN stamped on a peer's last heartbeat would make every timeout comparison false: the
    peer would stay ACTIVE forever. Infinity would make every schedule overdue forever."""
    producer, consumer = Node(PERIODIC, "producer"), Node(PERIODIC, "consumer")
    producer.poll(0.0)
    (beat,) = [s for s in producer.poll(0.05) if s.bundle == "heartbeat"]
    for now in (float("nan"), float("inf"), -float("inf"), True, "1", None):
        with pytest.raises(ValueError, match=r"now must be a finite number of seconds, not "):
            consumer.receive(beat.data, now)  # type: ignore[arg-type]
        with pytest.raises(ValueError, match="now must be a finite number"):
            producer.poll(now)  # type: ignore[arg-type]
    assert consumer.peer_state("producer") is Liveness.INACTIVE  # nothing was heard
    assert consumer.get("beat") == 0
    consumer.receive(beat.data, 0.05)
    assert consumer.peer_state("producer") is Liveness.ACTIVE
    consumer.poll(1.0)
    assert consumer.peer_state("producer") is Liveness.INACTIVE  # the timeout still works
    assert [s.bundle for s in producer.poll(0.1)] == ["fast", "heartbeat"]  # schedules intact
    assert [s.bundle for s in Node(PERIODIC, "producer").poll(-5.0)] == []  # any origin


def test_a_received_bundle_is_the_callers_and_the_registry_its_own() -> None:
    """A handler changing the lists of the bundle it is given changes nothing in the node."""
    pc, mcu = Node(TYPES_1_0, "pc", "1.0"), Node(TYPES_1_0, "mcu", "1.0")

    @mcu.on("mixed")
    def tamper(bundle: Bundle) -> None:
        texts = cast("list[str]", bundle.signals["texts"])
        texts.append("extra")

    pc.set("texts", ["a", "b", "c"])
    pc.trigger("mixed")
    (sent,) = pc.poll(0.0)
    received = mcu.receive(sent.data, 0.0)
    assert received.signals["texts"] == ["a", "b", "c", "extra"]  # the handler's to change
    assert mcu.get("texts") == ["a", "b", "c"]
    mcu.poll(0.0)
    mcu.trigger("lists")
    assert next(s.bundle for s in mcu.poll(10.0)) == "lists"  # every due bundle still encodes


ONE_LIST_TEXT = """\
nodes:
  - {name: pc, id: 0, endpoints: [{id: 0, type: udp4, ip: 127.0.0.1, port: 11416}]}
  - {name: mcu, id: 1, endpoints: [{id: 0, type: udp4, ip: 127.0.0.1, port: 11417}]}
connections:
  - {first: {node: pc, id: 0}, second: {node: mcu, id: 0}}
signals:
  - {name: temps, id: 1, type: list_float, length: 2}
  - {name: beat, id: 2, type: uint32}
bundles:
  - {name: heartbeat, id: 0, producers: [mcu], consumers: [pc], signals: [2], period_ms: 50}
  - {name: temperatures, id: 1, producers: [mcu], consumers: [pc], signals: [1], period_ms: 100}
"""
ONE_LIST = parse_config(ONE_LIST_TEXT)


def test_a_poll_that_cannot_encode_changes_nothing() -> None:
    """Every due bundle is encoded before any schedule or the heartbeat counter moves: a poll
    returns them all, or raises and leaves the node as it was. (A value cannot go bad through
    the node; a configuration's default changed after loading can.)"""
    config = ONE_LIST._replace(
        signals=tuple(
            s._replace(default=[0.0]) if s.name == "temps" else s for s in ONE_LIST.signals
        )
    )
    mcu = Node(config, "mcu", "1.0")
    mcu.poll(0.0)
    with pytest.raises(
        erc_codec.EncodeError, match="a list_float of length 2 is sent as exactly 2"
    ):
        mcu.poll(0.1)  # the heartbeat (encoded first: 50 ms overdue) and temperatures
    assert mcu.get("beat") == 0  # not counted: nothing was sent
    mcu.set("temps", [1.5, 2.5])
    sent = mcu.poll(0.1)
    assert [s.bundle for s in sent] == ["heartbeat", "temperatures"]  # both still due
    assert BundleCodec(config, "1.0").decode(sent[0].data).signals == {"beat": 1}


def test_any_bundle_from_a_watched_peer_proves_it_alive() -> None:
    """A peer sending periodic bundles but no heartbeat is watched by its fastest one; any
    bundle it produces counts. A peer sending only triggered bundles is UNCONFIGURED: nothing
    says when to expect it."""
    changes: list[tuple[str, Liveness]] = []
    config = parse_config(
        ONE_LIST_TEXT.replace("heartbeat, id: 0", "status, id: 0x10").replace(
            "signals: [2], period_ms: 50", "signals: [2], period_ms: 0"
        )
    )
    pc = Node(config, "pc", "1.0", on_peer=lambda peer, state: changes.append((peer, state)))
    mcu = Node(config, "mcu", "1.0")
    assert pc.peer_state("mcu") is Liveness.INACTIVE  # watched by temperatures' 100 ms
    assert mcu.peer_state("pc") is Liveness.UNCONFIGURED  # pc sends mcu nothing
    mcu.poll(0.0)
    for ms in range(0, 301, 10):
        for sent in mcu.poll(ms / 1000):
            pc.receive(sent.data, ms / 1000)
        pc.poll(ms / 1000)
    assert pc.peer_state("mcu") is Liveness.ACTIVE
    mcu.trigger("status")
    (status,) = mcu.poll(0.35)  # temperatures went at 0.3: not due until 0.4
    pc.receive(status.data, 0.35)  # a triggered bundle counts too
    pc.poll(0.64)
    assert pc.peer_state("mcu") is Liveness.ACTIVE  # 290 ms since status: within 300
    pc.poll(0.66)
    assert changes == [("mcu", Liveness.ACTIVE), ("mcu", Liveness.INACTIVE)]
