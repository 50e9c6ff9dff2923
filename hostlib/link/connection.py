"""Opening the serial link to a module: a device path, a pyserial URL, or a port object.

Anything :func:`serial.serial_for_url` accepts works: a Bluetooth SPP port
(``/dev/rfcomm0``, ``COM5``), a USB CDC port (``/dev/ttyACM0``), a pty, a TCP
bridge (``socket://host:port``), ``loop://``. The emulator's own URL scheme
``openshoe://`` lives in the emulator package (``firmware_sim.transports``); it
is registered with pyserial only when such a URL is opened, so the host SDK never
imports the emulator otherwise.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any

import serial

__all__ = ["EMULATOR_HANDLER_PACKAGE", "PortFactory", "open_port", "port_factory", "port_name"]

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
    """Open *url* (a device path or any pyserial URL) with a short read timeout for the reader."""
    if not isinstance(url, str) or not url:
        raise ValueError(f"a port is a device path or URL string, got {url!r}")
    if url.lower().startswith("openshoe://"):
        _register_emulator_scheme()
    return serial.serial_for_url(url, baudrate=baudrate, timeout=read_timeout, write_timeout=5.0, **kwargs)


def port_factory(target: Any, *, baudrate: int = DEFAULT_BAUDRATE, read_timeout: float = 0.05) -> PortFactory:
    """A callable that opens *target* now and re-opens it after a dropped link.

    *target* is a path/URL string, or an already-open pyserial port object
    (re-opened with its own ``close()``/``open()``).
    """
    if isinstance(target, str):
        return lambda: open_port(target, baudrate=baudrate, read_timeout=read_timeout)

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
