"""Re-processing a captured byte stream (``openshoe-host log --raw``) offline into a track.

The capture holds what the module sent (command acks and state packets, with
any garbage and resends the link produced). The same :class:`HostSession`
that runs live decodes it here, without sending anything back, so a capture
gives the same steps, gaps and counters as the live session did.

A capture does not show what the host asked for, only the module's acks of it.
The replay takes the acks of the commands an openshoe host sends after 0x34
(:data:`CAPTURE_HOST_COMMANDS`: the fusion set-up, :data:`protocol.extensions.FUSION_SETUP`,
and the in-situ calibration's magnetometer stream, on then off) as those commands, in the
order the host sends them, so the step packets of a fusion capture are split into their
states (with the swing time), its module serial number is read, and the stream's packets
(the magnetometers and the attitude, many a second while the wearer wiggles the shoe) are
told from the steps. A capture without the stream has no ack of it: nothing changes.

:func:`replay_calibrating` replays a capture of the in-situ calibration
(``openshoe-host replay --calibrate-mag``): a :class:`hostlib.calibration.wiggle.WiggleCalibration` follows
the session's events as it does live, and hands its result to the tracker when the first long
step ends it. Both
``openshoe-host log --raw`` and ``openshoe-emu replay --wire`` write such a
capture: every byte the module transmitted, in order.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from protocol.commands import command_set as _command_set
from protocol.extensions import FUSION_SETUP, MAG_STREAM_START, MAG_STREAM_STOP
from protocol.ids import Command

from ..calibration.drift import serial_text
from ..calibration.wiggle import WiggleCalibration
from ..events import StreamEvent
from ..link.session import HostSession, SessionStats
from ..track.steps import StepTracker, Track

if TYPE_CHECKING:  # the two feet's fusion is imported when two feet are replayed (a batch sums one foot)
    from ..fusion.feet import FeetSettings, TwoFeetTracker

__all__ = ["CALIBRATION_CHUNK", "CAPTURE_HOST_COMMANDS", "decode_feet", "implied_commands", "replay_bytes",
           "replay_calibrating", "replay_capture", "replay_capture_session", "replay_feet", "replay_session"]

#: The commands a capture's host is taken to have sent when the module acknowledges them, in the
#: order it sends them: those of the fusion set-up (STATE_IF_SETUP, MCU_ID), then the in-situ
#: calibration's magnetometer stream on and off (OUTPUT_MULTIPLE_STATES twice).
CAPTURE_HOST_COMMANDS: tuple[tuple[Command, Mapping[str, Any]], ...] = (FUSION_SETUP + MAG_STREAM_START
                                                                        + MAG_STREAM_STOP)


def implied_commands(command_set: str) -> dict[int, list[tuple[Command, Mapping[str, Any]]]]:
    """Wire id → the commands of :data:`CAPTURE_HOST_COMMANDS` with that id in *command_set*, in
    order: a :class:`HostSession`'s *implied_commands* when it decodes a capture."""
    cs = _command_set(command_set)
    implied: dict[int, list[tuple[Command, Mapping[str, Any]]]] = {}
    for meaning, fields in CAPTURE_HOST_COMMANDS:
        if cs.supports(meaning):
            implied.setdefault(cs.spec(meaning).wire_id, []).append((meaning, fields))
    return implied


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


#: Bytes fed at a time while an in-situ calibration follows a replay: fewer than a fusion step
#: packet has (110), so that no chunk completes two steps and the calibration sees each step
#: before the tracker sums the next — the step that ends it is the last one summed without it,
#: as when the host follows a live module.
CALIBRATION_CHUNK = 64


def replay_calibrating(data: bytes, wiggle: WiggleCalibration, tracker: Any, *, command_set: str = "2015",
                       on_events: Callable[[list[StreamEvent]], object] | None = None) -> HostSession:
    """The host session after the capture *data* of an in-situ calibration: *tracker* (a
    :class:`hostlib.fusion.tracker.FusionTracker`) holds its compass while *wiggle* takes the stream's
    readings and the steps; when the first long step ends it, the result goes to the tracker
    (:meth:`~hostlib.calibration.wiggle.WiggleCalibration.release`), named after the module's serial number.
    *on_events* sees the session's events too, after the calibration. The step counter before the
    first step is unknown, as in :func:`replay_session`."""
    tracker.hold_compass()
    session = HostSession(command_set, ack_policy="never", tracker=tracker,
                          implied_commands=implied_commands(command_set))

    def follow(events: list[StreamEvent]) -> None:
        serial = serial_text(session.mcu_serial) if session.mcu_serial is not None else ""
        if wiggle.feed(events, serial):
            wiggle.release(tracker)
        if on_events is not None:
            on_events(events)

    for i in range(0, len(data), CALIBRATION_CHUNK):
        follow(session.feed(data[i : i + CALIBRATION_CHUNK])[0])
    follow(session.finish()[0])
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
    :meth:`~hostlib.fusion.feet.TwoFeetTracker.fuse_in_time_order`: the caller can check each module's
    serial number (``session.mcu_serial``) against its calibrations first."""
    from ..fusion.feet import FOOT_SIDES

    return {side: replay_session(data, command_set=command_set, tracker=tracker.foot(side))
            for side, data in zip(FOOT_SIDES, (left, right), strict=True)}


def replay_feet(left: bytes, right: bytes, settings: FeetSettings | None = None, *,
                command_set: str = "2015", tracker: TwoFeetTracker | None = None
                ) -> tuple[TwoFeetTracker, dict[str, SessionStats]]:
    """The two feet of one walker from their modules' captures (``openshoe-host replay LEFT RIGHT``):
    :func:`decode_feet`, then both feet's steps fused in module-time order
    (:meth:`~hostlib.fusion.feet.TwoFeetTracker.fuse_in_time_order`). *tracker* (made with ``defer=True``
    and ``last_counter=None``, e.g. with aids) replaces the plain one of *settings*. Returns the
    tracker and each foot's session counters."""
    if tracker is None:
        from ..fusion.feet import TwoFeetTracker

        tracker = TwoFeetTracker(settings, last_counter=None, defer=True)
    sessions = decode_feet(left, right, tracker, command_set=command_set)
    tracker.fuse_in_time_order()
    return tracker, {side: session.stats for side, session in sessions.items()}
