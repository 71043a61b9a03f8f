"""The transport room: the runtime on real sockets and serial lines, in asyncio.

- ``open_udp`` gives a ``UdpEndpoint``.
- A ``UdpEndpoint`` reads datagrams in batches and hands them to a ``Dispatcher`` or a callback.
- It sends in order when the send buffer is full.
- It counts what the kernel drops (``UdpStats``).
- ``read_serial`` deframes a serial stream into the same dispatcher.
"""

from ._endpoint import UdpEndpoint, UdpStats, open_udp, read_serial

__all__ = ["UdpEndpoint", "UdpStats", "open_udp", "read_serial"]
