"""``openshoe-host track``: start step-wise dead reckoning (0x34) on one module, or on a module on
each foot, and sum the steps as they come — a :class:`~hostlib.run.tracking_run.TrackingRun` made
from the command line — then say what the walk and its aids did and write the files asked for."""

from __future__ import annotations

import argparse
from contextlib import ExitStack
from typing import TextIO

from protocol.board import FOOT_SIDES

from ..calibration.drift import DriftCalibration
from ..run.status import LiveLine, Messages
from ..run.tracking_run import TrackingRun
from ..web.walk_page import following, walk_page
from .options import aid_options, feet_settings, open_device, per_foot, run_options
from .outputs import aids_summary, finish_feet, write_outputs

__all__ = ["cmd_track"]


def cmd_track(args: argparse.Namespace, out: TextIO) -> int:
    from ..aids.geodesy import parse_origin

    drift = DriftCalibration.load(args.drift[0]) if args.drift and args.url2 is None else None
    origin = parse_origin(args.origin) if args.origin else None  # refused before the port opens
    messages = Messages("openshoe-host track")
    if args.url2 is not None:
        run = TrackingRun(run_options(args), aid_options(args, origin), feet=feet_settings(args),
                          drift=per_foot(args.drift), messages=messages)
        return _track_feet(args, run, origin, out)
    run = TrackingRun(run_options(args), aid_options(args, origin), drift=drift, messages=messages)
    with ExitStack() as stack:
        page = stack.enter_context(walk_page(args.web, _title(args), messages))
        stack.enter_context(run)
        dev = stack.enter_context(open_device(args, args.url, queue_packets=False,  # it reads steps
                                              tracker=run.tracker_for(None)))
        run.start(dev)
        stack.enter_context(following(page, run))
        run.follow(LiveLine(out))
        track = dev.track_snapshot()
        if run.aids is not None:
            origin = aids_summary(run.aids, out) or origin
        if run.in_situ is not None:
            print(run.in_situ.wiggle.summary(), file=out)
        if drift is not None:
            corrected = drift.apply(track, module_serial=dev.session.mcu_serial)
            moved = corrected.final_pose[:3] - track.final_pose[:3]
            print(f"drift correction ({drift}): the end moved by "
                  f"[{', '.join(f'{v:+.3f}' for v in moved)}] m", file=out)
            track = corrected
        write_outputs(args, track, origin, geographic_csv=bool(args.gps) and origin is not None)
        print(repr(track), file=out)
    return 0


def _track_feet(args: argparse.Namespace, run: TrackingRun, origin: tuple[float, float, float] | None,
                out: TextIO) -> int:
    """``track LEFT RIGHT``: a device per foot, both feet's steps fused in arrival order
    (hostlib.fusion.feet); with the aids, each foot's compass and a receiver read live (its fixes the
    body's, on each module's clock: hostlib.run.gps_stream), each foot's calibrations checked against
    the module on that foot once both named themselves."""
    with ExitStack() as stack:
        page = stack.enter_context(walk_page(args.web, _title(args), run.messages))
        stack.enter_context(run)
        urls = dict(zip(FOOT_SIDES, (args.url, args.url2), strict=True))
        devices = {side: stack.enter_context(open_device(args, urls[side], queue_packets=False,
                                                         tracker=run.tracker_for(side)))
                   for side in FOOT_SIDES}
        run.start(devices)
        stack.enter_context(following(page, run))
        run.follow(LiveLine(out))
        streams = {m.side: (m.dev.name, m.dev.session.stats) for m in run.modules}
        if run.aids is not None:
            origin = aids_summary(run.aids, out) or origin  # with GPS, the first fix: on the globe
    finish_feet(args, run.tracker, streams, origin, out)
    return 0


def _title(args: argparse.Namespace) -> str:
    """The live page's title: the modules tracked."""
    return "track " + " ".join(url for url in (args.url, args.url2) if url)
