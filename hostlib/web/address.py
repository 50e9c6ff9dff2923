"""Where a live page listens: ``--web [HOST:]PORT``, on the loopback interface unless a HOST is
given (:func:`web_address`), and the URL a browser opens (:func:`page_url`)."""

from __future__ import annotations

import argparse
import ipaddress
import os
import socket

__all__ = ["LOOPBACK", "bind_refusal", "is_loopback", "os_reason", "page_url", "web_address"]

#: Where a page listens when ``--web`` names only a port: this machine alone can open it.
LOOPBACK = "127.0.0.1"


def web_address(text: str) -> tuple[str, int]:
    """``PORT``, ``HOST:PORT`` or ``[IPv6]:PORT`` → (host, port); the host is :data:`LOOPBACK`
    unless given (port 0: a free one is picked). An argparse type: a bad value is an
    :class:`argparse.ArgumentTypeError` that says what was expected."""
    host, sep, port = text.rpartition(":")
    if sep and host.startswith("[") and host.endswith("]"):
        host = host[1:-1]
    try:
        number = int(port)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected [HOST:]PORT, got {text!r}") from None
    if not 0 <= number <= 65535:
        raise argparse.ArgumentTypeError(f"port {number} out of range 0..65535")
    if sep and not host:
        raise argparse.ArgumentTypeError(f"expected [HOST:]PORT, got {text!r}: the host is empty")
    return (host if sep else LOOPBACK), number


def bind_refusal(option: str, address: tuple[str, int], exc: Exception) -> str:
    """Why *option* could not listen on *address*, in one line naming both: ``--web
    127.0.0.1:5000: Address already in use`` (an OS error in words, without its errno; a host name
    that does not resolve: the resolver's words, ``Name or service not known``)."""
    reason = os_reason(exc)
    host, port = address
    return f"{option} {f'[{host}]' if ':' in host else host}:{port}: {reason}"


def os_reason(exc: Exception) -> str:
    """An OS error in words, without its errno and address: ``Address already in use``; a host name
    that does not resolve (a resolver's error, a negative errno, also as :func:`socket.create_server`
    re-raises it): the resolver's words, ``Name or service not known``."""
    errno = getattr(exc, "errno", None)
    if isinstance(exc, socket.gaierror) or (errno is not None and errno < 0):
        return str(getattr(exc, "strerror", None) or exc).split(" (while attempting")[0]
    return os.strerror(errno) if errno else (str(exc) or type(exc).__name__)


def is_loopback(host: str) -> bool:
    """Whether *host* is this machine alone (127.0.0.0/8, ::1, ``localhost``)."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def page_url(host: str, port: int) -> str:
    """The page's URL (an IPv6 address in brackets; a wildcard address as the loopback one)."""
    if host in ("0.0.0.0", ""):
        host = LOOPBACK
    elif host == "::":
        host = "::1"
    return f"http://[{host}]:{port}/" if ":" in host else f"http://{host}:{port}/"
