"""Opening the serial link to a module: a device path, a pyserial URL, or a port object.

Anything :func:`serial.serial_for_url` accepts works: a Bluetooth SPP port
(``/dev/rfcomm0``, ``COM5``), a USB CDC port (``/dev/ttyACM0``), a pty, a TCP
bridge (``socket://host:port``), ``loop://``. The emulator's own URL scheme
``openshoe://`` lives in the emulator package (``firmware_sim.transports``); it
is registered with pyserial only when such a URL is opened, so the host SDK never
imports the emulator otherwise.
"""

from __future__ import annotations

import errno
import importlib
import os
import re
import stat
from collections.abc import Callable
from typing import Any
from urllib.parse import urlsplit

import serial

__all__ = ["EMULATOR_HANDLER_PACKAGE", "TCP_SCHEMES", "PortFactory", "open_port", "port_factory", "port_name",
           "url_refusal"]

#: The package holding pyserial's ``protocol_openshoe`` handler (the emulator's URL scheme).
EMULATOR_HANDLER_PACKAGE = "firmware_sim.transports"
#: Baud rate of the module's Bluetooth UART (protocol.md §8); ignored by USB CDC and URLs.
DEFAULT_BAUDRATE = 115200

#: A callable that opens (or re-opens) the link and returns an open port.
PortFactory = Callable[[], "serial.SerialBase"]


def _register_emulator_scheme() -> None:
    try:
        importlib.import_module(EMULATOR_HANDLER_PACKAGE + ".protocol_openshoe")
    except ImportError as exc:
        raise ValueError(
            "openshoe:// URLs need the emulator package (firmware_sim.transports.protocol_openshoe), "
            f"which cannot be imported: {exc}"
        ) from exc
    if EMULATOR_HANDLER_PACKAGE not in serial.protocol_handler_packages:
        serial.protocol_handler_packages.append(EMULATOR_HANDLER_PACKAGE)


def open_port(url: str, *, baudrate: int = DEFAULT_BAUDRATE, read_timeout: float = 0.05, **kwargs: Any):
    """Open *url* (a device path or any pyserial URL) with a short read timeout for the reader.

    A URL that cannot name a port (``socket://HOST`` without a port, a port beyond 65535) is refused
    with a ValueError before anything is opened; a port that cannot be opened raises pyserial's
    :class:`~serial.SerialException` saying why in words (no such device, a directory or a regular
    file where a serial port should be, connection refused …; :func:`url_refusal`)."""
    if isinstance(url, os.PathLike):
        url = os.fspath(url)
    if not isinstance(url, str) or not url:
        raise ValueError(f"a port is a device path or URL string, got {url!r}")
    refusal = url_refusal(url)
    if refusal is not None:
        raise ValueError(refusal)
    if url.lower().startswith("openshoe://"):
        _register_emulator_scheme()
    try:
        return serial.serial_for_url(url, baudrate=baudrate, timeout=read_timeout, write_timeout=5.0,
                                     **kwargs)
    except serial.SerialException as exc:
        raise serial.SerialException(_why_not_opened(url, exc)) from exc


#: The pyserial URL schemes that name a TCP port: HOST:PORT after them.
TCP_SCHEMES = ("socket", "rfc2217")


def url_refusal(url: str) -> str | None:
    """Why *url* names no port pyserial could open, or None: a TCP URL (``socket://``,
    ``rfc2217://``) without a host, or whose port is not a number from 1 to 65535."""
    scheme, sep, _rest = url.partition("://")
    if not sep or scheme.lower() not in TCP_SCHEMES:
        return None
    parts = urlsplit(url)
    form = f"a TCP URL is {scheme}://HOST:PORT"
    if not parts.hostname:
        return f"no host: {form}"
    port = parts.netloc.rpartition(":")[2] if ":" in parts.netloc else ""
    if not port:
        return f"no port: {form}"
    if not (port.isdigit() and 0 < int(port) <= 65535):
        return f"port {port!r} is not a number from 1 to 65535"
    return None


def _why_not_opened(url: str, exc: serial.SerialException) -> str:
    """Why *url* did not open, in words: pyserial's reason without its repeats of the URL and errno,
    and for a path what is there when it is no serial port."""
    if "://" not in url:
        try:
            mode = os.stat(url).st_mode
        except OSError as err:
            return err.strerror or str(exc)
        if stat.S_ISDIR(mode):
            return "it is a directory, not a serial port"
        if stat.S_ISREG(mode):
            return "it is a regular file, not a serial port (a capture is replayed by openshoe-host replay)"
        if getattr(exc, "errno", None) == errno.ENOTTY or "Inappropriate ioctl" in str(exc):
            return "it is not a serial port (a device that is no terminal)"
    text = str(exc)
    for prefix in (f"could not open port {url}: ", f"Could not open port {url}: "):
        text = text.split(prefix, 1)[-1]
    return re.sub(r"^\[Errno -?\d+\] ", "", text)


def port_factory(target: Any, *, baudrate: int = DEFAULT_BAUDRATE, read_timeout: float = 0.05) -> PortFactory:
    """A callable that opens *target* now and re-opens it after a dropped link.

    *target* is a path/URL string (or a path object), or an already-open pyserial port object
    (re-opened with its own ``close()``/``open()``); anything else is refused (TypeError).
    """
    if isinstance(target, os.PathLike):
        target = os.fspath(target)
    if isinstance(target, str):
        return lambda: open_port(target, baudrate=baudrate, read_timeout=read_timeout)
    if not all(callable(getattr(target, name, None)) for name in ("read", "write", "close")):
        raise TypeError(f"a port is a device path or URL string, or a port object with read, write and "
                        f"close, got {type(target).__name__}")

    first = [True]

    def reopen():
        if first[0]:
            first[0] = False
            if not getattr(target, "is_open", True):
                target.open()
        else:
            try:
                target.close()
            finally:
                target.open()
        try:
            target.timeout = read_timeout
        except (AttributeError, ValueError):
            pass
        return target

    return reopen


def port_name(port: Any) -> str:
    """A human name for an open port (its path/URL when it has one)."""
    name = getattr(port, "port", None) or getattr(port, "name", None)
    return str(name) if name else type(port).__name__
