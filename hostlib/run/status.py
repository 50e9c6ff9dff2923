"""What a walk tells its user while it goes: messages (:class:`Messages`), the status line of one
module (:func:`summary_line`) or of two feet (:func:`feet_summary_line`), with what the aids did
(:func:`aids_status`), kept up to date on a terminal (:class:`LiveLine`)."""

from __future__ import annotations

import sys
import time
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, TextIO

from ..track.steps import heading_deg

if TYPE_CHECKING:
    from ..calibration.drift import DriftCalibration
    from ..fusion.feet import TwoFeetTracker
    from ..link.device import Device
    from .aid_setup import AidSetup
    from .gps_stream import GpsStream

__all__ = ["LiveLine", "Messages", "aids_status", "feet_summary_line", "heading_deg", "pose_text",
           "summary_line"]


class Messages:
    """Where a walk's messages go, one line each: to *stream* (default: the process's stderr at the
    time of the message). A message about a module, the receiver or a calibration starts with
    *prefix* (e.g. ``"openshoe-host track"``: ``openshoe-host track: the left foot (…): link back``)."""

    def __init__(self, prefix: str = "", stream: TextIO | None = None):
        self.prefix = prefix
        self.stream = stream

    def say(self, text: str) -> None:
        """A line as it is (what the run is doing, what the wearer should do)."""
        print(text, file=sys.stderr if self.stream is None else self.stream)

    def note(self, text: str) -> None:
        """A line about something that happened, after the prefix."""
        self.say(f"{self.prefix}: {text}" if self.prefix else text)


def pose_text(pose: Sequence[float], sigma: float, note: str = "") -> str:
    """Position, heading and horizontal 1σ as the status lines show them."""
    x, y, z, chi = pose
    return (f"x {x:+8.2f} y {y:+8.2f} z {z:+6.2f} m{note} | heading {heading_deg(chi):5.1f}° "
            f"| 1σ {sigma:6.3f} m")


def summary_line(dev: Device, drift: DriftCalibration | None = None) -> str:
    """One line: step packets, steps with motion, distance, position, heading, 1σ, gaps.

    The module sends a step packet at every INS reset, also while the wearer stands
    still; "steps" counts only those that moved the foot (hostlib.track.steps.is_motion_step).
    With *drift* the position is the drift-corrected one (refused for another module, or a
    step without a swing time: :class:`~hostlib.calibration.drift.DriftError`).
    """
    if drift is None:  # what the line shows, read under the session's lock (no copy of the walk)
        with dev.session_lock:
            tr = dev.track
            x, y, z, chi = tr.final_pose
            count, moving, distance, sigma = len(tr), tr.motion_steps, tr.distance, tr.closure_sigma()
            gaps, missing = len(tr.gaps), tr.missing
        return _summary(dev, (count, moving, distance, gaps, missing), pose_text((x, y, z, chi), sigma))
    tr = dev.track_snapshot()
    x, y, z, chi = tr.final_pose
    corrected = ""
    if len(tr):
        drift.check_module(dev.session.mcu_serial)
        x, y, z = tr.final_pose[:3] + drift.offsets(tr)[-1]
        corrected = " (drift-corrected)"
    text = pose_text((x, y, z, chi), tr.closure_sigma(), corrected)
    return _summary(dev, (len(tr), tr.motion_steps, tr.distance, len(tr.gaps), tr.missing), text)


def _summary(dev: Device, counts: tuple[int, int, float, int, int], pose: str) -> str:
    """:func:`summary_line` from the track's step packets, steps that moved, distance, gaps and steps
    missing (*counts*) and its *pose* text."""
    packets, moving, distance, gaps, missing = counts
    return (f"packets {packets:5d} | steps {moving:5d} | {distance:8.2f} m | {pose} "
            f"| gaps {gaps} (missing {missing}) | garbage {dev.stats['garbage_bytes']}")


def feet_summary_line(tracker: TwoFeetTracker, devices: Mapping[str, Device],
                      failed: Sequence[str] = ()) -> str:
    """One line for two feet: per foot its step packets, steps with motion, distance and gaps (and
    whether its link is down, or its walk failed: the *failed* sides), then the fused body."""
    parts = []
    for side, dev in devices.items():
        with dev.session_lock:  # read under the lock the steps are summed under (no copy of the walk)
            tr = dev.track
            packets, moving, distance, gaps, missing = (len(tr), tr.motion_steps, tr.distance, len(tr.gaps),
                                                        tr.missing)
        state = " FAILED" if side in failed else ("" if dev.link_up else " LINK DOWN")
        parts.append(f"{side} {packets:4d}/{moving:4d} steps {distance:7.2f} m "
                     f"gaps {gaps} (missing {missing}){state}")
    pose, sigma = tracker.body_end()
    return " | ".join(parts) + f" | body {pose_text(pose, sigma)}"


def aids_status(aids: AidSetup | None, receiver: GpsStream | None = None) -> str:
    """What the aids did so far, for a status line ("" without them): compass and GPS updates, and
    with a *receiver* read live its fixes and whether it went away."""
    if aids is None or not (aids.tracker.aid_settings.compass or aids.tracker.aid_settings.gps):
        return ""  # the module's errors alone: nothing to count
    f = aids.tracker.fusion
    line = f" | compass {f.compass_updates} | GPS {f.gps_updates} updates"
    if receiver is not None:
        st = receiver.fixes.stats
        line += (f" of {st.fixes} fixes ({st.missing_fix} without a fix, {st.garbled} garbled)"
                 + (" RECEIVER GONE" if receiver.lost else ""))
    return line


def _is_terminal(out: Any) -> bool:
    return bool(getattr(out, "isatty", lambda: False)())


class LiveLine:
    """A status line kept up to date with ``\\r`` on a terminal; elsewhere (a log file, a pipe)
    one line each time *key* changes (a new step), or every *every_s* seconds."""

    def __init__(self, out: TextIO, every_s: float | None = None):
        self.out = out
        self.tty = _is_terminal(out)
        self.every_s = every_s
        self._key: object = None
        self._next = time.monotonic() + (every_s or 0.0)

    def show(self, text: str, key: object = None) -> None:
        """Show *text*; *key* says whether it is news (off a terminal, a line is written for news
        only, or when *every_s* passed)."""
        if self.tty:
            self.out.write("\r" + text)
        elif key != self._key or (self.every_s is not None and time.monotonic() >= self._next):
            self._key = key
            self._next = time.monotonic() + (self.every_s or 0.0)
            self.out.write(text + "\n")
        else:
            return
        self.out.flush()

    def close(self) -> None:
        """The last line stays: on a terminal, end it."""
        if self.tty:
            self.out.write("\n")
