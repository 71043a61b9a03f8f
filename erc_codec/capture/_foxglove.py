"""A live Foxglove view: a Foxglove WebSocket server (the ``foxglove-sdk`` package, the
``foxglove`` extra) showing datagrams as they arrive.

What it guarantees:
- There is one channel per envelope member, ``/erc/<kind>``.
- Each channel has its payload's protobuf schema, with the same name and ``FileDescriptorSet``
  as in a recording.
- All channels are advertised when the server starts, so panels can be set up before anything
  arrives.
- Each payload is sent in the exact protobuf form.
- Drops go on ``/erc-codec/drops`` as a ``DroppedDatagram``, as in a recording.
- The rover's position goes on ``/erc-codec/fix`` as a ``foxglove.LocationFix``, for the Map
  panel.
  It comes from every ``gps_info`` that has a fix (``fix_quality`` other than 0).
- Every ``interval`` seconds, ``/erc-codec/stats`` (JSON) carries:
  - the counts and rates by kind;
  - the drops by reason;
  - the datagrams the view failed to show (``view_errors``).
- The view never fails its caller.
- The server binds 127.0.0.1 unless told otherwise, so a view of the rover is not served to the
  whole network by accident.

The server runs in the SDK's own native threads.
The statistics run in one thread of this view.
Nothing here reads a socket: the caller hands over each payload (``message``) and each drop.
"""

import time
from typing import Any

from google.protobuf.message import Message

from erc_schema import descriptor_of

from ..codec import Codec
from ..runtime import Drop
from ._recording import (
    DROPS_TOPIC,
    FIX_TOPIC,
    STATS_TOPIC,
    drop_schema,
    dropped_datagram,
    file_descriptor_set,
    member_topic,
    require,
)

__all__ = ["FoxgloveView"]

_FIX_KIND = "gps_info"
_LAST_STAMP = (1 << 32) * 1000  # milliseconds: the first a Timestamp's uint32 seconds cannot hold
_STATS_SCHEMA = {
    "title": "erc-codec statistics",
    "type": "object",
    "properties": {
        "received": {"type": "integer", "description": "datagrams since the view started"},
        "messages": {
            "type": "object",
            "description": "messages by kind since the view started",
            "additionalProperties": {"type": "integer"},
        },
        "rates": {
            "type": "object",
            "description": "messages per second by kind, over the last interval",
            "additionalProperties": {"type": "number"},
        },
        "drops": {
            "type": "object",
            "description": "datagrams that did not decode, by reason, since the view started",
            "additionalProperties": {"type": "integer"},
        },
        "drop_rate": {"type": "number", "description": "drops per second, last interval"},
        "view_errors": {
            "type": "integer",
            "description": "datagrams this view failed to show (the caller saw them all)",
        },
    },
}


