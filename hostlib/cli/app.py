"""The ``openshoe-host`` command line: its parser, one sub-command per module of :mod:`hostlib.cli`,
and :func:`main`, which refuses options that do not go together before any port opens, runs the
command and turns the host's errors into messages and exit statuses."""

from __future__ import annotations

import argparse
import importlib
import signal
import sys
import threading
from collections.abc import Callable, Sequence
from typing import TextIO

from ..errors import HostError
from ..web.address import web_address
from .checks import value_refusal
from .options import (
    add_aid_options,
    add_common,
    add_feet_options,
    add_log_calibration_options,
    add_setup_options,
    log_refusal,
    step_count,
    usage_refusal,
)

__all__ = ["DESCRIPTION", "build_parser", "main"]

#: What ``openshoe-host --help`` says first.
DESCRIPTION = ("``openshoe-host``: track, log and inspect an OpenShoe module (real or emulated) from a "
               "terminal.")

#: Each command's function, (args, out) → exit status, by its module of :mod:`hostlib.cli` and its
#: name: a run imports only its command's module.
COMMANDS = {"track": ("track", "cmd_track"), "log": ("log", "cmd_log"), "info": ("info", "cmd_info"),
            "replay": ("replay", "cmd_replay"), "drift": ("drift", "cmd_drift")}


def command(name: str) -> Callable[[argparse.Namespace, TextIO], int]:
    """The function of the command *name* (its module imported now)."""
    module, function = COMMANDS[name]
    return getattr(importlib.import_module(f"{__package__}.{module}"), function)


def _add_track(sub: argparse._SubParsersAction) -> None:
    t = sub.add_parser("track", help="start step-wise dead reckoning (0x34) and sum the steps "
                                     "(of one module, or of a module on each foot)")
    add_common(t)
    t.add_argument("url2", nargs="?", metavar="URL2",
                   help="a module on the other foot: url is then the left foot's, URL2 the right foot's, "
                        "and the two are fused (hostlib.fusion.feet)")
    t.add_argument("--duration", type=float, default=None, help="seconds to track (default: until Ctrl-C)")
    t.add_argument("--steps", type=step_count, default=None, metavar="N",
                   help="stop once N step packets came (from each module, with two: not from a foot whose "
                        "link was lost and that sent none since); with --duration, whichever comes first")
    t.add_argument("--csv", help="write the track (poses + covariances) to this CSV file (two feet: the "
                                 "body's, and each foot's in more columns)")
    t.add_argument("--geojson", help="write the track as GeoJSON")
    t.add_argument("--origin", help="LAT,LON[,ALT] of the start, for geographic GeoJSON")
    t.add_argument("--png", help="plot the track with 1-sigma ellipses to this PNG (needs matplotlib)")
    t.add_argument("--every", type=int, default=10, help="ellipse every N steps in the PNG")
    t.add_argument("--leave-running", action="store_true", help="do not switch outputs off at the end")
    t.add_argument("--attach", action="store_true",
                   help="do not send 0x34: sum the steps of a module that is already tracking")
    t.add_argument("--heading", type=float, default=0.0,
                   help="initial heading in degrees from north towards east (default 0)")
    add_setup_options(t)
    add_aid_options(t, live=True)
    t.add_argument("--drift", nargs="+", metavar="CAL.json",
                   help="correct the track with this module's drift calibration (not with --no-fusion); "
                        "with two URLs, the left foot's module's then the right foot's (- for none)")
    add_feet_options(t, "URL")
    t.add_argument("--web", metavar="[HOST:]PORT", type=web_address,
                   help="serve a live page of the walk (plan view, height, heading, counters) on this "
                        "port, on 127.0.0.1 unless HOST is given (0: a free port); its URL is said on stderr "
                        "(needs aiohttp: the web extra)")


def _add_log(sub: argparse._SubParsersAction) -> None:
    lg = sub.add_parser("log", help="capture the module's byte stream to a file (packets still acked)")
    add_common(lg)
    lg.add_argument("--raw", required=True, help="file to write every received byte to")
    lg.add_argument("--duration", type=float, default=None, help="seconds to capture (default: until Ctrl-C)")
    lg.add_argument("--steps", type=step_count, default=None, metavar="N",
                    help="stop once N step packets came; with --duration, whichever comes first")
    lg.add_argument("--start", action="store_true", help="send 0x34 (step-wise dead reckoning) first")
    add_setup_options(lg)
    add_log_calibration_options(lg)


