"""Re-processing a captured byte stream (``openshoe-host log --raw``) offline into a track.

The capture holds what the module sent (command acks and state packets, with
any garbage and resends the link produced). The same :class:`HostSession`
that runs live decodes it here, without sending anything back, so a capture
gives the same steps, gaps and counters as the live session did.

A capture does not show what the host asked for, only the module's acks of it.
The replay takes the acks of the commands an openshoe host sends after 0x34
(:data:`CAPTURE_HOST_COMMANDS`: the fusion set-up, :data:`protocol.extensions.FUSION_SETUP`)
as those commands, so the step packets of a fusion capture are split into their
states (with the swing time) and its module serial number is read. Both
``openshoe-host log --raw`` and ``openshoe-emu replay --wire`` write such a
capture: every byte the module transmitted, in order.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from protocol.commands import command_set as _command_set
from protocol.extensions import FUSION_SETUP
from protocol.ids import Command

from .feet import FOOT_SIDES, FeetSettings, TwoFeetTracker
from .session import HostSession, SessionStats
from .tracking import StepTracker, Track

__all__ = ["CAPTURE_HOST_COMMANDS", "decode_feet", "implied_commands", "replay_bytes", "replay_capture",
           "replay_capture_session", "replay_feet", "replay_session"]

#: The commands a capture's host is taken to have sent when the module acknowledges them:
#: those of the fusion set-up (STATE_IF_SETUP, MCU_ID).
CAPTURE_HOST_COMMANDS: tuple[tuple[Command, Mapping[str, Any]], ...] = FUSION_SETUP


def implied_commands(command_set: str) -> dict[int, tuple[Command, Mapping[str, Any]]]:
    """Wire id → command of :data:`CAPTURE_HOST_COMMANDS` in *command_set*: a
    :class:`HostSession`'s *implied_commands* when it decodes a capture."""
    cs = _command_set(command_set)
    return {cs.spec(meaning).wire_id: (meaning, fields) for meaning, fields in CAPTURE_HOST_COMMANDS
            if cs.supports(meaning)}


def replay_session(data: bytes, *, command_set: str = "2015", chunk: int = 4096,
                   tracker: StepTracker | None = None) -> HostSession:
    """The host session after the module → host byte stream *data*: its track
    (``session.tracker.track``), counters (``session.stats``) and the module's serial number
    (``session.mcu_serial``, None when the capture has no MCU_ID packet).

    The step counter before the first step is taken as unknown (a capture may
    start mid-walk), so no gap is reported before the first step seen.
    """
    session = HostSession(command_set, ack_policy="never",
                          tracker=tracker if tracker is not None else StepTracker(last_counter=None),
                          implied_commands=implied_commands(command_set))
    for i in range(0, len(data), chunk):
        session.feed(data[i : i + chunk])
    session.finish()
    return session


def replay_bytes(data: bytes, *, command_set: str = "2015", chunk: int = 4096,
                 tracker: StepTracker | None = None) -> tuple[Track, SessionStats]:
    """Sum the steps in a module → host byte stream; returns the track and the session counters
    (:func:`replay_session`)."""
    session = replay_session(data, command_set=command_set, chunk=chunk, tracker=tracker)
    return session.tracker.track, session.stats


def replay_capture(path: str | Path, **kwargs) -> tuple[Track, SessionStats]:
    """:func:`replay_bytes` of a capture file."""
    return replay_bytes(Path(path).read_bytes(), **kwargs)


def replay_capture_session(path: str | Path, **kwargs) -> HostSession:
    """:func:`replay_session` of a capture file."""
    return replay_session(Path(path).read_bytes(), **kwargs)


def decode_feet(left: bytes, right: bytes, tracker: TwoFeetTracker, *,
                command_set: str = "2015") -> dict[str, HostSession]:
    """Each foot's capture decoded by its own session into *tracker*'s foot (its counters,
    resends and gaps; the counter before its first step unknown, as in :func:`replay_session`).
    With a deferring tracker (``defer=True``) the steps wait for
    :meth:`~hostlib.feet.TwoFeetTracker.fuse_in_time_order`: the caller can check each module's
    serial number (``session.mcu_serial``) against its calibrations first."""
    return {side: replay_session(data, command_set=command_set, tracker=tracker.foot(side))
            for side, data in zip(FOOT_SIDES, (left, right), strict=True)}


def replay_feet(left: bytes, right: bytes, settings: FeetSettings | None = None, *,
                command_set: str = "2015", tracker: TwoFeetTracker | None = None
                ) -> tuple[TwoFeetTracker, dict[str, SessionStats]]:
    """The two feet of one walker from their modules' captures (``openshoe-host replay LEFT RIGHT``):
    :func:`decode_feet`, then both feet's steps fused in module-time order
    (:meth:`~hostlib.feet.TwoFeetTracker.fuse_in_time_order`). *tracker* (made with ``defer=True``
    and ``last_counter=None``, e.g. with aids) replaces the plain one of *settings*. Returns the
    tracker and each foot's session counters."""
    if tracker is None:
        tracker = TwoFeetTracker(settings, last_counter=None, defer=True)
    sessions = decode_feet(left, right, tracker, command_set=command_set)
    tracker.fuse_in_time_order()
    return tracker, {side: session.stats for side, session in sessions.items()}
