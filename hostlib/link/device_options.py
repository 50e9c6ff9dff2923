"""How a :class:`~hostlib.link.device.Device` talks to its module (:class:`DeviceOptions`), each value
checked when the options are made, and the options a ``Device(…, **settings)`` call gives."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, fields, replace
from typing import Any

from .connection import DEFAULT_BAUDRATE

__all__ = ["DeviceOptions", "device_options"]


@dataclass(frozen=True)
class DeviceOptions:
    """How a :class:`Device` talks to its module: the command numbering, how long it waits for
    acks, what it does when the link drops, how much it queues and how it opens the port."""

    #: ``"2015"`` (current) or ``"2014"`` numbering (protocol.md §10)
    command_set: str = "2015"
    #: seconds to wait for a command's ack, per attempt
    ack_timeout: float = 1.0
    #: extra attempts of each command after the first
    retries: int = 2
    #: which packets the session acknowledges (:class:`~hostlib.link.session.HostSession`)
    ack_policy: str = "auto"
    #: after a dropped link, keep re-opening it until :meth:`Device.close`
    reconnect: bool = True
    #: seconds between two attempts to re-open a dropped link
    reconnect_interval: float = 0.5
    #: bound of the packet queue and of the step queue
    queue_size: int = 10000
    #: put every state packet in the packet queue (:meth:`Device.recv_packet
    #: <hostlib.link.device.Device.recv_packet>`); off for a program that reads only the steps (as
    #: ``openshoe-host track`` does), where the unread packets would pile up to :attr:`queue_size`
    #: over a long walk and then be dropped with a warning
    queue_packets: bool = True
    #: UART baud rate (ignored by URLs and USB)
    baudrate: int = DEFAULT_BAUDRATE
    #: the port's read timeout [s]: how long the reader thread waits for bytes at a time
    read_timeout: float = 0.05
    #: let only the reader thread touch the port (writes are handed to it and go out between
    #: reads). Needed by ports that are not thread-safe, such as the emulator's virtual-time
    #: ``openshoe://`` port; None: on for those URLs, off otherwise (real serial ports read and
    #: write concurrently)
    serialize_io: bool | None = None

    def __post_init__(self) -> None:
        """Refuse a value the device could not work with, naming the option (ValueError; TypeError
        for one of the wrong kind): a wait that is not a number of seconds > 0, a negative count."""
        for name in ("ack_timeout", "reconnect_interval", "read_timeout"):
            _check_number(name, getattr(self, name), "a number of seconds > 0", lambda v: v > 0)
        _check_number("retries", self.retries, "a whole number >= 0", lambda v: v >= 0, whole=True)
        _check_number("queue_size", self.queue_size, "a whole number >= 1", lambda v: v >= 1, whole=True)
        _check_number("baudrate", self.baudrate, "a whole number of bits per second > 0", lambda v: v > 0,
                      whole=True)


def _check_number(name: str, value: Any, what: str, ok: Callable[[float], bool], whole: bool = False) -> None:
    """Refuse *value* of the option *name* unless it is a finite number (*whole*: an integer) *ok*
    takes."""
    kinds = (int,) if whole else (int, float)
    if not isinstance(value, kinds) or isinstance(value, bool):
        raise TypeError(f"{name} must be {what}, got {value!r}")
    if not (math.isfinite(value) and ok(value)):
        raise ValueError(f"{name} must be {what}, got {value!r}")


def device_options(options: DeviceOptions | None, settings: dict[str, Any]) -> DeviceOptions:
    """*options* with the keywords *settings* given to :class:`Device`; a keyword that is no option
    is refused naming the options there are."""
    if options is not None and not isinstance(options, DeviceOptions):
        raise TypeError(f"options must be a DeviceOptions, got {type(options).__name__}")
    known = {f.name for f in fields(DeviceOptions)}
    unknown = sorted(set(settings) - known)
    if unknown:
        raise TypeError(f"Device has no option {', '.join(map(repr, unknown))} (DeviceOptions: "
                        f"{', '.join(sorted(known))})")
    return replace(options or DeviceOptions(), **settings)
