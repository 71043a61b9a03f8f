"""This host's own addresses, however they are spelled: what keeps the relay from sending to itself.

One address has several spellings: ``::ffff:127.0.0.1`` is ``127.0.0.1`` (an IPv4-mapped IPv6
address, which is how a dual-stack socket names an IPv4 peer), and a socket bound to a wildcard
(``0.0.0.0``, ``::``) receives on every address of the host, loopback and interfaces alike.
Whether an address is the host's own is asked of the kernel, with no list of interfaces: a UDP
socket binds to it (port 0, closed at once) only if it is. A host that binds any address
(``ip_nonlocal_bind`` set) would make every address its own; there, only loopback addresses
count, which a documentation address that binds all the same tells.
"""

import contextlib
import functools
import ipaddress
import socket
from typing import Any

__all__ = ["WILDCARDS", "canonical", "is_local", "receives", "spellings"]

WILDCARDS = ("0.0.0.0", "::")  # a host that means every local address
_NOWHERE = ("192.0.2.1", "2001:db8::1")  # documentation addresses (RFC 5737, RFC 3849)


def canonical(host: str) -> str:
    """``host`` (a numeric IP address) in one spelling: an IPv4-mapped IPv6 address as its IPv4
    address, any other in its compressed form; a scope is kept as its interface's index
    (``%eth0`` and ``%4`` are one scope)."""
    address, percent, scope = host.partition("%")
    try:
        parsed = ipaddress.ip_address(address)
    except ValueError:
        return host
    if isinstance(parsed, ipaddress.IPv6Address) and parsed.ipv4_mapped is not None:
        return str(parsed.ipv4_mapped)
    if scope and not scope.isdigit():
        with contextlib.suppress(OSError):  # no such interface: the name stays
            scope = str(socket.if_nametoindex(scope))
    return str(parsed) + percent + scope


def spellings(host: str) -> tuple[str, ...]:
    """Every spelling a received datagram may give ``host`` as its sender: an IPv4 address
    also as the IPv4-mapped IPv6 address a dual-stack socket reports."""
    host = canonical(host)
    return (host, f"::ffff:{host}") if ":" not in host else (host,)


def is_local(host: str) -> bool:
    """Whether ``host`` (a numeric IP address, with a scope where it has one) is one of this
    host's, or a wildcard."""
    host = canonical(host)
    if host in WILDCARDS:
        return True
    if _binds_anything():
        return ipaddress.ip_address(host.partition("%")[0]).is_loopback
    return _binds(host)


def _binds(host: str) -> bool:
    """Whether a UDP socket binds to ``host`` (the socket address from getaddrinfo, which
    carries a scope as its index: bind refuses ``fe80::1%eth0`` as text)."""
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    try:
        found = socket.getaddrinfo(host, 0, family, socket.SOCK_DGRAM, 0, socket.AI_NUMERICHOST)
        with socket.socket(family, socket.SOCK_DGRAM) as probe:
            probe.bind(found[0][4])
    except OSError:
        return False
    return True


@functools.cache
def _binds_anything() -> bool:
    """Whether this host binds addresses it does not have (``ip_nonlocal_bind``)."""
    return any(_binds(host) for host in _NOWHERE)


def receives(bound: tuple[Any, ...], destination: tuple[Any, ...]) -> bool:
    """Whether a UDP socket bound to ``bound`` receives what is sent to ``destination`` (both
    socket addresses with numeric hosts): the same port, and the same address or, for a
    wildcard, any of this host's (an IPv4 wildcard only IPv4 ones; an IPv6 wildcard, dual-stack
    as Linux makes it, any)."""
    if bound[1] != destination[1]:
        return False
    listening, host = canonical(_scoped(bound)), canonical(_scoped(destination))
    if listening == host:
        return True
    if listening == "::" or (listening == "0.0.0.0" and ":" not in host):
        return is_local(host)
    return False


def _scoped(address: tuple[Any, ...]) -> str:
    """The host of a socket address with its scope, which getaddrinfo gives apart (as the
    address's fourth item) rather than in the text."""
    host = str(address[0])
    if len(address) == 4 and address[3] and "%" not in host:
        return f"{host}%{address[3]}"
    return host
