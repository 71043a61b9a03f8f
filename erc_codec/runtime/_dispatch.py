"""Dispatch: each decoded payload to the handler registered for its kind, and nothing lost silently.

Every datagram fed ends in exactly one counter:
- handled, per kind;
- unhandled, per kind: a kind with no handler;
- undecodable, per ``DecodeError.reason``;
- a handler error, per kind.

Guarantees:
- A handler takes a payload only.
- Fields the schema does not know beside the payload, on the envelope, are not passed on. They
  are counted by number in ``unkept``, for at most ``MAX_UNKEPT_NUMBERS`` numbers; the rest are
  counted in ``unkept_unlisted``.
- Every drop also goes to the optional ``on_drop`` callback, with the datagram and the reason.
- A handler's exception is caught and counted, and the next datagram is dispatched as usual.
- No threads, no I/O.
"""

from collections.abc import Callable, Mapping
from types import MappingProxyType
from typing import Any, NamedTuple, TypeVar

from google.protobuf.message import DecodeError as ProtobufDecodeError
from google.protobuf.message import Message

from erc_schema import DecodeError, SchemaError, UnreadableKind

from ..codec import Codec, UnkeptFields

__all__ = ["DispatchStats", "Dispatcher", "Drop"]

Handler = Callable[[Message], object]
H = TypeVar("H", bound=Handler)


class Drop(NamedTuple):
    """A datagram that reached no handler, or whose handler failed."""

    reason: str  # "unhandled", "handler_error", or a DecodeError reason ("corrupt", ...)
    kind: str | None  # the payload kind, when the datagram decoded (or is UnreadableKind's)
    data: bytes
    error: Exception | None


class DispatchStats(NamedTuple):
    """Counters since the dispatcher was made (copies: changing them changes nothing)."""

    handled: dict[str, int]  # kind → datagrams handled
    unhandled: dict[str, int]  # kind → datagrams with no handler
    undecodable: dict[str, int]  # DecodeError reason → datagrams
    handler_errors: dict[str, int]  # kind → handler exceptions
    # field number → datagrams whose envelope carried that field, unknown to the schema, beside
    # the payload: the payload was dispatched, the field (which no handler takes) was not; the
    # first MAX_UNKEPT_NUMBERS numbers to arrive are listed
    unkept: Mapping[int, int] = MappingProxyType({})
    # fields of the numbers not listed in ``unkept``, once per datagram and number
    unkept_unlisted: int = 0

    @property
    def dropped(self) -> int:
        """Datagrams that reached no handler, or whose handler failed."""
        return (
            sum(self.unhandled.values())
            + sum(self.undecodable.values())
            + sum(self.handler_errors.values())
        )


class Dispatcher:
    """Decodes datagrams with ``codec`` and calls the handler registered for each payload kind."""

    def __init__(
        self,
        codec: Codec | None = None,
        on_drop: Callable[[Drop], object] | None = None,
        on_decoded: Callable[[str], object] | None = None,
        on_arrival: Callable[[str, float | None], object] | None = None,
    ) -> None:
        """The callbacks, each optional.

        - ``on_drop`` hears of every drop.
        - ``on_decoded`` hears the kind of every datagram that decodes, handled or not, before
          its handler runs. Liveness feeds on it. It is an attribute, too.
        - ``on_arrival`` hears the same, with the timeout the datagram's sender advertised in
          seconds (``None``: none), as ``Watchdog.seen`` takes it. It is an attribute, too.
        """
        self._codec = codec or Codec.default()
        self.on_decoded = on_decoded
        self.on_arrival = on_arrival
        self._peek = self._codec.peek
        self._decode = self._codec.decode
        # kind → [handler or None, datagrams handled, payload parser]: one lookup finds all
        # three on the hot path.
        self._kinds: dict[str, list[Any]] = {
            kind: [None, 0, self._parser(kind)] for kind in self._codec.kinds().values()
        }
        self._on_drop = on_drop
        self._unhandled: dict[str, int] = {}
        self._undecodable: dict[str, int] = {}
        self._handler_errors: dict[str, int] = {}
        self._unkept = UnkeptFields()

    def _parser(self, kind: str) -> Callable[[bytes], Message] | None:
        """The payload class's parser; ``None`` for a member nobody can read as nanopb does,
        whose datagrams peek never finds and decode counts as ``"unsupported"``."""
        try:
            return self._codec.payload_class(kind).FromString
        except SchemaError:
            return None

    @property
    def codec(self) -> Codec:
        """The codec this dispatcher decodes with."""
        return self._codec

    def register(self, kind: str, handler: Handler) -> None:
        """Call ``handler(payload)`` for every datagram of ``kind`` (an envelope member name)."""
        entry = self._kinds.get(kind)
        if entry is None:
            raise SchemaError(f"{kind!r} is not a payload kind of {self._codec.root}")
        if entry[2] is None:
            self._codec.payload_class(kind)  # raises why no datagram of it can be read
        entry[0] = handler

    def on(self, kind: str) -> Callable[[H], H]:
        """The decorator form of ``register``: ``@dispatcher.on("gps_info")``."""

        def decorate(handler: H) -> H:
            self.register(kind, handler)
            return handler

        return decorate

    def feed(self, data: bytes) -> bool:
        """Decode one datagram and hand it to its handler; whether a handler took it."""
        # The usual datagram is located by the codec's peek and parsed here, sparing the
        # decoder's call and result tuple. Target: Dispatcher.feed in bench_runtime.py, at most
        # 1.2x codec.decode. Anything else, and a payload that does not parse, goes the general
        # way, which also says what is wrong.
        found = self._peek(data)
        message: Message | None = None
        advertised = 0  # peek's datagrams are one member alone: no metadata, so no timeout
        if found is not None:
            kind, payload = found
            entry = self._kinds[kind]
            try:
                message = entry[2](payload)
            except ProtobufDecodeError:
                message = None
        if message is None:
            try:
                decoded = self._decode(data)
            except DecodeError as error:
                known = error.kind if isinstance(error, UnreadableKind) else None
                return self._drop(
                    self._undecodable, error.reason, Drop(error.reason, known, data, error)
                )
            kind, message = decoded
            advertised = decoded.timeout
            if decoded.envelope_unknown_fields:  # never on peek's path: one member, no more
                self._unkept.count(field.number for field in decoded.envelope_unknown_fields)
            entry = self._kinds[kind]
        if self.on_decoded is not None:
            self.on_decoded(kind)
        if self.on_arrival is not None:
            self.on_arrival(kind, advertised / 1000 if advertised else None)
        handler = entry[0]
        if handler is None:
            return self._drop(self._unhandled, kind, Drop("unhandled", kind, data, None))
        try:
            handler(message)
        except Exception as error:  # a handler's failure must not stop dispatching
            return self._drop(self._handler_errors, kind, Drop("handler_error", kind, data, error))
        entry[1] += 1
        return True

    def stats(self) -> DispatchStats:
        """A snapshot of the counters."""
        return DispatchStats(
            {kind: entry[1] for kind, entry in self._kinds.items() if entry[1]},
            dict(self._unhandled),
            dict(self._undecodable),
            dict(self._handler_errors),
            dict(self._unkept.counts),
            self._unkept.unlisted,
        )

    def _drop(self, counter: dict[str, int], key: str, drop: Drop) -> bool:
        counter[key] = counter.get(key, 0) + 1
        if self._on_drop is not None:
            self._on_drop(drop)
        return False
