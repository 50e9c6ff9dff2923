"""``openshoe-host drift calibrate CAPTURE... -o CAL.json``: one module's closed-loop drift
calibration (hostlib.calibration.drift) from captures of closed loops walked with the fusion set-up."""

from __future__ import annotations

import argparse
from typing import TextIO

from ..calibration.drift import DriftError, calibrate, loop_closure, serial_text
from ..inputs import read_input

__all__ = ["cmd_drift"]


def cmd_drift(args: argparse.Namespace, out: TextIO) -> int:
    """``drift calibrate CAPTURE... -o CAL.json``: each capture one closed loop of one module."""
    from ..files.capture_check import check_capture
    from ..files.replay import replay_session
    from .replay import warn

    sessions = []
    for path in args.captures:
        data = read_input(path, "capture")
        sessions.append(replay_session(data, command_set=args.command_set))
        warn(check_capture(path, data, sessions[-1]))
    serials = {s.mcu_serial for s in sessions}
    if len(serials) > 1:
        which = "; ".join(f"{path}: {serial_text(s.mcu_serial)}" for path, s in zip(args.captures, sessions,
                                                                                   strict=True))
        raise DriftError(f"the captures come from different modules ({which}): a drift calibration "
                         "belongs to one module")
    tracks = [s.tracker.track for s in sessions]
    cal = calibrate(tracks, serials.pop(), names=args.captures)
    for path, track in zip(args.captures, tracks, strict=True):
        loop = loop_closure(track, path)
        dp = ", ".join(f"{v:+.3f}" for v in loop.dp)
        print(f"{path}: {loop.steps} steps, {loop.distance_m:.2f} m, T_swing {loop.t_swing_s:.3f} s, "
              f"closure {loop.closure_m:.3f} m (Δp = [{dp}] m)", file=out)
    print(cal, file=out)
    cal.save(args.output)
    print(f"→ {args.output}", file=out)
    return 0
