"""What a host sends a tracking module besides 0x34 and the packet acks: one policy, without I/O.

Every host that carries out a walk — ``openshoe-host track`` and ``log`` (through a
:class:`~hostlib.link.device.Device`, :class:`~hostlib.run.tracking_run.DeviceSetup`), the emulator's
replayed host (``openshoe-emu replay --host fusion``, over a :class:`SessionSetup`) — sends the same
commands at the same moments, each once the module acknowledged the one before:

* right after 0x34 the fusion set-up (:data:`protocol.extensions.FUSION_SETUP`: each step's swing
  time, the module's time, attitude and magnetometers, and the module's serial number; the default
  of ``track``, ``log`` and :class:`HostSetup`, off with ``--no-fusion`` / ``fusion=False``), then,
  with an in-situ magnetometer calibration, the start
  of the magnetometer stream (:data:`WiggleCalibration.START
  <hostlib.calibration.wiggle.WiggleCalibration.START>`);
* at the first step packet, height compensation (:func:`protocol.extensions.height_compensation_on`);
* when the wiggle ended (the first step longer than 0.5 m), the stream's stop
  (:data:`WiggleCalibration.STOP <hostlib.calibration.wiggle.WiggleCalibration.STOP>`).

:class:`HostSetup` says which commands are due; :class:`SessionSetup` carries them out over a
:class:`~hostlib.link.session.HostSession` for a host that moves the bytes itself.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable, Mapping
from typing import Any

from protocol.extensions import FUSION_SETUP, height_compensation_on
from protocol.ids import Command

from ..calibration.wiggle import WiggleCalibration
from ..events import CommandAckEvent, StepEvent
from ..link.session import HostSession

__all__ = ["HostCommand", "HostSetup", "SessionSetup"]

#: A command as a host sends it: its meaning and its payload's fields.
HostCommand = tuple[Command, Mapping[str, Any]]


class HostSetup:
    """The commands a host sends besides 0x34 and the packet acks, and when (module docstring).

    *fusion*: the fusion set-up after 0x34 (the default; False: plain 0x34 step packets, whose steps
    carry no module time); *height_compensation*: height compensation at the first step packet;
    *wiggle*: the in-situ magnetometer calibration whose stream starts after the fusion set-up and
    stops when it ended. Each method returns the commands that became due, in the order they go
    out; a command is due once.
    """

    def __init__(self, *, fusion: bool = True, height_compensation: bool = False,
                 wiggle: WiggleCalibration | None = None):
        self.fusion = fusion
        self.wiggle = wiggle
        #: height compensation waits for the first step packet
        self.height_compensation_pending = height_compensation
        #: whether the magnetometer stream was started and not stopped yet
        self.streaming = False

    def after_start(self) -> list[HostCommand]:
        """Once 0x34 was acknowledged (or at once, with a module that tracks already): the fusion
        set-up (:meth:`fusion_setup`), then the magnetometer stream's start (:meth:`stream_start`)."""
        return self.fusion_setup() + self.stream_start()

    def fusion_setup(self) -> list[HostCommand]:
        """The fusion set-up's commands, if asked for (the first part of :meth:`after_start`)."""
        return list(FUSION_SETUP) if self.fusion else []

    def stream_start(self) -> list[HostCommand]:
        """The magnetometer stream's start, with a wiggle (the rest of :meth:`after_start`)."""
        if self.wiggle is None:
            return []
        self.streaming = True
        return list(self.wiggle.START)

    def stepped(self) -> list[HostCommand]:
        """A step packet came: height compensation, the first time."""
        if not self.height_compensation_pending:
            return []
        self.height_compensation_pending = False
        return [height_compensation_on()]

    def stop_stream(self) -> list[HostCommand]:
        """The magnetometer stream's stop, if it runs: when the wiggle ended, or when a walk ends
        with the module's outputs left on."""
        if not self.streaming or self.wiggle is None:
            return []
        self.streaming = False
        return list(self.wiggle.STOP)

    def follow(self, events: Iterable[Any], module_serial: str = "") -> list[HostCommand]:
        """For a host that reads the session's events itself: *events* in order (the wiggle is fed
        them, *module_serial* naming the module it is fitted on); the commands they made due."""
        events = list(events)
        due: list[HostCommand] = []
        for event in events:
            if isinstance(event, StepEvent):
                due += self.stepped()
        if self.wiggle is not None and self.wiggle.feed(events, module_serial):
            due += self.stop_stream()
        return due

    @property
    def sent(self) -> bool:
        """Whether every command of the set-up is out (height compensation waits for a step)."""
        return not self.height_compensation_pending


class SessionSetup:
    """A :class:`HostSetup` carried out without I/O over a :class:`~hostlib.link.session.HostSession`
    (*session*; default: the 2015 numbering, packets acknowledged as the module asks): the caller
    writes :meth:`start` to the module, then hands each chunk the module sent to :meth:`received` and
    writes what it returns — the packet acks, and the next command once the one before was acked."""

    def __init__(self, setup: HostSetup, session: HostSession | None = None):
        self.setup = setup
        self.session = session or HostSession(ack_policy="auto")
        self.queue: deque[HostCommand] = deque()
        self.awaiting: int | None = None  #: wire id of the command sent and not yet acked

    def start(self) -> bytes:
        """The first frame: 0x34 (the set-up's first commands follow its ack)."""
        self.queue.extend(self.setup.after_start())
        return self._send(Command.STEPWISE_DEAD_RECKONING, {})

    def _send(self, meaning: Command, fields: Mapping[str, Any]) -> bytes:
        self.awaiting = self.session.wire_id(meaning)
        return self.session.encode_command(meaning, **fields)

    def received(self, data: bytes) -> tuple[bytes, bytes]:
        """Follow the module's *data*: the packet acks to send, and the next command's frame when it
        is due (else b"")."""
        events, acks = self.session.feed(data)
        for event in events:
            if isinstance(event, CommandAckEvent) and event.command_id == self.awaiting:
                self.awaiting = None
        self.queue.extend(self.setup.follow(events))
        if self.awaiting is None and self.queue:
            return acks, self._send(*self.queue.popleft())
        return acks, b""
