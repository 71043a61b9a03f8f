"""A Proton configuration (the YAML of Proton 2.0's ``core/tests/core/*.yaml``) as checked records.

Guarantees: a configuration that loads is one Proton's generator reads (``yaml.safe_load``: merge
keys included) and turns into a working registry: every name is ASCII letters, digits and ``_``,
unique where Proton looks it up and where the generated C names it (``PROTON_SIGNAL_<NAME>_ID``: so
``speed`` and ``Speed`` collide); every id is unique; every reference (a connection's endpoint, a
bundle's producers, consumers and signals) resolves; every bundle has a producer and a consumer,
each consumer connected to one of its producers and each producer to one of its consumers (else
what it sends would reach no one); every default fits its signal and is one the generator can write
into C (not a bool, NaN or infinity, nor a string with ``"``, ``\\`` or a control character).
Anything else is one ``ProtonConfigError`` naming the file, the line and the key, never another
exception. A key Proton does not know is an error too: a misspelt ``period_ms`` would otherwise
leave a bundle silently unsent. Nothing here depends on a protocol version: list types (1.0's)
load, and a ``BundleCodec`` for 2.0 refuses them (and the capacities its C core cannot decode); a
1.0 one refuses a bundle 0 that is not a heartbeat.

Read as Proton's generator reads it (``generator_scripts/normalize.py``): ``capacity`` 0 means "not
given"; a string with a default value and no capacity (or a capacity equal to the value's length)
gets the value's length plus its NUL, the length counted in characters as the generator counts it,
so a default with multi-byte UTF-8 needs its capacity given (the error says which); a bytes
default is padded with zeros to the capacity (the generated registry holds, and sends, the whole
buffer until the signal is set); a list's ``length`` defaults to the length of its default value.
Integers are YAML 1.1's, so ``0x101`` reads as 257, as it does for the generator.
"""

import math
import re
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any, Literal, NamedTuple, Protocol, TypeVar, cast

from erc_schema import CodecError

from ._types import TYPES, SignalType, Value, check, is_list, needs_capacity, zero

__all__ = [
    "BundleConfig",
    "Config",
    "ConnectionConfig",
    "EndpointConfig",
    "EndpointType",
    "NodeConfig",
    "ProtonConfigError",
    "SignalConfig",
    "load_config",
    "parse_config",
]

EndpointType = Literal["udp4", "serial"]

_UINT32 = (1 << 32) - 1
_MAX_CAPACITY = 0xFFFF  # signal_desc_t.capacity is a uint16_t
_NAME = re.compile(r"[A-Za-z0-9_]+")  # the generator writes PROTON_SIGNAL_<NAME>_ID and such
_NOT_IN_A_C_STRING = re.compile(r'["\\\x00-\x1f\x7f]')  # what "{{ value }}" in C cannot hold
_MAP, _SEQ, _MERGE = (f"tag:yaml.org,2002:{name}" for name in ("map", "seq", "merge"))
_T = TypeVar("_T")


class _Record(Protocol):
    @property
    def name(self) -> str: ...

    @property
    def id(self) -> int: ...


_R = TypeVar("_R", bound=_Record)


class ProtonConfigError(CodecError):
    """A Proton configuration that cannot be used: ``source:line: key: what is wrong``."""

    def __init__(self, source: str, line: int | None, key: str, problem: str) -> None:
        where = f"{source}:{line}" if line is not None else source
        super().__init__(f"{where}: {key}: {problem}" if key else f"{where}: {problem}")
        self.source = source
        self.line = line
        self.key = key
        self.problem = problem


class EndpointConfig(NamedTuple):
    """Where a node can be reached: ``udp4`` (``ip``, ``port``) or ``serial`` (``device``)."""

    id: int
    type: EndpointType
    ip: str | None
    port: int | None
    device: str | None
    line: int

    @property
    def address(self) -> tuple[str, int] | None:
        """``(ip, port)`` of a udp4 endpoint, ``None`` for a serial one."""
        return None if self.ip is None or self.port is None else (self.ip, self.port)


