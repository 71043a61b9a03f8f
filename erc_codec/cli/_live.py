"""``listen --foxglove``: the Foxglove server beside ``listen``'s own output."""

import click

from ..capture import FoxgloveView
from ..codec import Codec
from ._shared import Fatal

__all__ = ["foxglove_view"]


def foxglove_view(codec: Codec, host: str, port: int) -> FoxgloveView:
    """A Foxglove WebSocket server on ``host:port`` for ``codec``'s envelope; where it listens
    is said on stderr (``foxglove on ws://HOST:PORT``)."""
    try:
        view = FoxgloveView(codec, host, port)
    except ImportError as error:
        raise Fatal(str(error)) from None
    except (OSError, RuntimeError) as error:
        raise Fatal(f"cannot serve Foxglove on {host}:{port}: {error}") from None
    bound_host, bound_port = view.address
    shown = f"[{bound_host}]" if ":" in bound_host else bound_host
    click.echo(f"foxglove on ws://{shown}:{bound_port}", err=True)
    return view
