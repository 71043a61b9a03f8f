"""A Proton configuration (the YAML of Proton 2.0's ``core/tests/core/*.yaml``) as checked records.

Guarantees: a configuration that loads is one Proton's generator would turn into a working
registry: every name and id is unique where Proton looks it up, every reference (a connection's
endpoint, a bundle's producers, consumers and signals) resolves, every bundle has a producer and a
consumer, every default fits its signal. Anything else is one ``ProtonConfigError`` naming the file,
the line and the key. A key Proton does not know is an error too: a misspelt ``period_ms`` would
otherwise leave a bundle silently unsent. Nothing here depends on a protocol version; list types
(Proton 1.0's) load, and a ``BundleCodec`` for 2.0 refuses them.

Read as Proton's generator reads it (``generator_scripts/normalize.py``): ``capacity`` 0 means "not
given"; a string with a default value and no capacity (or a capacity equal to the value's length)
gets the value's length plus its NUL; a bytes default is padded with zeros to the capacity (the
generated registry holds, and sends, the whole buffer until the signal is set); a list's
``length`` defaults to the length of its default value. Integers are YAML 1.1's, so ``0x101``
reads as 257, as it does for the generator.
"""

from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any, NamedTuple, Protocol, TypeVar

from .._errors import CodecError
from ._types import TYPES, Value, check, is_list, needs_capacity, zero

__all__ = [
    "BundleConfig",
    "Config",
    "ConnectionConfig",
    "EndpointConfig",
    "NodeConfig",
    "ProtonConfigError",
    "SignalConfig",
    "load_config",
    "parse_config",
]