class NodeConfig(NamedTuple):
    """A participant of the network."""

    name: str
    id: int
    endpoints: tuple[EndpointConfig, ...]
    line: int

    def endpoint(self, endpoint_id: int) -> EndpointConfig:
        """The endpoint with id ``endpoint_id`` (``KeyError`` if it has none)."""
        for endpoint in self.endpoints:
            if endpoint.id == endpoint_id:
                return endpoint
        raise KeyError(f"node {self.name!r} has no endpoint {endpoint_id}")


class ConnectionConfig(NamedTuple):
    """Two nodes paired through one endpoint each: ``(node name, endpoint id)``."""

    first: tuple[str, int]
    second: tuple[str, int]
    line: int


class SignalConfig(NamedTuple):
    """A typed value. ``capacity``: bytes a string (its NUL included) or bytes value may take, 0
    for other types; ``length``: items of a list type, 0 for scalars; ``default``: its value until
    it is set or received."""

    name: str
    id: int
    type: SignalType
    capacity: int
    length: int
    default: Value
    line: int


class BundleConfig(NamedTuple):
    """Signals sent together, by name in the configuration's order; ``period_ms`` 0: sent only
    when triggered."""

    name: str
    id: int
    producers: tuple[str, ...]
    consumers: tuple[str, ...]
    signals: tuple[str, ...]
    period_ms: int
    line: int


class Config(NamedTuple):
    """A whole configuration; ``source`` is the file it came from."""

    source: str
    nodes: tuple[NodeConfig, ...]
    connections: tuple[ConnectionConfig, ...]
    signals: tuple[SignalConfig, ...]
    bundles: tuple[BundleConfig, ...]

    def node(self, name: str) -> NodeConfig:
        """The node called ``name`` (``KeyError`` if none is)."""
        return _named(self.nodes, name, "node")

    def signal(self, name: str) -> SignalConfig:
        """The signal called ``name`` (``KeyError`` if none is)."""
        return _named(self.signals, name, "signal")

    def bundle(self, name: str) -> BundleConfig:
        """The bundle called ``name`` (``KeyError`` if none is)."""
        return _named(self.bundles, name, "bundle")

    def peers(self, name: str) -> tuple[tuple[EndpointConfig, NodeConfig, EndpointConfig], ...]:
        """Node ``name``'s connections: (its endpoint, the peer, the peer's endpoint) each."""
        found = []
        for connection in self.connections:
            for (mine, my_endpoint), (theirs, their_endpoint) in (
                (connection.first, connection.second),
                (connection.second, connection.first),
            ):
                if mine == name:
                    peer = self.node(theirs)
                    found.append(
                        (self.node(mine).endpoint(my_endpoint), peer, peer.endpoint(their_endpoint))
                    )
        return tuple(found)


def _named(records: Iterable[_T], name: str, what: str) -> _T:
    for record in records:
        if getattr(record, "name", None) == name:
            return record
    raise KeyError(f"no {what} is called {name!r}")