class FoxgloveView:
    """A Foxglove WebSocket server on ``host:port`` for ``codec``'s envelope.

    ``port`` 0 binds any free port.
    Hand it every payload (``message``) and every drop (``drop``), then ``close()`` it."""

    def __init__(
        self,
        codec: Codec | None = None,
        host: str = "127.0.0.1",
        port: int = 8765,
        interval: float = 1.0,
    ) -> None:
        foxglove = require("foxglove", "foxglove-sdk", "foxglove", "serving Foxglove")
        import threading  # here, not at import: erc_codec's own start-up stays small

        self._foxglove = foxglove
        codec = codec or Codec.default()
        self._context = foxglove.Context()
        self._server = foxglove.start_server(
            name="erc-codec", host=host, port=port, context=self._context
        )
        self._host = host
        self._channels: dict[str, Any] = {}
        for kind in codec.kinds().values():
            descriptor = descriptor_of(codec.payload_class(kind))
            self._channels[kind] = self._channel(
                member_topic(kind), descriptor.full_name, file_descriptor_set(descriptor)
            )
        self._drops = self._channel(DROPS_TOPIC, *drop_schema())
        self._fixes = foxglove.channels.LocationFixChannel(FIX_TOPIC, context=self._context)
        self._fix_kind = _FIX_KIND if _has_position(codec) else None
        self._stats = foxglove.Channel(STATS_TOPIC, schema=_STATS_SCHEMA, context=self._context)
        self._lock = threading.Lock()
        self._received = 0
        self._counts: dict[str, int] = {}
        self._reasons: dict[str, int] = {}
        self._view_errors = 0
        self._closing = threading.Event()
        self._publisher = threading.Thread(
            target=self._publish, args=(interval,), name="erc-codec stats", daemon=True
        )
        self._publisher.start()

    @property
    def address(self) -> tuple[str, int]:
        """The (host, port) the server listens on."""
        return self._host, int(self._server.port)

    def message(self, kind: str, message: Message, log_time: int | None = None) -> None:
        """Show the payload of a datagram of member ``kind`` (arrived at ``log_time``, in
        nanoseconds since the epoch; now, if not given)."""
        now = time.time_ns() if log_time is None else log_time
        channel = self._channels[kind]
        with self._lock:
            self._received += 1
            self._counts[kind] = self._counts.get(kind, 0) + 1
        try:
            if channel.has_sinks():
                channel.log(message.SerializeToString(), log_time=now)
            if kind == self._fix_kind:
                self._fix(message, now)
        except Exception:  # the view never fails its caller (listen's own output): counted
            self._failed()

    def drop(self, drop: Drop, source: str = "", log_time: int | None = None) -> None:
        """Show a datagram that did not decode (a ``Dispatcher``'s ``Drop``), from ``source``."""
        now = time.time_ns() if log_time is None else log_time
        with self._lock:
            self._received += 1
            self._reasons[drop.reason] = self._reasons.get(drop.reason, 0) + 1
        try:
            if self._drops.has_sinks():
                record = dropped_datagram()(
                    reason=drop.reason,
                    error=" ".join(str(drop.error or "").split()),
                    length=len(drop.data),
                    data=drop.data,
                    source=source,
                )
                self._drops.log(record.SerializeToString(), log_time=now)
        except Exception:  # as in message()
            self._failed()

    def _failed(self) -> None:
        with self._lock:
            self._view_errors += 1

    def close(self) -> None:
        """Stop the statistics and the server."""
        self._closing.set()
        self._publisher.join()
        self._server.stop()

    def _channel(self, topic: str, name: str, files: bytes) -> Any:
        schema = self._foxglove.Schema(name=name, encoding="protobuf", data=files)
        return self._foxglove.Channel(
            topic, schema=schema, message_encoding="protobuf", context=self._context
        )

    def _fix(self, gps: Any, now: int) -> None:
        if getattr(gps, "fix_quality", 1) == 0:  # NO_FIX: the coordinates mean nothing
            return
        stamp = getattr(gps, "utc_timestamp", 0)  # milliseconds since the epoch, 0 unknown
        # A Timestamp's seconds are a uint32: a stamp past 2106 (a board's garbage) is no time
        # the fix was taken, so the arrival time stands in, as for an unknown one.
        if not 0 < stamp < _LAST_STAMP:
            stamp = 0
        seconds, nanos = divmod(stamp * 1_000_000 if stamp else now, 1_000_000_000)
        messages = self._foxglove.messages
        self._fixes.log(
            messages.LocationFix(
                timestamp=messages.Timestamp(sec=seconds, nsec=nanos),
                frame_id=_FIX_KIND,
                latitude=gps.latitude,
                longitude=gps.longitude,
                altitude=float(getattr(gps, "altitude", 0.0)),
            ),
            log_time=now,
        )

    def _publish(self, interval: float) -> None:
        before: dict[str, int] = {}
        dropped_before = 0
        last = time.monotonic()
        while not self._closing.wait(interval):
            now = time.monotonic()
            with self._lock:
                received, counts, reasons = self._received, dict(self._counts), dict(self._reasons)
                view_errors = self._view_errors
            elapsed = max(now - last, 1e-9)
            dropped = sum(reasons.values())
            self._stats.log(
                {
                    "received": received,
                    "messages": counts,
                    "rates": {
                        kind: round((n - before.get(kind, 0)) / elapsed, 3)
                        for kind, n in counts.items()
                    },
                    "drops": reasons,
                    "drop_rate": round((dropped - dropped_before) / elapsed, 3),
                    "view_errors": view_errors,
                },
                log_time=time.time_ns(),
            )
            before, dropped_before, last = counts, dropped, now


def _has_position(codec: Codec) -> bool:
    """Whether the schema has a ``gps_info`` member with ``latitude`` and ``longitude``."""
    if _FIX_KIND not in codec.kinds().values():
        return False
    fields = descriptor_of(codec.payload_class(_FIX_KIND)).fields_by_name
    return "latitude" in fields and "longitude" in fields