_UINT32 = (1 << 32) - 1
_MAX_CAPACITY = 0xFFFF  # signal_desc_t.capacity is a uint16_t
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
    type: str
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
        return next(e for e in self.endpoints if e.id == endpoint_id)


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
    type: str
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
    import yaml  # the proton extra; loaded only when a configuration is read

    try:
        document = yaml.compose(text, Loader=yaml.SafeLoader)
    except yaml.MarkedYAMLError as error:
        mark = error.problem_mark or error.context_mark
        line = mark.line + 1 if mark is not None else None
        problem = " ".join(str(error.problem or error.context or "not YAML").split())
        raise ProtonConfigError(source, line, "", f"not valid YAML: {problem}") from None
    except yaml.YAMLError as error:
        raise ProtonConfigError(source, None, "", f"not valid YAML: {error}") from None
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
        self.source = source

    def fail(self, field: _Field, problem: str) -> ProtonConfigError:
        return ProtonConfigError(self.source, field.line, field.key, problem)

    # -- shapes --------------------------------------------------------------------------------

    def mapping(self, field: _Field, allowed: Iterable[str]) -> dict[str, _Field]:
        """The keys of a mapping; a key given twice or not in ``allowed`` is an error."""
        if not isinstance(field.node, self._yaml.MappingNode):
            raise self.fail(field, "must be a mapping (key: value)")
        allowed = tuple(allowed)
        found: dict[str, _Field] = {}
        for key_node, value_node in field.node.value:
            line = key_node.start_mark.line + 1
            key = self.scalar(_Field(field.key or "key", line, key_node))
            path = f"{field.key}.{key}" if field.key else str(key)
            if not isinstance(key, str):
                raise ProtonConfigError(self.source, line, field.key, f"{key!r} is not a key")
            if key in found:
                raise ProtonConfigError(
                    self.source, line, path, f"given twice (first on line {found[key].line})"
                )
            if key not in allowed:
                raise ProtonConfigError(
                    self.source, line, path, f"unknown key (expected one of {', '.join(allowed)})"
                )
            found[key] = _Field(path, line, value_node)
        return found

    def sequence(self, field: _Field) -> list[_Field]:
        if not isinstance(field.node, self._yaml.SequenceNode):
            raise self.fail(field, "must be a list")
        return [
            _Field(f"{field.key}[{i}]", item.start_mark.line + 1, item)
            for i, item in enumerate(field.node.value)
        ]

    def scalar(self, field: _Field) -> Any:
        if not isinstance(field.node, self._yaml.ScalarNode):
            raise self.fail(field, "must be a single value")
        return self._constructor.construct_object(field.node)

    def value(self, field: _Field) -> Any:
        """Any YAML value, built as yaml.safe_load would build it."""
        return self._constructor.construct_object(field.node, deep=True)

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
        bundles = self.each(
            self.required(top, "bundles", whole),
            lambda item: self.bundle(item, nodes, signals),
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
        """Every record of a list, by name; a name or an id given twice is an error."""
        by_name: dict[str, tuple[_R, _Field]] = {}
        ids: dict[int, _Field] = {}
        for item in self.sequence(field):
            record = read(item)
            name, number = record.name, record.id
            if name in by_name:
                first = by_name[name][1].line
                raise self.fail(item, f"{what} name {name!r} is used twice (first on line {first})")
            if number in ids:
                raise self.fail(
                    item, f"{what} id {number:#x} is used twice (first on line {ids[number].line})"
                )
            by_name[name], ids[number] = (record, item), item
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
            self.text(self.required(keys, "name", item)),
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
        return EndpointConfig(number, kind, ip, port, device, item.line)

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
        name = self.text(self.required(keys, "name", item))
        number = self.integer(self.required(keys, "id", item))
        kind = self.text(self.required(keys, "type", item))
        if kind not in TYPES:
            raise self.fail(
                keys["type"], f"{kind!r} is not a Proton signal type ({', '.join(TYPES)})"
            )
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
            default = self.default(keys["value"], kind, capacity, length, given)
        if needs_capacity(kind) and capacity == 0:
            raise self.fail(item, f"a {kind} signal needs a capacity (or a default value)")
        if is_list(kind) and length == 0:
            raise self.fail(item, f"a {kind} signal needs a length (or a default value)")
        if default is None:
            default = zero(kind, capacity, length)
        return SignalConfig(name, number, kind, capacity, length, default, item.line)

    def default(self, field: _Field, kind: str, capacity: int, length: int, given: Any) -> Value:
        """A default value, as the generator writes it into the registry (bytes padded)."""
        try:
            if kind == "bytes":
                given = _padded(given, capacity)
            elif kind == "list_bytes" and isinstance(given, list):
                given = [_padded(item, capacity) for item in given]
            return check(kind, capacity, length, given, "2.0")
        except ValueError as error:
            raise self.fail(field, f"the default {error}") from None

    def bundle(
        self,
        item: _Field,
        nodes: dict[str, tuple[NodeConfig, _Field]],
        signals: dict[str, tuple[SignalConfig, _Field]],
    ) -> BundleConfig:
        keys = self.mapping(item, ("name", "id", "producers", "consumers", "signals", "period_ms"))
        name = self.text(self.required(keys, "name", item))
        number = self.integer(self.required(keys, "id", item))
        ends = {}
        for side in ("producers", "consumers"):
            if side not in keys or not self.sequence(keys[side]):
                what = "produced" if side == "producers" else "consumed"
                raise self.fail(keys.get(side, item), f"bundle {name!r} is {what} by no node")
            listed: list[str] = []
            for node, field in self.names(keys[side]):
                if node not in nodes:
                    raise self.fail(field, f"no node is called {node!r}")
                if node in listed:
                    raise self.fail(field, f"node {node!r} is listed twice")
                listed.append(node)
            ends[side] = tuple(listed)
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
        if number == 0 and [signals[m][0].type for m in members] != ["uint32"]:
            raise self.fail(
                keys["id"], "bundle id 0 is Proton's heartbeat: exactly one uint32 signal"
            )
        return BundleConfig(
            name, number, ends["producers"], ends["consumers"], tuple(members), period, item.line
        )


def _sized(kind: str, capacity: int, length: int, given: Any) -> tuple[int, int]:
    """Capacity and length as the generator settles them from a default value."""
    if is_list(kind) and length == 0 and isinstance(given, list):
        length = len(given)
    if kind == "string" and isinstance(given, str):
        size = len(given.encode("utf-8", "surrogatepass"))
        if capacity in (0, size):
            capacity = size + 1  # room for the NUL, as normalize.py gives it
    elif kind == "bytes" and isinstance(given, list) and capacity == 0:
        capacity = len(given)
    elif kind == "list_string" and isinstance(given, list) and capacity == 0:
        sizes = [
            len(item.encode("utf-8", "surrogatepass")) for item in given if isinstance(item, str)
        ]
        capacity = max(sizes, default=0) + 1
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
    return len(parts) == 4 and all(p.isdigit() and int(p) <= 255 and len(p) <= 3 for p in parts)