def load_config(path: str | Path) -> Config:
    """The configuration in the YAML file at ``path``."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as error:
        reason = error.strerror if isinstance(error, OSError) and error.strerror else error
        raise ProtonConfigError(str(path), None, "", f"cannot read it: {reason}") from None
    return parse_config(text, str(path))


def parse_config(text: str, source: str = "<config>") -> Config:
    """The configuration YAML ``text`` spells; ``source`` names it in errors."""
    try:
        import yaml  # the proton extra; loaded only when a configuration is read
    except ImportError:
        raise ModuleNotFoundError(
            "reading a Proton configuration needs pyyaml: pip install 'erc-codec[proton]'",
            name="yaml",
        ) from None

    try:
        document = yaml.compose(text, Loader=yaml.SafeLoader)
    except yaml.MarkedYAMLError as error:
        mark = error.problem_mark or error.context_mark
        line = mark.line + 1 if mark is not None else None
        problem = " ".join(str(error.problem or error.context or "not YAML").split())
        raise ProtonConfigError(source, line, "", f"not valid YAML: {problem}") from None
    except yaml.YAMLError as error:
        raise ProtonConfigError(source, None, "", f"not valid YAML: {error}") from None
    except RecursionError:
        raise ProtonConfigError(
            source, None, "", "not valid YAML here: nested too deeply to read"
        ) from None
    if document is None:
        raise ProtonConfigError(source, 1, "", "the file is empty")
    return _Reader(source).config(document)


class _Field(NamedTuple):
    key: str  # its path, as errors name it: bundles[2].period_ms
    line: int
    node: Any  # a yaml node


class _Reader:
    """Reads a composed YAML document into records, with the line of every key at hand."""

    def __init__(self, source: str) -> None:
        import yaml

        self._yaml = yaml
        self._constructor = yaml.constructor.SafeConstructor()
        self._merged: dict[int, int] = {}  # id of a mapping node: how many pairs merge keys gave
        self.source = source

    def fail(self, field: _Field, problem: str) -> ProtonConfigError:
        return ProtonConfigError(self.source, field.line, field.key, problem)

    # -- shapes --------------------------------------------------------------------------------

    def mapping(self, field: _Field, allowed: Iterable[str]) -> dict[str, _Field]:
        """The keys of a mapping, merge keys (``<<: *anchor``) resolved as yaml.safe_load
        resolves them (a key written here overrides a merged one); a key written twice here, or
        not in ``allowed``, is an error."""
        node = field.node
        if not isinstance(node, self._yaml.MappingNode):
            raise self.fail(field, "must be a mapping (key: value)")
        self.plain(field, _MAP, "mapping")
        merged = self.merged(field)
        allowed = tuple(allowed)
        found: dict[str, _Field] = {}
        written: set[str] = set()
        for index, (key_node, value_node) in enumerate(node.value):
            line = key_node.start_mark.line + 1
            key = self.scalar(_Field(field.key or "key", line, key_node))
            path = f"{field.key}.{key}" if field.key else str(key)
            if not isinstance(key, str):
                raise ProtonConfigError(self.source, line, field.key, f"{key!r} is not a key")
            if key in written:
                raise ProtonConfigError(
                    self.source, line, path, f"given twice (first on line {found[key].line})"
                )
            if key not in allowed:
                raise ProtonConfigError(
                    self.source, line, path, f"unknown key (expected one of {', '.join(allowed)})"
                )
            if index >= merged:
                written.add(key)
            found[key] = _Field(path, line, value_node)
        return found

    def merged(self, field: _Field) -> int:
        """Resolve the mapping's merge keys in place (once: an anchored mapping may be read
        again through an alias); how many of its pairs, at its start, they brought."""
        node = field.node
        if id(node) not in self._merged:
            own = sum(1 for key, _ in node.value if key.tag != _MERGE)
            if own < len(node.value):
                try:
                    self._constructor.flatten_mapping(node)
                except self._yaml.YAMLError as error:
                    problem = f"a merge key (<<) it cannot use: {_problem(error)}"
                    raise self.fail(field, problem) from None
            self._merged[id(node)] = len(node.value) - own
        return self._merged[id(node)]

    def plain(self, field: _Field, tag: str, what: str) -> None:
        """A mapping or a list must carry no tag of its own: yaml.safe_load (the generator) would
        build something else of it, or fail."""
        if field.node.tag != tag:
            raise self.fail(field, f"a {what} tagged {field.node.tag!r}: write it untagged")

    def sequence(self, field: _Field) -> list[_Field]:
        if not isinstance(field.node, self._yaml.SequenceNode):
            raise self.fail(field, "must be a list")
        self.plain(field, _SEQ, "list")
        return [
            _Field(f"{field.key}[{i}]", item.start_mark.line + 1, item)
            for i, item in enumerate(field.node.value)
        ]

    def scalar(self, field: _Field) -> Any:
        if not isinstance(field.node, self._yaml.ScalarNode):
            raise self.fail(field, "must be a single value")
        return self.built(field, deep=False)

    def value(self, field: _Field) -> Any:
        """Any YAML value, built as yaml.safe_load would build it."""
        return self.built(field, deep=True)

    def built(self, field: _Field, deep: bool) -> Any:
        """The node's value as yaml.safe_load builds it; what it cannot build (an unknown tag, a
        date that does not exist, nesting past Python's stack) is an error naming the line."""
        try:
            return self._constructor.construct_object(field.node, deep=deep)
        except self._yaml.YAMLError as error:
            raise self.fail(field, f"cannot be read: {_problem(error)}") from None
        except (ValueError, OverflowError) as error:
            raise self.fail(field, f"cannot be read: {error}") from None
        except RecursionError:
            raise self.fail(field, "cannot be read: nested too deeply") from None

    def required(self, keys: dict[str, _Field], key: str, within: _Field) -> _Field:
        if key not in keys:
            raise self.fail(within, f"needs {key!r}")
        return keys[key]

    def integer(self, field: _Field, low: int = 0, high: int = _UINT32) -> int:
        value = self.scalar(field)
        if not isinstance(value, int) or isinstance(value, bool):
            raise self.fail(field, f"{value!r} is not an integer")
        if not low <= value <= high:
            raise self.fail(field, f"{value} is out of range {low}..{high}")
        return value

    def text(self, field: _Field) -> str:
        value = self.scalar(field)
        if not isinstance(value, str) or not value:
            raise self.fail(field, f"{value!r} is not a name")
        return value

    def name(self, field: _Field) -> str:
        """A node's, signal's or bundle's name: the generator makes C names of it."""
        value = self.text(field)
        if not _NAME.fullmatch(value):
            raise self.fail(
                field,
                f"{value!r} is not a name C can hold (ASCII letters, digits and _): Proton's "
                "generator makes C identifiers of it (PROTON_SIGNAL_<NAME>_ID, ...)",
            )
        return value

    def names(self, field: _Field) -> list[tuple[str, _Field]]:
        return [(self.text(item), item) for item in self.sequence(field)]

    # -- the document --------------------------------------------------------------------------

    def config(self, document: Any) -> Config:
        top = self.mapping(
            _Field("", document.start_mark.line + 1, document),
            ("nodes", "connections", "signals", "bundles"),
        )
        whole = _Field("", 1, document)
        nodes = self.each(self.required(top, "nodes", whole), self.node, "node")
        connections = (
            tuple(self.connection(item, nodes) for item in self.sequence(top["connections"]))
            if "connections" in top
            else ()
        )
        signals = self.each(self.required(top, "signals", whole), self.signal, "signal")
        linked = {frozenset((c.first[0], c.second[0])) for c in connections}
        bundles = self.each(
            self.required(top, "bundles", whole),
            lambda item: self.bundle(item, nodes, signals, linked),
            "bundle",
        )
        return Config(
            self.source,
            tuple(node for node, _ in nodes.values()),
            connections,
            tuple(signal for signal, _ in signals.values()),
            tuple(bundle for bundle, _ in bundles.values()),
        )

    def each(
        self, field: _Field, read: Callable[[_Field], _R], what: str
    ) -> dict[str, tuple[_R, _Field]]:
        """Every record of a list, by name; a name (in any case: the generator upper-cases it
        into C names) or an id given twice is an error."""
        by_name: dict[str, tuple[_R, _Field]] = {}
        by_upper: dict[str, str] = {}
        ids: dict[int, _Field] = {}
        for item in self.sequence(field):
            record = read(item)
            name, number = record.name, record.id
            if name.upper() in by_upper:
                first = by_name[by_upper[name.upper()]]
                same = "" if first[0].name == name else f" (as {first[0].name!r}, in C)"
                raise self.fail(
                    item,
                    f"{what} name {name!r} is used twice{same} (first on line {first[1].line})",
                )
            if number in ids:
                raise self.fail(
                    item, f"{what} id {number:#x} is used twice (first on line {ids[number].line})"
                )
            by_name[name], by_upper[name.upper()], ids[number] = (record, item), name, item
        return by_name

    def node(self, item: _Field) -> NodeConfig:
        keys = self.mapping(item, ("name", "id", "endpoints"))
        endpoints: dict[int, EndpointConfig] = {}
        for field in self.sequence(self.required(keys, "endpoints", item)):
            endpoint = self.endpoint(field)
            if endpoint.id in endpoints:
                first = endpoints[endpoint.id].line
                raise self.fail(field, f"endpoint id {endpoint.id} is used twice (line {first})")
            endpoints[endpoint.id] = endpoint
        if not endpoints:
            raise self.fail(keys["endpoints"], "a node needs at least one endpoint")
        return NodeConfig(
            self.name(self.required(keys, "name", item)),
            self.integer(self.required(keys, "id", item)),
            tuple(endpoints.values()),
            item.line,
        )

    def endpoint(self, item: _Field) -> EndpointConfig:
        keys = self.mapping(item, ("id", "type", "ip", "port", "device"))
        number = self.integer(self.required(keys, "id", item))
        kind = self.text(self.required(keys, "type", item))
        wanted = {"udp4": ("ip", "port"), "serial": ("device",)}
        if kind not in wanted:
            raise self.fail(keys["type"], f"{kind!r} is not an endpoint type (udp4, serial)")
        for key in keys.keys() - {"id", "type", *wanted[kind]}:
            raise self.fail(keys[key], f"a {kind} endpoint has no {key!r}")
        for key in wanted[kind]:
            self.required(keys, key, item)
        ip = port = device = None
        if kind == "udp4":
            ip = self.text(keys["ip"])
            if not _is_ipv4(ip):
                raise self.fail(keys["ip"], f"{ip!r} is not an IPv4 address")
            port = self.integer(keys["port"], high=0xFFFF)
        else:
            device = self.text(keys["device"])
        return EndpointConfig(number, cast(EndpointType, kind), ip, port, device, item.line)

    def connection(
        self, item: _Field, nodes: dict[str, tuple[NodeConfig, _Field]]
    ) -> ConnectionConfig:
        keys = self.mapping(item, ("first", "second"))
        ends = []
        for side in ("first", "second"):
            field = self.required(keys, side, item)
            end = self.mapping(field, ("node", "id"))
            name = self.text(self.required(end, "node", field))
            number = self.integer(self.required(end, "id", field))
            if name not in nodes:
                raise self.fail(end["node"], f"no node is called {name!r}")
            if all(e.id != number for e in nodes[name][0].endpoints):
                raise self.fail(end["id"], f"node {name!r} has no endpoint {number}")
            ends.append((name, number))
        if ends[0][0] == ends[1][0]:
            raise self.fail(item, f"connects node {ends[0][0]!r} to itself")
        return ConnectionConfig(ends[0], ends[1], item.line)

    def signal(self, item: _Field) -> SignalConfig:
        keys = self.mapping(item, ("name", "id", "type", "capacity", "length", "value"))
        name = self.name(self.required(keys, "name", item))
        number = self.integer(self.required(keys, "id", item))
        kind = self.text(self.required(keys, "type", item))
        if kind not in TYPES:
            raise self.fail(
                keys["type"], f"{kind!r} is not a Proton signal type ({', '.join(TYPES)})"
            )
        signal_type: SignalType = kind  # narrowed by TYPES, the Literal's values
        capacity = self.integer(keys["capacity"], high=_MAX_CAPACITY) if "capacity" in keys else 0
        length = self.integer(keys["length"], high=0xFFFF) if "length" in keys else 0
        if "capacity" in keys and not needs_capacity(kind):
            raise self.fail(keys["capacity"], f"a {kind} signal has no capacity")
        if "length" in keys and not is_list(kind):
            raise self.fail(keys["length"], f"a {kind} signal has no length (list types do)")
        default = None
        if "value" in keys:
            given = self.value(keys["value"])
            capacity, length = _sized(kind, capacity, length, given)
            default = self.default(keys["value"], signal_type, capacity, length, given)
        if needs_capacity(kind) and capacity == 0:
            raise self.fail(item, f"a {kind} signal needs a capacity (or a default value)")
        if is_list(kind) and length == 0:
            raise self.fail(item, f"a {kind} signal needs a length (or a default value)")
        if default is None:
            default = zero(kind, capacity, length)
        return SignalConfig(name, number, signal_type, capacity, length, default, item.line)

    def default(
        self, field: _Field, kind: SignalType, capacity: int, length: int, given: Any
    ) -> Value:
        """A default value, as the generator writes it into the registry (bytes padded)."""
        if kind == "string" and isinstance(given, str):
            self.c_string(field, given, capacity)
        elif kind == "bool":
            raise self.fail(
                field,
                f"Proton's generator writes the default {given!r} into C as Python spells it "
                "(True, False), which C does not know: leave it out (false) and set the signal",
            )
        elif kind in ("double", "float") and isinstance(given, float) and not math.isfinite(given):
            raise self.fail(
                field,
                f"Proton's generator writes the default {given!r} into C as {given!r}, which C "
                "does not know: leave it out (0.0) and set the signal",
            )
        try:
            if kind == "bytes":
                given = _padded(given, capacity)
            elif kind == "list_bytes" and isinstance(given, list):
                given = [_padded(item, capacity) for item in given]
            return check(kind, capacity, length, given, "2.0")
        except ValueError as error:
            raise self.fail(field, f"the default {error}") from None

    def c_string(self, field: _Field, given: str, capacity: int) -> None:
        """A string default as the generator writes it: between quotes in C, sized by its
        characters (normalize.py's ``len(value)``), so it must fit its bytes and its NUL."""
        bad = _NOT_IN_A_C_STRING.search(given)
        if bad is not None:
            raise self.fail(
                field,
                f"the default {given!r} holds {bad.group()!r} at index {bad.start()}: Proton's "
                'generator writes it between quotes in C ("..."), where it would end the string '
                "or start an escape",
            )
        size = len(given.encode("utf-8", "surrogatepass"))
        if size + 1 > capacity:
            raise self.fail(
                field,
                f"the default {given!r} is {size} bytes of UTF-8 and its NUL, over capacity "
                f"{capacity} (Proton's generator sizes a default by its characters: "
                f"{len(given)}): "
                f"give it capacity: {size + 1} or more",
            )

    def bundle(
        self,
        item: _Field,
        nodes: dict[str, tuple[NodeConfig, _Field]],
        signals: dict[str, tuple[SignalConfig, _Field]],
        linked: set[frozenset[str]],
    ) -> BundleConfig:
        keys = self.mapping(item, ("name", "id", "producers", "consumers", "signals", "period_ms"))
        name = self.name(self.required(keys, "name", item))
        number = self.integer(self.required(keys, "id", item))
        ends: dict[str, tuple[tuple[str, _Field], ...]] = {}
        for side in ("producers", "consumers"):
            if side not in keys or not self.sequence(keys[side]):
                what = "produced" if side == "producers" else "consumed"
                raise self.fail(keys.get(side, item), f"bundle {name!r} is {what} by no node")
            listed: dict[str, _Field] = {}
            for node, field in self.names(keys[side]):
                if node not in nodes:
                    raise self.fail(field, f"no node is called {node!r}")
                if node in listed:
                    raise self.fail(field, f"node {node!r} is listed twice")
                listed[node] = field
            ends[side] = tuple(listed.items())
        self.reachable(name, ends["producers"], ends["consumers"], linked)
        by_id = {signal.id: signal for signal, _ in signals.values()}
        members: list[str] = []
        for field in self.sequence(self.required(keys, "signals", item)):
            signal_id = self.integer(field)
            if signal_id not in by_id:
                raise self.fail(field, f"no signal has id {signal_id:#x}")
            if by_id[signal_id].name in members:
                raise self.fail(field, f"signal {signal_id:#x} is in the bundle twice")
            members.append(by_id[signal_id].name)
        period = self.integer(keys["period_ms"]) if "period_ms" in keys else 0
        return BundleConfig(
            name,
            number,
            tuple(node for node, _ in ends["producers"]),
            tuple(node for node, _ in ends["consumers"]),
            tuple(members),
            period,
            item.line,
        )

    def reachable(
        self,
        bundle: str,
        producers: tuple[tuple[str, _Field], ...],
        consumers: tuple[tuple[str, _Field], ...],
        linked: set[frozenset[str]],
    ) -> None:
        """Each consumer is connected to a producer, each producer to a consumer: a node sends
        a bundle to its consumers among its connections, and to nothing else."""
        for (node, field), others, role, verb in (
            *((end, producers, "consumer", "receive it from") for end in consumers),
            *((end, consumers, "producer", "send it to") for end in producers),
        ):
            peers = [other for other, _ in others if other != node]
            if not any(frozenset((node, peer)) in linked for peer in peers):
                listed = ", ".join(repr(peer) for peer in peers) or "no other node"
                raise self.fail(
                    field,
                    f"node {node!r} is a {role} of bundle {bundle!r} with no connection to "
                    f"{listed}: it has no one to {verb}",
                )


