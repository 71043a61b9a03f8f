"""Did-you-mean: the known name closest to a mistyped one, for one-line errors."""

from collections.abc import Iterable

__all__ = ["did_you_mean"]


def did_you_mean(word: str, choices: Iterable[str]) -> str:
    """`` (did you mean 'X'?)`` for the choice closest to ``word``, or ``""`` when none is
    close; case is ignored (``field_deleted`` finds ``FIELD_DELETED``)."""
    import difflib  # only on the way to an error: a run that succeeds does not pay for it

    known = {choice.lower(): choice for choice in choices}
    close = difflib.get_close_matches(word.lower(), list(known), n=1, cutoff=0.6)
    return f" (did you mean {known[close[0]]!r}?)" if close else ""
