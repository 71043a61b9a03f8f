"""What the Proton tests share: the test configurations, and hypothesis strategies for every value
a signal may hold in a protocol version (full ranges, ±0, NaN, ±inf, subnormals; empty and full
strings and bytes, multi-byte UTF-8 up to the capacity's last byte)."""

import math
import struct
from pathlib import Path
from typing import Any

from hypothesis import strategies as st

from erc_codec.proton import SignalConfig, Value, Version, load_config

HERE = Path(__file__).resolve().parent / "proton"
TYPES_2_0 = load_config(HERE / "types.yaml")
TYPES_1_0 = load_config(HERE / "types_1_0.yaml")

_INTEGERS = {
    "int32": (-(1 << 31), (1 << 31) - 1),
    "int64": (-(1 << 63), (1 << 63) - 1),
    "uint32": (0, (1 << 32) - 1),
    "uint64": (0, (1 << 64) - 1),
}
_TEXT = st.characters(codec="utf-8", exclude_characters="\0")


def _fitted(text: str, size: int) -> str:
    """``text`` cut to at most ``size`` bytes of UTF-8, on a character boundary."""
    while len(text.encode("utf-8")) > size:
        text = text[:-1]
    return text


def _item(element: str, capacity: int, exact_bytes: bool) -> st.SearchStrategy[Any]:
    if element == "double":
        return st.floats()
    if element == "float":
        return st.floats(width=32)
    if element == "bool":
        return st.booleans()
    if element in _INTEGERS:
        low, high = _INTEGERS[element]
        return st.integers(low, high) | st.sampled_from(sorted({low, high, 0, 1, max(low, -1)}))
    if element == "string":
        room = capacity - 1
        return st.one_of(
            st.just(""),
            st.text(_TEXT, max_size=room).map(lambda text: _fitted(text, room)),
            st.text(
                st.characters(min_codepoint=1, max_codepoint=127), min_size=room, max_size=room
            ),
        )
    if exact_bytes:
        return st.binary(min_size=capacity, max_size=capacity)
    return st.one_of(
        st.just(b""),
        st.binary(max_size=capacity),
        st.binary(min_size=capacity, max_size=capacity),
    )


def values(signal: SignalConfig, version: Version) -> st.SearchStrategy[Value]:
    """Any value ``signal`` can hold and send in ``version``."""
    element = signal.type.removeprefix("list_")
    item = _item(element, signal.capacity, exact_bytes=version == "1.0")
    if signal.type.startswith("list_"):
        return st.lists(item, min_size=signal.length, max_size=signal.length)
    return item


def same(a: object, b: object) -> bool:
    """Equal values, floats compared by their bits (NaN equals NaN, 0.0 is not -0.0)."""
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, float) and isinstance(b, float):
        return struct.pack("<d", a) == struct.pack("<d", b) or (math.isnan(a) and math.isnan(b))
    return type(a) is type(b) and a == b
