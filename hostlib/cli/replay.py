"""``openshoe-host replay``: sum the steps of a raw capture (from ``log --raw``) offline, with the
aids and calibrations the options ask for, or fuse the captures of a module on each foot."""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from typing import TextIO

from protocol.board import FOOT_SIDES

from ..calibration.drift import DriftCalibration
from ..files.capture_check import check_capture
from ..inputs import read_input
from ..run.aid_setup import feet_tracker, prepare_aids
from ..run.calibrations import check_feet_modules, check_mag_module, saved_calibration, use_saved_calibrations
from ..run.in_situ import keep_in_situ
from ..run.status import Messages
from .options import aid_options, feet_settings, per_foot
from .outputs import aids_summary, finish_feet, stats_line, write_outputs

__all__ = ["cmd_replay", "warn"]


def warn(warnings: list[str]) -> None:
    """Say each warning about an input on stderr, the command's name first."""
    for text in warnings:
        print(f"openshoe-host: warning: {text}", file=sys.stderr)


def cmd_replay(args: argparse.Namespace, out: TextIO) -> int:
    from ..aids.geodesy import parse_origin
    from ..files.replay import replay_calibrating, replay_session

    if args.capture2 is not None:
        return _replay_feet(args, out)
    drift = DriftCalibration.load(args.drift[0]) if args.drift else None
    origin = parse_origin(args.origin) if args.origin else None
    data = read_input(args.capture, "capture")
    options = aid_options(args, origin)
    saved = None
    if options.wants_saved_calibration:  # the capture's module's own, if one was saved
        saved = saved_calibration(options, replay_session(data, command_set=args.command_set).mcu_serial)
    aids = None
    if options.uses_aids:
        aids = prepare_aids(options if saved is None else replace(options, mag_calibration=saved[0]))
        if saved is not None:
            aids.calibration_source = f"saved {saved[1]}"
    wiggle = None
    if args.calibrate_mag:
        from ..calibration.wiggle import WiggleCalibration

        wiggle = WiggleCalibration()
        session = replay_calibrating(data, wiggle, aids.tracker, command_set=args.command_set)
        aids.calibration_source = (keep_in_situ(wiggle, args.mag_cal_dir, Messages("openshoe-host replay"))
                                   if wiggle.done else "the wiggle did not end")
    else:
        session = replay_session(data, command_set=args.command_set,
                                 tracker=None if aids is None else aids.tracker)
    warn(check_capture(args.capture, data, session))
    track, stats = session.tracker.track, session.stats
    if aids is not None:
        cal = aids.tracker.settings.mag_calibration
        if cal is not None:
            check_mag_module(cal, session.mcu_serial)
        origin = aids_summary(aids, out) or origin
    if wiggle is not None:
        print(wiggle.summary(), file=out)
    if drift is not None:
        corrected = drift.apply(track, module_serial=session.mcu_serial, what=args.capture)
        print(f"drift correction: {drift}", file=out)
        print(f"closure {track.closure_error():.3f} m uncorrected → {corrected.closure_error():.3f} m "
              f"corrected (horizontal; 3-D {track.closure_error(False):.3f} → "
              f"{corrected.closure_error(False):.3f} m)", file=out)
        track = corrected
    write_outputs(args, track, origin, geographic_csv=bool(args.gps))
    print(repr(track), file=out)
    print(stats_line(stats), file=out)
    return 0


def _replay_feet(args: argparse.Namespace, out: TextIO) -> int:
    """``replay LEFT RIGHT``: each capture decoded by its own session (its counters, resends and
    gaps), the two feet's steps then fused in module-time order."""
    from ..aids.geodesy import parse_origin
    from ..files.replay import decode_feet, replay_session

    origin = parse_origin(args.origin) if args.origin else None
    paths = dict(zip(FOOT_SIDES, (args.capture, args.capture2), strict=True))
    left, right = (read_input(paths[side], "capture") for side in FOOT_SIDES)
    options = aid_options(args, origin)
    drift = {side: DriftCalibration.load(path) for side, path in per_foot(args.drift).items()}
    tracker, aids = feet_tracker(options, feet_settings(args), drift=drift, last_counter=None, defer=True)
    if aids is not None and options.wants_saved_calibration:  # each capture's module's own, if saved
        serials = {side: replay_session(data, command_set=args.command_set).mcu_serial
                   for side, data in zip(FOOT_SIDES, (left, right), strict=True)}
        use_saved_calibrations(options, aids, serials)
    sessions = decode_feet(left, right, tracker, command_set=args.command_set)
    for side, data in zip(FOOT_SIDES, (left, right), strict=True):
        warn(check_capture(paths[side], data, sessions[side]))
    check_feet_modules(tracker, {side: sessions[side].mcu_serial for side in FOOT_SIDES}, paths)
    tracker.fuse_in_time_order()
    if aids is not None:
        origin = aids_summary(aids, out) or origin  # with GPS, the first fix: on the globe
    streams = {side: (paths[side], sessions[side].stats) for side in FOOT_SIDES}
    finish_feet(args, tracker, streams, origin, out)
    return 0
