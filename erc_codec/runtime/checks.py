"""The checks every public API applies to the times, durations and counts it is given.

A NaN compares false with everything, so one that slips into a clock reading or a period
silently disables whatever compares against it (a watchdog that never fires again); an infinity
or a negative count removes a bound. Each check refuses those with a ``ValueError`` naming the
parameter, and is called before anything is changed, so a refused call changes nothing.
"""

import math
import operator
from numbers import Real

__all__ = ["count", "duration", "instant"]


def duration(name: str, value: float) -> float:
    """``value`` if it is a positive, finite number of seconds (a period, a timeout)."""
    if not 0 < _seconds(value) < math.inf:  # False for NaN, too
        raise ValueError(f"{name} must be a positive, finite number of seconds, not {value!r}")
    return value


def instant(name: str, value: float) -> float:
    """``value`` if it is a finite clock reading in seconds (any origin, so any sign)."""
    if not -math.inf < _seconds(value) < math.inf:
        raise ValueError(f"{name} must be a finite clock reading in seconds, not {value!r}")
    return value


def _seconds(value: object) -> float:
    """``value`` as the float every later sum makes of it; NaN for what is no real number (a
    bool is none), or a whole number too large for any float (``10**400``: an OverflowError
    in the first sum)."""
    if isinstance(value, bool) or not isinstance(value, Real):
        return math.nan
    try:
        return float(value)
    except OverflowError:
        return math.nan


def count(name: str, value: int, minimum: int = 1) -> int:
    """``value`` if it is a whole number of at least ``minimum`` (not a float, not a bool)."""
    try:
        number = operator.index(value)
    except TypeError:
        number = None
    if number is None or isinstance(value, bool) or number < minimum:
        raise ValueError(f"{name} must be a whole number of at least {minimum}, not {value!r}")
    return number
