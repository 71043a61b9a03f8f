"""How errors name a field: its full path from the message type the caller handed over.

``GPSInfo.fix_quality``, a submessage's field through it (``SensorBoardDiagnostics.gps_sensor_1.
fix_quality``), an item of a repeated field by its index (``LimitsRecord.points[1].colour``), a
map's entry by its key as protobuf's JSON mapping writes it (``LimitsRecord.palette[key=1]``,
``[key=true]``). The encoder's contract, the decoder's truncation check and the JSON reader all
spell paths through ``entry_path``, so one field has one name in every error.
"""

__all__ = ["entry_path", "key_text"]


def key_text(key: object) -> str:
    """A map key as the JSON mapping writes it, without quotes: ``1``, ``true``, ``left``."""
    return ("true" if key else "false") if isinstance(key, bool) else str(key)


def entry_path(path: str, key: object) -> str:
    """The path of the entry with ``key`` in the map at ``path``."""
    return f"{path}[key={key_text(key)}]"
