"""The capture room: recording, replaying and viewing datagrams.

- ``McapWriter`` records decoded payloads on one MCAP channel per kind, and drops on their own.
- ``read_mcap`` reads them back (``Recorded``, ``RecordingStats``).
- ``FoxgloveView`` serves the live stream to a Foxglove client.
- ``wireshark_dissector`` writes a Lua dissector for the schema.

Each imports its optional library (mcap, foxglove-sdk) only when used.
"""

from ._foxglove import FoxgloveView
from ._mcap import McapWriter, Recorded, RecordingStats, read_mcap
from ._wireshark import wireshark_dissector

__all__ = [
    "FoxgloveView",
    "McapWriter",
    "Recorded",
    "RecordingStats",
    "read_mcap",
    "wireshark_dissector",
]
