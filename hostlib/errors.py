"""Exceptions and warnings of the host SDK, one class per way talking to a module can fail."""

from __future__ import annotations

__all__ = [
    "AckTimeout",
    "DeviceClosed",
    "HostError",
    "LinkLost",
    "NotSupportedByCommandSet",
    "QueueFullWarning",
]


class HostError(Exception):
    """Base class of every error raised by :mod:`hostlib`."""


class AckTimeout(HostError, TimeoutError):
    """A command was sent (and resent) but the module never acknowledged it.

    *command* is the command's name, *wire_id* its header byte, *attempts* how
    many times it was sent and *timeout* the wait per attempt in seconds.
    """

    def __init__(self, command: str, wire_id: int, attempts: int, timeout: float):
        self.command = command
        self.wire_id = wire_id
        self.attempts = attempts
        self.timeout = timeout
        super().__init__(
            f"no ack (A0 {wire_id:02X} ..) for {command} (0x{wire_id:02X}) after {attempts} attempt(s) "
            f"of {timeout:g} s each; is the module connected, powered and speaking this command set?"
        )


class DeviceClosed(HostError):
    """The device was closed (by the user, or the link is gone and not coming back)."""


class LinkLost(HostError, ConnectionError):
    """The serial link dropped (e.g. Bluetooth out of range) and is not reconnected."""


class NotSupportedByCommandSet(HostError, ValueError):
    """The command does not exist in the numbering this device speaks (2014 vs 2015)."""

    def __init__(self, command: str, command_set: str):
        self.command = command
        self.command_set = command_set
        super().__init__(
            f"{command} does not exist in the {command_set} command numbering "
            f"(protocol.md §10); open the device with the other command_set"
        )


class QueueFullWarning(RuntimeWarning):
    """An internal receive queue was full: events were dropped (and counted)."""