def _add_replay(sub: argparse._SubParsersAction) -> None:
    r = sub.add_parser("replay", help="sum the steps of a raw capture (from `log --raw`) offline "
                                      "(or fuse the captures of a module on each foot)")
    r.add_argument("capture", help="file of module bytes")
    r.add_argument("capture2", nargs="?", metavar="CAPTURE2",
                   help="the capture of a module on the other foot: capture is then the left foot's, "
                        "CAPTURE2 the right foot's, and the two are fused (hostlib.fusion.feet)")
    r.add_argument("--command-set", choices=("2014", "2015"), default="2015")
    r.add_argument("--csv", help="write the track to this CSV file (two feet: the body's, and each "
                                 "foot's in more columns)")
    r.add_argument("--geojson", help="write the track as GeoJSON")
    r.add_argument("--origin", help="LAT,LON[,ALT] of the start, for geographic GeoJSON")
    r.add_argument("--png", help="plot the track to this PNG (needs matplotlib)")
    r.add_argument("--every", type=int, default=10, help="ellipse every N steps in the PNG")
    add_aid_options(r)
    r.add_argument("--drift", nargs="+", metavar="CAL.json",
                   help="correct the track with this module's drift calibration (`drift calibrate`); with "
                        "two captures, the left foot's module's then the right foot's (- for none)")
    add_feet_options(r, "capture")


def build_parser() -> argparse.ArgumentParser:
    """The parser of ``openshoe-host`` and its commands."""
    parser = argparse.ArgumentParser(prog="openshoe-host", description=DESCRIPTION)
    sub = parser.add_subparsers(dest="cmd", required=True)
    _add_track(sub)
    _add_log(sub)
    i = sub.add_parser("info", help="ping the module and read its MCU serial number")
    add_common(i)
    _add_replay(sub)
    d = sub.add_parser("drift", help="closed-loop drift correction of one module (hostlib.calibration.drift)")
    dsub = d.add_subparsers(dest="drift_cmd", required=True)
    dc = dsub.add_parser("calibrate", help="the module's drift velocity from closed-loop captures")
    dc.add_argument("captures", nargs="+", metavar="CAPTURE",
                    help="captures (log --raw, openshoe-emu replay --wire) of closed loops walked with the "
                         "fusion set-up, one loop each, all with one module")
    dc.add_argument("-o", "--output", required=True, metavar="CAL.json", help="calibration file to write")
    dc.add_argument("--command-set", choices=("2014", "2015"), default="2015")
    return parser


def ctrl_c_ends_the_walk() -> None:
    """Ctrl-C (SIGINT) ends a live walk even in a process started with SIGINT ignored — a script's
    background job (``openshoe-host track … &``, then ``kill -INT``), a test runner's worker — where
    Python would leave the inherited ignore as it is and the walk would run on."""
    if threading.current_thread() is threading.main_thread() and \
            signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)


def main(argv: Sequence[str] | None = None, out: TextIO | None = None) -> int:
    """Entry point of ``openshoe-host``; returns the exit status."""
    args = build_parser().parse_args(argv)
    out = sys.stdout if out is None else out
    check = {"track": usage_refusal, "replay": usage_refusal, "log": log_refusal,
             "drift": value_refusal}.get(args.cmd)
    refusal = None if check is None else check(args)
    if refusal is not None:
        print(f"openshoe-host {args.cmd}: {refusal}", file=sys.stderr)
        return 2
    if args.cmd in ("track", "log"):
        ctrl_c_ends_the_walk()
    try:
        return command(args.cmd)(args, out)
    except HostError as exc:
        print(f"openshoe-host: {exc}", file=sys.stderr)
        return 1
    except (OSError, ValueError) as exc:  # a port that would not open, or did not answer as one
        given = (getattr(args, name, None) for name in ("url", "url2", "capture", "capture2"))
        what = " and ".join(name for name in given if name) or " ".join(getattr(args, "captures", ()))
        print(f"openshoe-host: cannot use {what}: {exc}" if what else f"openshoe-host: {exc}",
              file=sys.stderr)
        return 1
