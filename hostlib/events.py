"""Every event a host receives from a module, declared in one place.

* :class:`CommandAckEvent` — the module acknowledged a command (``A0 cmd ck ck``);
* :class:`PacketEvent` — a new state packet (resends are not reported again);
* :class:`StepEvent` — a new step, summed into the track;
* :class:`GapEvent` — step counters skipped between two summed steps;
* :class:`LinkEvent` — the serial link dropped or came back.

:class:`hostlib.link.session.HostSession` produces the first four from the byte
stream (:data:`StreamEvent`); :class:`hostlib.link.device.Device` adds the fifth
(:data:`Event` is any of them). All are frozen dataclasses.

This module is as light as :mod:`hostlib.track.steps`, which records its gaps as
:class:`GapEvent`: it needs numpy at run time and names :mod:`protocol` types
for type checkers only (the payload hexdump imports :mod:`protocol.frames` when
an event is printed).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from protocol.codec import Step

__all__ = [
    "CommandAckEvent",
    "Event",
    "GapEvent",
    "LinkEvent",
    "PacketEvent",
    "StepEvent",
    "StepOutcome",
    "StreamEvent",
]


class StepOutcome(Enum):
    """What the tracker did with one step."""

    SUMMED = "summed"  #: the next step, summed
    SUMMED_AFTER_GAP = "summed after gap"  #: summed, but steps before it were lost
    DUPLICATE = "duplicate"  #: a resend of a step already summed (or older): ignored
    #: a step whose numbers are not finite or whose covariance is no covariance: counted, left out
    #: (:func:`hostlib.track.step_checks.step_problem` says why)
    REJECTED = "rejected"

    @property
    def summed(self) -> bool:
        """Whether the step went into the track."""
        return self in (StepOutcome.SUMMED, StepOutcome.SUMMED_AFTER_GAP)


@dataclass(frozen=True)
class CommandAckEvent:
    """The module acknowledged the command with header byte *command_id* (``A0 cmd ck ck``).

    *command_id* is the byte on the wire, in the link's numbering (0x34 for
    step-wise dead reckoning in the 2015 numbering, 0x14 in the 2014 one).
    """

    command_id: int

    def __repr__(self) -> str:
        return f"CommandAckEvent(command_id=0x{self.command_id:02X})"


@dataclass(frozen=True, eq=False)
class PacketEvent:
    """A new state packet (resends are not reported again).

    *number* is the packet number (uint16, +1 per packet). *states* maps state
    id → value (native numpy arrays) when the payload could be split by the
    states the host asked for, else None (the raw *payload* is always there).
    """

    number: int
    payload: bytes
    states: dict[int, np.ndarray] | None = None

    def __repr__(self) -> str:
        from protocol.frames import hexdump

        ids = "?" if self.states is None else " ".join(f"{i:02X}" for i in self.states)
        payload = hexdump(self.payload, 16)
        return f"PacketEvent(number=0x{self.number:04X}, states=[{ids}], payload={payload!r})"


@dataclass(frozen=True, eq=False)
class StepEvent:
    """A new step, summed into the track: the step, the packet it came in, the pose after it.

    *step* is the module's :class:`protocol.codec.Step` (dx, dp, counter).
    Resent steps (a counter already summed) are not reported.
    """

    step: Step
    packet_number: int
    outcome: StepOutcome
    pose: np.ndarray  #: [x, y, z, χ] after this step
    covariance: np.ndarray  #: 4×4 covariance of that pose
    index: int  #: 1-based index of the step in the track
    #: the step's swing time [s] (state 0x34 SWING_TIME, :data:`protocol.extensions.FUSION_SETUP`);
    #: NaN when the packet did not carry it
    swing_time: float = math.nan

    def __repr__(self) -> str:
        x, y, z, chi = self.pose
        return (
            f"StepEvent(#{self.index} counter={self.step.counter}, packet=0x{self.packet_number:04X}, "
            f"pose=({x:.3f}, {y:.3f}, {z:.3f}, {chi:.3f}), {self.outcome.value})"
        )


@dataclass(frozen=True)
class GapEvent:
    """Steps lost between two summed steps: counters ``after+1 .. counter−1`` never arrived.

    The pose continues from the last summed step (the lost displacement is
    unknown); the gap is also kept in :attr:`hostlib.track.steps.Track.gaps`.
    """

    after: int | None  #: counter of the last summed step (None: none summed yet)
    counter: int  #: counter of the step that arrived after the gap
    missing: int  #: number of step counters skipped
    index: int  #: index in the track of the step that arrived after the gap

    def __str__(self) -> str:
        after = "start" if self.after is None else str(self.after)
        return f"step gap: {self.missing} step(s) missing between {after} and {self.counter}"


@dataclass(frozen=True)
class LinkEvent:
    """The serial link dropped (``up=False``) or came back (``up=True``).

    *error* says why it dropped (None when it came back). While the link is down
    the device keeps re-opening it if it was asked to reconnect.
    """

    up: bool
    error: BaseException | None = None


#: An event decoded from the module's byte stream (what :meth:`HostSession.feed` returns).
StreamEvent = CommandAckEvent | PacketEvent | StepEvent | GapEvent

#: Any event a host receives: one from the byte stream, or a change of the link.
Event = StreamEvent | LinkEvent
