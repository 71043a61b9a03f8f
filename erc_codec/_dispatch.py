"""Dispatch: each decoded payload to the handler registered for its kind, and nothing lost silently.

Guarantees: every datagram fed ends in exactly one counter: handled (per kind), unhandled (a kind
with no handler), undecodable (per ``DecodeError.reason``) or a handler error (per kind). Every
drop also goes to the optional ``on_drop`` callback with the datagram and the reason. A handler's
exception is caught and counted; the next datagram is dispatched as usual. No threads, no I/O.
"""

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, NamedTuple, TypeVar

from google.protobuf.message import DecodeError as ProtobufDecodeError
from google.protobuf.message import Message

from ._codec import Codec
from ._errors import DecodeError, SchemaError

__all__ = ["DispatchStats", "Dispatcher", "Drop"]

Handler = Callable[[Message], object]
H = TypeVar("H", bound=Handler)


class Drop(NamedTuple):
    """A datagram that reached no handler, or whose handler failed."""

    reason: str  # "unhandled", "handler_error", or a DecodeError reason ("corrupt", ...)
    kind: str | None  # the payload kind, when the datagram decoded
    data: bytes
    error: Exception | None


@dataclass
class DispatchStats:
    """Counters since the dispatcher was made (copies: changing them changes nothing)."""

    handled: dict[str, int] = field(default_factory=dict)  # kind → datagrams handled
    unhandled: dict[str, int] = field(default_factory=dict)  # kind → datagrams with no handler
    undecodable: dict[str, int] = field(default_factory=dict)  # DecodeError reason → datagrams
    handler_errors: dict[str, int] = field(default_factory=dict)  # kind → handler exceptions

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
    ) -> None:
        """``on_drop`` hears of every drop; ``on_decoded`` (an attribute, too) of the kind of every
        datagram that decodes, handled or not, before its handler runs: liveness feeds on it."""
        self._codec = codec or Codec.default()
        self.on_decoded = on_decoded
        self._decode = self._codec.decode
        # The codec's own table (first tag byte, or first | second << 8 → kind, payload parser,
        # offset of the length prefix) and size limit, for the short cut in ``feed``.
        self._tags = self._codec._tags
        self._max_size = self._codec.max_size(self._codec.root)
        self._kinds = set(self._codec.kinds().values())
        # kind → [handler, datagrams handled]: one lookup finds both on the hot path.
        self._handlers: dict[str, list[Any]] = {}
        self._on_drop = on_drop
        self._unhandled: dict[str, int] = {}
        self._undecodable: dict[str, int] = {}
        self._handler_errors: dict[str, int] = {}

    @property
    def codec(self) -> Codec:
        """The codec this dispatcher decodes with."""
        return self._codec

    def register(self, kind: str, handler: Handler) -> None:
        """Call ``handler(payload)`` for every datagram of ``kind`` (an envelope member name)."""
        if kind not in self._kinds:
            raise SchemaError(f"{kind!r} is not a payload kind of {self._codec.root}")
        self._handlers.setdefault(kind, [handler, 0])[0] = handler

    def on(self, kind: str) -> Callable[[H], H]:
        """The decorator form of ``register``: ``@dispatcher.on("gps_info")``."""

        def decorate(handler: H) -> H:
            self.register(kind, handler)
            return handler

        return decorate

    def feed(self, data: bytes) -> bool:
        """Decode one datagram and hand it to its handler; whether a handler took it."""
        # The usual datagram (tag, one-byte length, the payload exact or stripped of its last
        # zeros) is parsed here, as Envelope.decode would, with the codec's own table: the
        # decoder's call and result tuple would cost a fifth of the whole. Anything else (a
        # padded datagram, a two-byte length) and a payload that does not parse go the general
        # way, which also says what is wrong. A property test holds the two ways equal.
        size = len(data)
        message: Message | None = None
        member = None
        if 0 < size <= self._max_size:
            first = data[0]
            if first < 0x80:
                member = self._tags.get(first)
            elif size > 1:
                member = self._tags.get(first | data[1] << 8)
        if member is not None:
            kind, parse, start = member
            payload: bytes | None = None
            if start == size:  # stripped down to the tag: the length was a zero, too
                payload = b""
            elif data[start] < 0x80:
                missing = start + 1 + data[start] - size  # zeros stripped off the end
                if missing == 0:
                    payload = data[start + 1 :]
                elif 0 < missing <= self._max_size - size:
                    payload = data[start + 1 :] + bytes(missing)
            if payload is not None:
                try:
                    message = parse(payload)
                except ProtobufDecodeError:
                    message = None  # the general decoder says why
        if message is None:
            try:
                kind, message = self._decode(data)
            except DecodeError as error:
                return self._drop(
                    self._undecodable, error.reason, Drop(error.reason, None, data, error)
                )
        if self.on_decoded is not None:
            self.on_decoded(kind)
        try:
            entry = self._handlers[kind]
        except KeyError:
            return self._drop(self._unhandled, kind, Drop("unhandled", kind, data, None))
        try:
            entry[0](message)
        except Exception as error:  # a handler's failure must not stop dispatching
            return self._drop(self._handler_errors, kind, Drop("handler_error", kind, data, error))
        entry[1] += 1
        return True

    def stats(self) -> DispatchStats:
        """A snapshot of the counters."""
        return DispatchStats(
            {kind: entry[1] for kind, entry in self._handlers.items() if entry[1]},
            dict(self._unhandled),
            dict(self._undecodable),
            dict(self._handler_errors),
        )

    def _drop(self, counter: dict[str, int], key: str, drop: Drop) -> bool:
        counter[key] = counter.get(key, 0) + 1
        if self._on_drop is not None:
            self._on_drop(drop)
        return False
