"""The runtime room, sans-IO: what a comms node does with datagrams, given them and the clock.

- ``Dispatcher`` hands each datagram's payload to its kind's handler, every drop counted.
- ``Watchdog`` says which kinds went silent.
- ``Router`` sends each datagram to the destinations that want it, in each one's form. It also
  sends a failsafe message while a watched kind is silent.
- ``DetectionAssembler`` puts chunked detection frames back together.
- ``Deframer`` and ``frame`` are the envelope's serial framing.
- ``checks`` validates the times and counts they take.
"""

from ._detections import (
    AssemblerStats,
    DetectionAssembler,
    DetectionFrame,
    DetectionLoss,
    Rejected,
)
from ._dispatch import Dispatcher, DispatchStats, Drop
from ._framing import Deframer, DeframerStats, frame
from ._router import Failsafe, FailsafeEvent, Outgoing, Route, Router, RouterStats
from ._watchdog import Liveness, Watchdog

__all__ = [
    "AssemblerStats",
    "Deframer",
    "DeframerStats",
    "DetectionAssembler",
    "DetectionFrame",
    "DetectionLoss",
    "DispatchStats",
    "Dispatcher",
    "Drop",
    "Failsafe",
    "FailsafeEvent",
    "Liveness",
    "Outgoing",
    "Rejected",
    "Route",
    "Router",
    "RouterStats",
    "Watchdog",
    "frame",
]