def _problem(error: Exception) -> str:
    """A YAML error's problem, on one line, without the excerpt of the file it prints."""
    text = getattr(error, "problem", None) or str(error)
    return " ".join(str(text).split())


def _sized(kind: str, capacity: int, length: int, given: Any) -> tuple[int, int]:
    """Capacity and length as the generator settles them from a default value."""
    if is_list(kind) and length == 0 and isinstance(given, list):
        length = len(given)
    if kind == "string" and isinstance(given, str):
        if capacity in (0, len(given)):  # normalize.py: len(value) + 1, in characters
            capacity = len(given) + 1
    elif kind == "bytes" and isinstance(given, list) and capacity == 0:
        capacity = len(given)
    elif kind == "list_string" and isinstance(given, list) and capacity == 0:
        sizes = [
            len(item.encode("utf-8", "surrogatepass")) for item in given if isinstance(item, str)
        ]
        capacity = max(sizes, default=0) + 1  # 1.0's generator is not published: room for all
    elif kind == "list_bytes" and isinstance(given, list) and capacity == 0:
        capacity = max((len(item) for item in given if isinstance(item, list)), default=0)
    return capacity, length


def _padded(given: Any, capacity: int) -> Any:
    """A bytes default (a list of byte values) as the registry's buffer holds it."""
    if not isinstance(given, list):
        return given  # check() says what is wrong with it
    for value in given:
        if not isinstance(value, int) or isinstance(value, bool) or not 0 <= value <= 255:
            raise ValueError(f"{given!r} holds {value!r}, which is not a byte (0..255)")
    if len(given) > capacity:
        raise ValueError(f"{given!r} is {len(given)} bytes, over its capacity of {capacity}")
    return bytes(given) + bytes(capacity - len(given))


def _is_ipv4(text: str) -> bool:
    parts = text.split(".")
    return len(parts) == 4 and all(
        p.isascii() and p.isdigit() and int(p) <= 255 and len(p) <= 3 for p in parts
    )
