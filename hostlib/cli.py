"""``openshoe-host``: track, log and inspect an OpenShoe module (real or emulated) from a terminal.

    openshoe-host info  /dev/rfcomm0
    openshoe-host track /dev/rfcomm0 --duration 60 --csv walk.csv --png walk.png
    openshoe-host log   socket://localhost:5000 --raw capture.bin --duration 10
    openshoe-host track /dev/rfcomm0 --steps 100 --csv walk.csv      # stop after 100 step packets
    openshoe-host replay capture.bin --csv walk.csv

Two feet (a module on each; hostlib.fusion.feet): both streams acked and gap-checked on their own, fused
into one body track (the feet's midpoint); a lost link on one foot degrades the fusion to the
other foot, it never stops it::

    openshoe-host track /dev/rfcomm0 /dev/rfcomm1 --fusion --csv walk.csv      # LEFT RIGHT
    openshoe-host replay left.bin right.bin --csv walk.csv --png walk.png
    openshoe-host replay left.bin right.bin --compass --gps walk.nmea --drift left.json right.json

Per-module calibrations (--drift, --mag-cal) then take one file per foot, the left foot's first
(- for none); each is checked against the serial number of the module on its foot.

Heading aids on a live walk (the fusion set-up; hostlib.fusion.tracker): a compass update per step, and GPS
fixes from a receiver read as they come (hostlib.run.gps_stream), each put on the module's clock; with a
module on each foot, each foot's compass and the body's fixes, each fix on each module's clock::

    openshoe-host track /dev/rfcomm0 --fusion --compass --gps /dev/ttyACM0 --csv walk.csv
    openshoe-host track /dev/rfcomm0 /dev/rfcomm1 --fusion --compass --gps /dev/ttyACM0 --csv walk.csv

In-situ magnetometer calibration (hostlib.calibration.wiggle, NavShoe's): once tracking started, wiggle the
shoe in one place for about 30 s — toe down and up, the sole to either side, all round — then walk
off: the first step longer than 0.5 m ends it. It is saved for the module (hostlib.calibration.magcal; the
directory --mag-cal-dir, else $OPENSHOE_MAGCAL_DIR, else $XDG_CONFIG_HOME/openshoe/magcal), and
--compass without --mag-cal takes the saved one of the module it talks to. ``log`` records the
wiggle's stream in its capture (and saves the calibration too), for ``replay`` to fit it again::

    openshoe-host track /dev/rfcomm0 --fusion --compass --calibrate-mag --csv walk.csv
    openshoe-host track /dev/rfcomm0 --fusion --compass --csv later.csv
    openshoe-host log /dev/rfcomm0 --start --fusion --calibrate-mag --raw walk.bin
    openshoe-host replay walk.bin --compass --calibrate-mag --csv walk.csv

Closed-loop drift correction (per module; hostlib.calibration.drift): record closed loops with the fusion
set-up, calibrate from them, then correct the module's later walks::

    openshoe-host log /dev/rfcomm0 --start --fusion --raw loop1.bin --duration 120
    openshoe-host drift calibrate loop1.bin -o cal.json
    openshoe-host replay walk.bin --csv walk.csv --drift cal.json
    openshoe-host track /dev/rfcomm0 --fusion --drift cal.json --csv walk.csv

URL is anything pyserial opens: a device path (``/dev/rfcomm0``, ``/dev/ttyACM0``,
``COM5``), ``socket://host:port``, ``loop://``, or the emulator's ``openshoe://``.
"""

from __future__ import annotations

import argparse
import math
import sys
import threading
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

from protocol.board import FOOT_SIDES
from protocol.ids import OutputMode, StateId

from .calibration.drift import DriftCalibration, DriftError, calibrate, loop_closure, serial_text
from .errors import HostError
from .events import LinkEvent
from .fusion.feet import FeetSettings, TwoFeetTracker
from .link.device import Device
from .link.session import SessionStats
from .track.steps import StepTracker, Track

__all__ = ["feet_summary", "feet_summary_line", "heading_deg", "main", "summary_line"]

#: `log` to a file or pipe: one status line this often [s] (on a terminal the line is live).
LOG_LINE_EVERY_S = 5.0


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("url", help="serial device path or pyserial URL (socket://host:port, openshoe://...)")
    p.add_argument("--command-set", choices=("2014", "2015"), default="2015",
                   help="command numbering of the module's firmware (default 2015)")
    p.add_argument("--baudrate", type=int, default=115200, help="UART baud rate (ignored by URLs and USB)")
    p.add_argument("--ack-timeout", type=float, default=1.0, help="seconds to wait for each command ack")


def _setup_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--fusion", action="store_true",
                   help="after 0x34 also ask for each step's swing time and the module's serial number "
                        "(protocol.extensions.FUSION_SETUP; needed by --drift, --calibrate-mag and by drift "
                        "calibrate)")
    p.add_argument("--height-compensation", action="store_true",
                   help="turn the module's height compensation (function 0x25) on at the first step "
                        "packet (an emulator extension)")


def _aid_options(p: argparse.ArgumentParser, live: bool = False) -> None:
    """The heading aids' options; *live*: of ``track`` (one URL, a GPS device read as it talks)."""
    what = "one URL, with --fusion" if live else "the capture needs the --fusion set-up"
    g = p.add_argument_group(f"heading aids (hostlib.fusion.tracker; {what})")
    g.add_argument("--compass", action="store_true",
                   help="one compass update per step from the magnetometers and attitude at the end of "
                        "each stance")
    g.add_argument("--compass-sigma", type=float, default=None, metavar="DEG",
                   help="1σ of one compass reading (the local deviation; default 20, indoors; "
                        "outdoors about 5; with --compass-deviation only the reading's own white error, "
                        "default 1.5)")
    g.add_argument("--compass-deviation", type=_compass_deviation, default=None,
                   metavar="outdoors|indoors|SIGMA_DEG,LENGTH_M",
                   help="hold the local magnetic deviation as a state of the filter "
                        "(hostlib.fusion.deviation), "
                        "correlated over the distance walked: 'outdoors' (3° over 9 m), 'indoors' "
                        "(20° over 0.5 m) or its 1σ [deg] and correlation length [m]; with two modules "
                        "one deviation for both feet (with --compass)")
    if live:
        g.add_argument("--gps", metavar="DEVICE_OR_FILE",
                       help="a GPS receiver to fuse (NMEA GGA/RMC): a device or pyserial URL, read as it "
                            "talks, each fix put on the module's clock; or a file of its sentences (as "
                            "replay reads it). The track is then placed on the globe at the first fix and "
                            "the CSV gets lat_deg, lon_deg, alt_m")
    else:
        g.add_argument("--gps", metavar="FILE.nmea",
                       help="GPS fixes (NMEA GGA/RMC) to fuse; the track is then placed on the globe "
                            "and the CSV gets lat_deg, lon_deg, alt_m")
    g.add_argument("--gps-bias", action="store_true",
                   help="hold the receiver's correlated error as a state of the filter "
                        "(hostlib.fusion.gps_bias): "
                        "a bias wandering over minutes (3 m RMS, τ 120 s) plus 0.3 m white per fix, every "
                        "fix used (without it a fix is white noise of 15 m every 10 s); with two modules one "
                        "bias for the body's receiver (with --gps)")
    g.add_argument("--mag-cal", nargs="+", metavar="CAL.json",
                   help="the shoe's magnetometer calibration (hard/soft iron); with two captures or URLs, "
                        "the left foot's then the right foot's (- for none). Without it, --compass takes the "
                        "module's saved calibration, if there is one (--mag-cal-dir)")
    g.add_argument("--module-errors", type=_module_errors, default=None,
                   metavar="SCALE,CLIMB[,TURN[,DRIFT_DEG_PER_H[,WARMUP_DEG_PER_S[,TAU_S]]]]",
                   help="hold the module's step-length scale, climb per metre, turn scale, heading drift "
                        "rate and the gyros' warm-up as states of the filter "
                        "(hostlib.fusion.module_errors), with "
                        "these 1σ priors (e.g. 0.001,0.0017,0.01,20,0.05,120: 0.1 %% per metre, 1.7 mm/m, "
                        "1 %% of the angle turned, 20 °/h, and a vertical rate bias settling 0.05 °/s away "
                        "with a warm-up time constant of 120 s, counted from the first step; a drift or "
                        "warm-up of 0 or none: not held), or 'emulated' (also 'emulated-sway') for the "
                        "emulated module's on a real foot's swaying stance (openshoe-emu's default; its "
                        "warm-up from the sensors' physics), or 'emulated-still' for the emulated module "
                        "on still stances (openshoe-emu --no-stance-sway): the covariance "
                        "then grows with the distance, the angle turned and the time walked, as a module's "
                        "systematic errors do; with two modules each foot's module holds its own")
    where = "once tracking started" if live else "the capture's"
    g.add_argument("--calibrate-mag", action="store_true",
                   help=f"calibrate the magnetometers in situ (with --compass, one module): {where} wiggle "
                        "of the shoe in one place, ended by the first step longer than 0.5 m; the compass "
                        "waits for it, and the calibration is saved for the module (--mag-cal-dir)"
                        + ("; the module streams its magnetometers meanwhile" if live else
                           " (a capture of the stream: log --calibrate-mag, or openshoe-emu replay --host "
                           "fusion --calibrate-mag)"))
    _mag_cal_dir_option(g)
    g.add_argument("--declination", type=float, default=None, metavar="DEG",
                   help="magnetic declination, east positive (default: the World Magnetic Model at the "
                        "first fix or at --origin)")


def _mag_cal_dir_option(g: Any) -> None:
    """``--mag-cal-dir`` in the argument group *g*."""
    g.add_argument("--mag-cal-dir", metavar="DIR", default=None,
                   help="where each module's magnetometer calibration is kept, as <serial>.json (default: "
                        "$OPENSHOE_MAGCAL_DIR, else $XDG_CONFIG_HOME/openshoe/magcal, else "
                        "~/.config/openshoe/magcal)")


def _log_calibration_options(p: argparse.ArgumentParser) -> None:
    """``log --calibrate-mag``: record the wiggle's stream, and fit and save it as ``track`` does."""
    g = p.add_argument_group("in-situ magnetometer calibration (hostlib.calibration.wiggle; with --fusion)")
    g.add_argument("--calibrate-mag", action="store_true",
                   help="after the fusion set-up the module streams its magnetometers and attitude while "
                        "the shoe is wiggled in one place, until the first step longer than 0.5 m: the "
                        "capture holds the stream (replay --compass --calibrate-mag fits it again), and the "
                        "calibration is fitted and saved for the module (--mag-cal-dir) as track does")
    _mag_cal_dir_option(g)


def _positive_metres(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not value > 0 or not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"a distance > 0 m, not {text!r}")
    return value


def _step_count(text: str) -> int:
    """The argparse type of ``--steps``: a whole number ≥ 1."""
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"a whole number of step packets ≥ 1, not {text!r}")
    return value


def _enough_steps(steps: int | None, setups: Iterable[_HostSetup]) -> bool:
    """Whether every device of *setups* has had ``--steps`` step packets and has nothing of its
    set-up left to send (never without ``--steps``)."""
    return steps is not None and all(s.dev.session.stats.steps >= steps and s.sent for s in setups)


def _feet_options(p: argparse.ArgumentParser, what: str) -> None:
    g = p.add_argument_group(f"two feet (with two {what}s: the left foot's, then the right foot's; "
                             "hostlib.fusion.feet)")
    g.add_argument("--max-separation", type=_positive_metres, default=None, metavar="M",
                   help="γ: the feet's last rests are never farther apart than M metres (default "
                        f"{FeetSettings.max_separation_m:g}, the longest walking step; a runner's: 1.5); a "
                        "step longer than 2γ is fused without it (the other foot moved meanwhile)")
    g.add_argument("--no-constraint", action="store_true",
                   help="no inter-foot constraint: the body is the average of the two single-module tracks")


def _feet_settings(args: argparse.Namespace) -> FeetSettings:
    gamma = FeetSettings.max_separation_m if args.max_separation is None else args.max_separation
    return FeetSettings(constraint=not args.no_constraint, max_separation_m=gamma)


#: Options for two feet only: (dest, flag).
_FEET_OPTIONS = (("max_separation", "--max-separation"), ("no_constraint", "--no-constraint"))
#: Options that name one calibration file per module: (dest, flag).
_PER_MODULE_FILES = (("drift", "--drift"), ("mag_cal", "--mag-cal"))
#: Stands for "no calibration for this foot" in a per-module list.
NO_FILE = "-"


def _second(args: argparse.Namespace) -> str | None:
    """The right foot's URL or capture (None: one module)."""
    return getattr(args, "url2", None) or getattr(args, "capture2", None)


def _track_aid_refusal(args: argparse.Namespace) -> str | None:
    """Why the aid options of ``track`` do not go together, or None."""
    for flag, why in (("compass", "the compass needs the magnetometers and the attitude at the end of each "
                                  "stance"),
                      ("gps", "a fix is put on the module's clock, which only the step packets' time "
                              "(T_INT_K) gives")):
        if getattr(args, flag) and not args.fusion:
            return f"--{flag} needs --fusion: {why}, which the fusion set-up asks the module for"
    return None


def _usage_refusal(args: argparse.Namespace) -> str | None:
    """Why the options of ``track`` or ``replay`` do not go together, or None."""
    what = "URL" if args.cmd == "track" else "capture"
    two = _second(args) is not None
    if args.cmd == "track" and (refusal := _track_aid_refusal(args)) is not None:
        return refusal
    given = [flag for dest, flag in _FEET_OPTIONS if getattr(args, dest, None) not in (None, False)]
    if given and not two:
        verb = "need" if len(given) > 1 else "needs"
        return f"{', '.join(given)} {verb} two {what}s (the left foot's, then the right foot's)"
    for dest, flag in _PER_MODULE_FILES:
        files = getattr(args, dest, None)
        if files is None:
            continue
        if two and len(files) != 2:
            return (f"{flag} takes one file per module with two {what}s: the left foot's, then the right "
                    f"foot's ({NO_FILE} for none), not {len(files)}")
        if not two and (len(files) != 1 or files[0] == NO_FILE):
            return f"{flag} takes one file with one {what}"
    if args.cmd == "track" and args.drift and not args.fusion:
        return ("--drift needs --fusion: the drift correction needs every step's swing time and the "
                "module's serial number, which the fusion set-up asks the module for")
    if args.compass_deviation is not None and not args.compass:
        return ("--compass-deviation needs --compass: it is the local deviation of the compass's "
                "readings")
    if args.gps_bias and not args.gps:
        return "--gps-bias needs --gps: it is the error of the receiver's fixes"
    return _calibration_refusal(args, two)


def _calibration_refusal(args: argparse.Namespace, two: bool) -> str | None:
    """Why ``--calibrate-mag`` does not go with the other options, or None."""
    if not args.calibrate_mag:
        return None
    if two:
        what = "URL" if args.cmd == "track" else "capture"
        return (f"--calibrate-mag calibrates one module: the wiggle turns one shoe in one place, standing on "
                f"the other, and the first step ends it; calibrate each foot's module on its own (one "
                f"{what}, --compass --calibrate-mag), then --compass with two {what}s takes each module's "
                f"saved calibration")
    if not args.compass:
        return ("--calibrate-mag needs --compass: the calibration removes the shoe's iron from the compass's "
                "readings, and the compass waits for it")
    if args.mag_cal:
        return ("--calibrate-mag fits a new calibration: give it or --mag-cal CAL.json (an earlier one), "
                "not both")
    return None


def _log_refusal(args: argparse.Namespace) -> str | None:
    """Why the options of ``log`` do not go together, or None (as ``track``: the calibration needs the
    fusion set-up; without --start the module is taken to track already, as with ``track --attach``)."""
    if args.calibrate_mag and not args.fusion:
        return ("--calibrate-mag needs --fusion: the calibration is saved for the module under the serial "
                "number the fusion set-up asks it for, and a replay of the capture with --compass takes "
                "the magnetometers and the attitude at the end of each stance from that set-up's steps")
    return None


def _uses_aids(args: argparse.Namespace) -> bool:
    return bool(args.compass or args.gps or args.module_errors is not None)


def _module_errors(text: str):
    """The argparse type of ``--module-errors``: 'emulated' or 'emulated-sway' (the emulated module
    as it walks by default, on swaying stances), 'emulated-still' (on still stances) or
    SCALE,CLIMB[,TURN[,DRIFT_DEG_PER_H[,WARMUP_DEG_PER_S[,TAU_S]]]] (numbers ≥ 0, τ > 0; the heading
    drift rate's 1σ in °/h and the warm-up's in °/s, held as [rad/s])."""
    from .fusion.module_errors import EMULATED_MODULE, EMULATED_MODULE_SWAYING, ModuleErrors

    presets = {"emulated": EMULATED_MODULE_SWAYING, "emulated-sway": EMULATED_MODULE_SWAYING,
               "emulated-still": EMULATED_MODULE}
    word = text.strip().lower()
    if word in presets:
        return presets[word]
    try:
        sigmas = [float(v) for v in text.split(",")]
        if not 2 <= len(sigmas) <= 6:
            raise ValueError(f"{len(sigmas)} numbers")
        if len(sigmas) >= 4:
            sigmas[3] = math.radians(sigmas[3]) / 3600.0  # °/h → rad/s
        if len(sigmas) >= 5:
            sigmas[4] = math.radians(sigmas[4])  # °/s → rad/s
        return ModuleErrors(*sigmas)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected SCALE,CLIMB[,TURN[,DRIFT_DEG_PER_H[,WARMUP_DEG_PER_S[,TAU_S]]]] (1σ, numbers ≥ 0, "
            f"τ > 0, e.g. 0.001,0.0017,0.01,20,0.05,120), 'emulated', 'emulated-sway' or 'emulated-still', "
            f"got {text!r}") from None


def _compass_deviation(text: str):
    """The argparse type of ``--compass-deviation``: 'outdoors', 'indoors' or SIGMA_DEG,LENGTH_M
    (numbers > 0)."""
    from .fusion.deviation import INDOORS, OUTDOORS, CompassDeviation

    presets = {"outdoors": OUTDOORS, "indoors": INDOORS}
    word = text.strip().lower()
    if word in presets:
        return presets[word]
    try:
        values = [float(v) for v in text.split(",")]
        if len(values) != 2:
            raise ValueError(f"{len(values)} numbers")
        return CompassDeviation(math.radians(values[0]), values[1])
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected 'outdoors', 'indoors' or SIGMA_DEG,LENGTH_M (numbers "
                                         f"> 0, e.g. 3,50), got {text!r}") from None


def _fusion_settings(args: argparse.Namespace):
    """The aids' settings the options change (``--compass-sigma``, ``--compass-deviation``: σ_c is
    then only the white part, 1.5° unless given; ``--gps-bias``: the receiver's defaults); the rest
    as hostlib.run.aid_setup sets them."""
    from .fusion.deviation import WHITE_SIGMA_RAD
    from .fusion.gps_bias import GpsBias
    from .fusion.tracker import FusionSettings

    deviation = args.compass_deviation
    bias = GpsBias() if args.gps_bias else None
    if args.compass_sigma is None and deviation is None:
        return FusionSettings(module_errors=args.module_errors, gps_bias=bias)
    sigma = WHITE_SIGMA_RAD if args.compass_sigma is None else math.radians(args.compass_sigma)
    return FusionSettings(compass_sigma_rad=sigma, module_errors=args.module_errors,
                          compass_deviation=deviation, gps_bias=bias)


def _prepare_aids(args: argparse.Namespace, origin: tuple[float, float, float] | None, *,
                  saved: tuple[Any, Path] | None = None, **more: Any):
    """The fusion tracker the aid options ask for (hostlib.run.aid_setup; *more*: to :func:`prepare_aids`),
    with the calibration of --mag-cal, else the module's *saved* one (calibration, file)."""
    from .calibration.magcal import MagCalibration
    from .run.aid_setup import prepare_aids

    cal = MagCalibration.load(args.mag_cal[0]) if args.mag_cal else saved[0] if saved else None
    gps_path = None if more.get("live_gps") else args.gps
    aids = prepare_aids(compass=args.compass, gps_path=gps_path, mag_calibration=cal,
                        declination=args.declination, origin=origin, settings=_fusion_settings(args), **more)
    if saved is not None and not args.mag_cal:
        aids.calibration_source = f"saved {saved[1]}"
    return aids


def _wants_saved_calibration(args: argparse.Namespace) -> bool:
    """Whether the compass takes the module's saved magnetometer calibration: ``--compass`` without
    --mag-cal and --calibrate-mag."""
    return bool(args.compass and not (args.mag_cal or args.calibrate_mag))


def _saved_calibration(args: argparse.Namespace, serial: bytes | None) -> tuple[Any, Path] | None:
    """The saved magnetometer calibration (calibration, file) of the module whose serial number is
    *serial*, when the options want one (:func:`_wants_saved_calibration`); else None."""
    from .calibration.magcal import load_for_module

    if not _wants_saved_calibration(args) or not serial:
        return None
    return load_for_module(serial_text(serial), args.mag_cal_dir)


def _per_foot(files: Sequence[str] | None, load: Callable[[str], Any]) -> dict[str, Any]:
    """Side → the calibration loaded from each foot's file of a per-module option (none: -)."""
    return {side: load(path) for side, path in zip(FOOT_SIDES, files or (), strict=False) if path != NO_FILE}


def _feet_tracker(args: argparse.Namespace, origin: tuple[float, float, float] | None, *,
                  last_counter: int | None, defer: bool, heading: float = 0.0, **more: Any):
    """The two-feet tracker the options ask for, with each module's drift calibration, and — with
    --compass, --gps or --module-errors — the aids (hostlib.run.aid_setup; None otherwise; *more*: to
    :func:`~hostlib.run.aid_setup.prepare_feet_aids`, e.g. a receiver read live)."""
    from .calibration.magcal import MagCalibration
    from .run.aid_setup import prepare_feet_aids

    drift = _per_foot(args.drift, DriftCalibration.load)
    if not _uses_aids(args):
        return TwoFeetTracker(_feet_settings(args), last_counter=last_counter, defer=defer, heading=heading,
                              drift=drift), None
    aids = prepare_feet_aids(compass=args.compass, gps_path=None if more.get("live_gps") else args.gps,
                             mag_calibrations=_per_foot(args.mag_cal, MagCalibration.load),
                             declination=args.declination, origin=origin, settings=_fusion_settings(args),
                             feet=_feet_settings(args), drift=drift, last_counter=last_counter, defer=defer,
                             heading=heading, **more)
    return aids.tracker, aids


def _check_mag_module(cal: Any, serial: bytes | None) -> None:
    """Refuse a magnetometer calibration (hostlib.calibration.magcal) fitted on another module than the one
    whose MCU serial number is *serial* (None: unknown, accepted)."""
    cal.check_module(serial_text(serial) if serial else "")


def _check_feet_modules(tracker: TwoFeetTracker, serials: Mapping[str, bytes | None], files: Mapping[str, str]
                        ) -> None:
    """Refuse a foot's drift or magnetometer calibration made with another module than the one on
    that foot (*serials*: side → the module's serial number, None unknown; *files*: side → where
    its stream came from); a pair given in the wrong order is named as swapped."""
    checks: list[tuple[str, str, Callable[[bytes | None], None]]] = []
    for side in FOOT_SIDES:
        drift = tracker.drift.get(side)
        if drift is not None:
            checks.append((side, "drift", drift.check_module))
        cal = tracker.foot(side).settings.mag_calibration
        if cal is not None:
            checks.append((side, "magnetometer", lambda serial, cal=cal: _check_mag_module(cal, serial)))
    for side, what, check in checks:
        try:
            check(serials[side])
        except HostError as exc:
            other = FOOT_SIDES[1 - FOOT_SIDES.index(side)]
            try:
                check(serials[other])
                hint = f"; it fits the {other} foot's module: give the left foot's calibration first"
            except HostError:
                hint = ""
            raise type(exc)(f"the {side} foot ({files[side]}): {what} calibration: {exc}{hint}") from None


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="openshoe-host", description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="cmd", required=True)

    t = sub.add_parser("track", help="start step-wise dead reckoning (0x34) and sum the steps "
                                     "(of one module, or of a module on each foot)")
    _common(t)
    t.add_argument("url2", nargs="?", metavar="URL2",
                   help="a module on the other foot: url is then the left foot's, URL2 the right foot's, "
                        "and the two are fused (hostlib.fusion.feet)")
    t.add_argument("--duration", type=float, default=None, help="seconds to track (default: until Ctrl-C)")
    t.add_argument("--steps", type=_step_count, default=None, metavar="N",
                   help="stop once N step packets came (from each module, with two); with --duration, "
                        "whichever comes first")
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
    _setup_options(t)
    _aid_options(t, live=True)
    t.add_argument("--drift", nargs="+", metavar="CAL.json",
                   help="correct the track with this module's drift calibration (needs --fusion); with two "
                        "URLs, the left foot's module's then the right foot's (- for none)")
    _feet_options(t, "URL")

    lg = sub.add_parser("log", help="capture the module's byte stream to a file (packets still acked)")
    _common(lg)
    lg.add_argument("--raw", required=True, help="file to write every received byte to")
    lg.add_argument("--duration", type=float, default=None, help="seconds to capture (default: until Ctrl-C)")
    lg.add_argument("--steps", type=_step_count, default=None, metavar="N",
                    help="stop once N step packets came; with --duration, whichever comes first")
    lg.add_argument("--start", action="store_true", help="send 0x34 (step-wise dead reckoning) first")
    _setup_options(lg)
    _log_calibration_options(lg)

    i = sub.add_parser("info", help="ping the module and read its MCU serial number")
    _common(i)

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
    _aid_options(r)
    r.add_argument("--drift", nargs="+", metavar="CAL.json",
                   help="correct the track with this module's drift calibration (`drift calibrate`); with "
                        "two captures, the left foot's module's then the right foot's (- for none)")
    _feet_options(r, "capture")

    d = sub.add_parser("drift", help="closed-loop drift correction of one module (hostlib.calibration.drift)")
    dsub = d.add_subparsers(dest="drift_cmd", required=True)
    dc = dsub.add_parser("calibrate", help="the module's drift velocity from closed-loop captures")
    dc.add_argument("captures", nargs="+", metavar="CAPTURE",
                    help="captures (log --raw, openshoe-emu replay --wire) of closed loops walked with the "
                         "fusion set-up, one loop each, all with one module")
    dc.add_argument("-o", "--output", required=True, metavar="CAL.json", help="calibration file to write")
    dc.add_argument("--command-set", choices=("2014", "2015"), default="2015")
    return parser


def heading_deg(chi: float) -> float:
    """A heading [rad] as shown: degrees in [0, 360), rounded to 0.1° first so that −0.0 and
    359.96° both read 0.0, never 360.0."""
    return (round(math.degrees(chi), 1) % 360.0) + 0.0


def summary_line(dev: Device, drift: DriftCalibration | None = None) -> str:
    """One line: step packets, steps with motion, distance, position, heading, 1σ, gaps.

    The module sends a step packet at every INS reset, also while the wearer stands
    still; "steps" counts only those that moved the foot (hostlib.track.steps.is_motion_step).
    With *drift* the position is the drift-corrected one (refused for another module, or a
    step without a swing time: :class:`~hostlib.calibration.drift.DriftError`).
    """
    tr = dev.track_snapshot()
    x, y, z, chi = tr.final_pose
    corrected = ""
    if drift is not None and len(tr):
        drift.check_module(dev.session.mcu_serial)
        x, y, z = tr.final_pose[:3] + drift.offsets(tr)[-1]
        corrected = " (drift-corrected)"
    st = dev.stats
    return (
        f"packets {len(tr):5d} | steps {tr.motion_steps:5d} | {tr.distance:8.2f} m "
        f"| {_pose_text((x, y, z, chi), tr.closure_sigma(), corrected)} "
        f"| gaps {len(tr.gaps)} (missing {tr.missing}) | garbage {st['garbage_bytes']}"
    )


def _pose_text(pose: Sequence[float], sigma: float, note: str = "") -> str:
    """Position, heading and horizontal 1σ as the status lines show them."""
    x, y, z, chi = pose
    return (f"x {x:+8.2f} y {y:+8.2f} z {z:+6.2f} m{note} | heading {heading_deg(chi):5.1f}° "
            f"| 1σ {sigma:6.3f} m")


def feet_summary_line(tracker: TwoFeetTracker, devices: Mapping[str, Device],
                      failed: Sequence[str] = ()) -> str:
    """One line for two feet: per foot its step packets, steps with motion, distance and gaps (and
    whether its link is down, or its walk failed: the *failed* sides), then the fused body."""
    parts = []
    for side, dev in devices.items():
        tr = dev.track_snapshot()
        state = " FAILED" if side in failed else ("" if dev.link_up else " LINK DOWN")
        parts.append(f"{side} {len(tr):4d}/{tr.motion_steps:4d} steps {tr.distance:7.2f} m "
                     f"gaps {len(tr.gaps)} (missing {tr.missing}){state}")
    body = tracker.body
    return " | ".join(parts) + f" | body {_pose_text(body.final_pose, body.closure_sigma())}"


def _is_terminal(out: TextIO) -> bool:
    return bool(getattr(out, "isatty", lambda: False)())


class _LiveLine:
    """A status line kept up to date with ``\\r`` on a terminal; elsewhere (a log file, a pipe)
    one line each time *key* changes (a new step), or every *every_s* seconds."""

    def __init__(self, out: TextIO, every_s: float | None = None):
        self.out = out
        self.tty = _is_terminal(out)
        self.every_s = every_s
        self._key: object = None
        self._next = time.monotonic() + (every_s or 0.0)

    def show(self, text: str, key: object = None) -> None:
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
        if self.tty:
            self.out.write("\n")


def _open(args: argparse.Namespace, url: str, **kw: Any) -> Device:
    return Device(url, command_set=args.command_set, baudrate=args.baudrate,
                  ack_timeout=args.ack_timeout, **kw)


def _deadline(duration: float | None) -> float | None:
    return None if duration is None else time.monotonic() + duration


def _remaining(deadline: float | None, cap: float = 0.5) -> float:
    return cap if deadline is None else max(0.0, min(cap, deadline - time.monotonic()))


class _HostSetup:
    """What the host sends besides 0x34, each command once the one before was acked: the fusion
    set-up right after 0x34 (``--fusion``), height compensation at the first step packet
    (``--height-compensation``)."""

    def __init__(self, dev: Device, fusion: bool, height_compensation: bool):
        self.dev = dev
        self.fusion = fusion
        self.height_compensation_pending = height_compensation
        #: the in-situ magnetometer calibration (``--calibrate-mag``), started after the fusion set-up
        self.in_situ: _InSitu | None = None

    def after_start(self) -> None:
        """Right after 0x34 (or, attaching, at once)."""
        if self.fusion:
            self.dev.fusion_setup()
        if self.in_situ is not None:
            self.in_situ.start()

    @property
    def sent(self) -> bool:
        """Whether every command of the set-up went out (height compensation waits for a step)."""
        return not self.height_compensation_pending

    def poll(self) -> None:
        """Between reads: turn height compensation on once the first step packet came; stop the
        in-situ calibration's stream once it ended."""
        if self.height_compensation_pending and self.dev.session.stats.steps > 0:
            self.height_compensation_pending = False
            self.dev.height_compensation_on()
        if self.in_situ is not None:
            self.in_situ.poll()


class _InSitu:
    """``track --calibrate-mag`` and ``log --calibrate-mag``: the in-situ magnetometer calibration
    of one module (hostlib.calibration.wiggle). The device's reader thread hands it the session's packets and
    steps, in their order; when the first long step ends it, the fit goes at once to the tracker of
    *aids* (``track``: its compass waits for it; ``log`` has none, its capture holds the stream); the
    main loop then stops the stream, saves the calibration for the module and says what it did
    (*cmd*: whose messages they are)."""

    def __init__(self, dev: Device, directory: str | None, cmd: str, aids: Any = None):
        from .calibration.wiggle import WiggleCalibration

        self.dev, self.directory, self.cmd, self.aids = dev, directory, cmd, aids
        self.wiggle = WiggleCalibration()
        self.reported = False
        #: held while the reader thread hands a step over, so that the main loop sees the wiggle's
        #: end only once its fit is done
        self._lock = threading.Lock()
        if aids is not None:
            aids.tracker.hold_compass()
        dev.on_packet(lambda ev: self.wiggle.add_packet(ev.states))
        dev.on_step(self._step)

    def start(self) -> None:
        """Start the magnetometer stream (after the fusion set-up) and tell the wearer what to do."""
        for meaning, fields in self.wiggle.START:
            self.dev.command(meaning, **fields)
        print("calibrating the magnetometers: wiggle the shoe in one place for about 30 s — toe down and "
              f"up, the sole to either side, all round — then walk off (a step longer than "
              f"{self.wiggle.stop_step_m:g} m ends it)", file=sys.stderr)

    def _step(self, ev: Any) -> None:
        serial = self.dev.session.mcu_serial
        with self._lock:
            ended = self.wiggle.add_step(ev.step.dx, serial_text(serial) if serial else "")
            if ended and self.aids is not None:
                with self.dev.session_lock:
                    self.wiggle.release(self.aids.tracker)

    def _ended(self) -> bool:
        """Whether the wiggle ended (fitted or refused; a fit under way is waited for)."""
        with self._lock:
            return self.wiggle.done

    def poll(self) -> None:
        """Once the calibration ended: stop the stream, save, say so (once)."""
        if not self.reported and self._ended():
            self._stop_stream()
            self._report()

    def close(self, leave_running: bool) -> None:
        """The walk or capture ended (the module's outputs off unless *leave_running*): a calibration
        that ended in the last moments is saved and reported; one that did not end says so. The
        stream is stopped if the outputs stay on."""
        if self.reported:
            return
        if leave_running:
            self._stop_stream()
        if self._ended():
            self._report()
        elif self.aids is not None:
            self.aids.calibration_source = "the wiggle did not end"
        else:
            print(f"openshoe-host {self.cmd}: {self.wiggle.summary()}; nothing saved", file=sys.stderr)

    def _stop_stream(self) -> None:
        for meaning, fields in self.wiggle.STOP:
            self.dev.command(meaning, **fields)

    def _report(self) -> None:
        self.reported = True
        source = _keep_in_situ(self.wiggle, self.directory, self.cmd)
        print(f"openshoe-host {self.cmd}: {self.wiggle.summary()}", file=sys.stderr)
        if self.aids is not None:
            self.aids.calibration_source = source
        elif self.wiggle.calibration is not None:
            print(f"openshoe-host {self.cmd}: magnetometer calibration: {source}", file=sys.stderr)


def _keep_in_situ(wiggle: Any, directory: str | None, cmd: str) -> str:
    """Save an in-situ calibration for its module (hostlib.calibration.magcal.save_for_module); returns where
    the tracker's calibration came from, for the summary."""
    from .calibration.magcal import MagCalibrationError, save_for_module

    if wiggle.calibration is None:
        return "the in-situ calibration was refused"
    try:
        path = save_for_module(wiggle.calibration, directory)
    except (MagCalibrationError, OSError) as exc:
        print(f"openshoe-host {cmd}: the magnetometer calibration was not saved: {exc}", file=sys.stderr)
        return "in situ, not saved"
    return f"in situ, saved {path}"


def _await_serial(dev: Device, timeout: float) -> None:
    """Wait up to *timeout* s for the packet with the module's serial number (the fusion set-up's
    MCU_ID), reading packets meanwhile."""
    deadline = time.monotonic() + timeout
    while dev.session.mcu_serial is None and time.monotonic() < deadline:
        dev.recv_packet(timeout=_remaining(deadline))


@dataclass
class _Tracked:
    """One module being tracked: which foot it is on (None: the only module), its device and host
    set-up, and the error that ended its walk (None while it goes on)."""

    side: str | None
    dev: Device
    setup: _HostSetup
    failure: HostError | None = None

    @property
    def label(self) -> str:
        return self.dev.name if self.side is None else f"the {self.side} foot ({self.dev.name})"

    def report_link(self, ev: LinkEvent) -> None:
        """A foot's link went down or came back (the device reconnects by itself): say so."""
        what = "link back" if ev.up else f"link lost ({ev.error}); the other foot goes on"
        print(f"openshoe-host track: {self.label}: {what}", file=sys.stderr)


def _start_tracking(args: argparse.Namespace, stack: ExitStack,
                    trackers: Mapping[str | None, tuple[str, StepTracker]],
                    opened: Callable[[list[_Tracked]], None] | None = None) -> list[_Tracked]:
    """Open a device per module (side → (URL, tracker)), then start each: 0x34 unless attaching,
    and the set-up the options ask for. *opened* sees the devices before any is started."""
    modules = [_Tracked(side, dev, _HostSetup(dev, args.fusion, args.height_compensation))
               for side, (url, tracker) in trackers.items()
               for dev in [stack.enter_context(_open(args, url, tracker=tracker))]]
    if opened is not None:
        opened(modules)
    for m in modules:
        if m.side is not None:
            m.dev.on_link(m.report_link)
        if not args.attach:
            m.dev.start_stepwise_dead_reckoning()
        m.setup.after_start()
    names = " and ".join(m.label for m in modules)
    print(f"tracking on {names} ({args.command_set} commands); Ctrl-C to stop", file=sys.stderr)
    return modules


def _follow(args: argparse.Namespace, modules: list[_Tracked], live: _LiveLine,
            status: Callable[[], tuple[str, object]], first: Callable[[], None] | None = None) -> None:
    """Read the modules' steps until ``--duration`` is over, ``--steps`` came or Ctrl-C, keeping *live*
    up to date with *status()* (its text and the key that changes with a new step). *first* runs
    before, under the same rules. A module whose walk fails is reported and left while another goes
    on; the failure of the last one is raised. At the end the outputs go off unless
    ``--leave-running``."""
    deadline = _deadline(args.duration)
    try:
        if first is not None:
            first()
        live.show(*status())
        while deadline is None or time.monotonic() < deadline:
            going = [m for m in modules if m.failure is None]
            for m in going:
                try:
                    m.dev.recv_step(timeout=_remaining(deadline, 0.5 / len(going)))
                    m.setup.poll()
                except HostError as exc:
                    m.failure = exc
                    if all(other.failure is not None for other in modules):
                        raise
                    print(f"openshoe-host track: {m.label}: {exc}; tracking goes on without it",
                          file=sys.stderr)
            live.show(*status())
            if _enough_steps(args.steps, (m.setup for m in modules if m.failure is None)):
                break
    except KeyboardInterrupt:
        pass
    finally:
        if not args.leave_running:
            for m in modules:
                try:
                    m.dev.output_all_off()
                except HostError as exc:
                    print(f"warning: could not switch the outputs of {m.label} off: {exc}", file=sys.stderr)
    # the last line counts every step, also those that came while the outputs went off
    live.show(*status())
    live.close()


def cmd_track(args: argparse.Namespace, out: TextIO) -> int:
    from .aids.geodesy import parse_origin

    drift = DriftCalibration.load(args.drift[0]) if args.drift and args.url2 is None else None
    origin = parse_origin(args.origin) if args.origin else None  # refused before the port opens
    last_counter = None if args.attach else 0
    heading = math.radians(args.heading)
    if args.url2 is not None:
        return _track_feet(args, origin, last_counter, heading, out)
    with ExitStack() as stack:
        live = _open_live_gps(args, stack) if _reads_live_gps(args) else None
        aids = _track_aids(args, origin, live, heading=heading, last_counter=last_counter)
        tracker = StepTracker(heading=heading, last_counter=last_counter) if aids is None else aids.tracker
        saved = aids is not None and _wants_saved_calibration(args)

        def opened(modules: list[_Tracked]) -> None:
            if live is not None:
                _feed_live_gps(live, aids.tracker, modules)
            if args.calibrate_mag:
                modules[0].setup.in_situ = _InSitu(modules[0].dev, args.mag_cal_dir, "track", aids)
            elif saved:
                _use_saved_calibration(modules, aids, args)

        (module,) = _start_tracking(args, stack, {None: (args.url, tracker)}, opened)
        dev = module.dev
        cal = None if aids is None else aids.tracker.settings.mag_calibration
        first = None if drift is None and cal is None else \
            lambda: _check_calibrations(dev, drift, cal, args.ack_timeout)
        try:
            _follow(args, [module], _LiveLine(out), lambda: _track_status(dev, drift, aids, live), first)
        finally:
            if module.setup.in_situ is not None:
                module.setup.in_situ.close(args.leave_running)
        track = dev.track_snapshot()
        if aids is not None:
            origin = _aids_summary(aids, live, out) or origin
        if module.setup.in_situ is not None:
            print(module.setup.in_situ.wiggle.summary(), file=out)
        if drift is not None:
            corrected = drift.apply(track, module_serial=dev.session.mcu_serial)
            moved = corrected.final_pose[:3] - track.final_pose[:3]
            print(f"drift correction ({drift}): the end moved by "
                  f"[{', '.join(f'{v:+.3f}' for v in moved)}] m", file=out)
            track = corrected
        _write_outputs(args, track, origin, geographic_csv=bool(args.gps) and origin is not None)
        print(repr(track), file=out)
    return 0


def _track_feet(args: argparse.Namespace, origin: tuple[float, float, float] | None, last_counter: int | None,
                heading: float, out: TextIO) -> int:
    """``track LEFT RIGHT``: a device per foot, both feet's steps fused in arrival order
    (hostlib.fusion.feet); with the aids, each foot's compass and a receiver read live (its fixes the
    body's, on each module's clock: hostlib.run.gps_stream), each foot's calibrations checked against
    the module on that foot once both named themselves."""
    with ExitStack() as stack:
        live = _open_live_gps(args, stack) if _reads_live_gps(args) else None
        feet, aids = _feet_tracker(args, origin, last_counter=last_counter, defer=False, heading=heading,
                                   **_live_gps_start(live))

        def opened(modules: list[_Tracked]) -> None:
            if live is not None:
                _feed_live_gps(live, feet, modules)
            if aids is not None and _wants_saved_calibration(args):
                _use_saved_calibration(modules, aids, args)

        urls = dict(zip(FOOT_SIDES, (args.url, args.url2), strict=True))
        modules = _start_tracking(args, stack, {side: (urls[side], feet.foot(side)) for side in FOOT_SIDES},
                                  opened)
        calibrated = feet.drift or any(feet.foot(side).settings.mag_calibration is not None
                                       for side in FOOT_SIDES)
        first = None if not calibrated else lambda: _check_feet_calibrations(feet, modules, args.ack_timeout)
        _follow(args, modules, _LiveLine(out), lambda: _feet_status(feet, modules, aids, live), first)
        streams = {m.side: (m.dev.name, m.dev.session.stats) for m in modules}
        if aids is not None:
            origin = _aids_summary(aids, live, out) or origin  # with GPS, the first fix: on the globe
    _finish_feet(args, feet, streams, origin, out)
    return 0


#: How long ``track --gps DEVICE`` waits for the receiver's first fix before the walk starts [s]:
#: the first fix places the walk on the globe (and gives the declination there).
FIRST_FIX_WAIT_S = 10.0


def _reads_live_gps(args: argparse.Namespace) -> bool:
    """Whether ``--gps`` names a receiver to read as it talks (a device or URL), not a file."""
    return bool(args.gps) and not Path(args.gps).is_file()


def _open_live_gps(args: argparse.Namespace, stack: ExitStack):
    """The GPS receiver at ``--gps`` (a device or URL), read in its own thread (hostlib.run.gps_stream)."""
    from .run.gps_stream import GpsStream, LiveFixes

    def report(text: str) -> None:
        print(f"openshoe-host track: {text}", file=sys.stderr)

    try:
        return stack.enter_context(GpsStream(args.gps, LiveFixes(), report=report))
    except (OSError, ValueError) as exc:  # pyserial's SerialException is an OSError
        raise HostError(f"cannot open the GPS receiver {args.gps}: {exc}") from None


def _feed_live_gps(live, tracker: Any, modules: list[_Tracked]) -> None:
    """Queue the receiver's fixes on *tracker* (the module's, or the two feet's) between two steps:
    under the session lock of every module whose steps it sums, taken in the modules' order; each
    module's step renews that module's clock (hostlib.run.gps_stream)."""
    live.fixes.attach(tracker, *(m.dev.session_lock for m in modules))
    for m in modules:
        m.dev.on_step(lambda _ev, side=m.side: live.fixes.stepped(module=side))


def _live_gps_start(live) -> dict[str, Any]:
    """What a receiver read live gives the aids before the walk (to hostlib.run.aid_setup): its first fix,
    waited for up to :data:`FIRST_FIX_WAIT_S`, places the walk. Nothing without a receiver."""
    if live is None:
        return {}
    print(f"waiting up to {FIRST_FIX_WAIT_S:g} s for the first fix of the GPS receiver {live.url}",
          file=sys.stderr)
    first = live.wait_first_fix(FIRST_FIX_WAIT_S)
    if first is None and live.lost is None:
        print("no GPS fix yet: the declination is taken without it (--declination, or the World Magnetic "
              "Model at --origin); the fixes still to come are fused", file=sys.stderr)
    when = None if first is None else first.date or live.fixes.reader.date
    return {"live_gps": True, "first_fix": first, "when": when}


def _track_aids(args: argparse.Namespace, origin: tuple[float, float, float] | None, live, **more: Any):
    """The aids of ``track`` (hostlib.run.aid_setup; None without --compass or --gps). With a receiver read
    live, its first fix (waited for up to :data:`FIRST_FIX_WAIT_S`) places the walk."""
    if not _uses_aids(args):
        return None
    return _prepare_aids(args, origin, **_live_gps_start(live), **more)


def _track_status(dev: Device, drift: DriftCalibration | None, aids, live) -> tuple[str, object]:
    """The live line of one module: :func:`summary_line`, and with the aids what they did so far."""
    return summary_line(dev, drift) + _aids_status(aids, live), len(dev.tracker)


def _aids_status(aids, live) -> str:
    """What the aids did so far, for a live line ("" without them): compass and GPS updates, and
    with a receiver read live its fixes and whether it went away."""
    if aids is None:
        return ""
    f = aids.tracker.fusion
    line = f" | compass {f.compass_updates} | GPS {f.gps_updates} updates"
    if live is not None:
        st = live.fixes.stats
        line += (f" of {st.fixes} fixes ({st.missing_fix} without a fix, {st.garbled} garbled)"
                 + (" RECEIVER GONE" if live.lost else ""))
    return line


def _aids_summary(aids, live, out: TextIO) -> tuple[float, float, float] | None:
    """What the aids did, at the end of a walk; returns the track's geographic origin (the first
    fix's place; None without one)."""
    if live is not None:
        aids.gps_stats = live.fixes.stats
        aids.origin = live.fixes.origin or aids.origin
    print(f"aids: {aids.describe()}", file=out)
    print(_fusion_line(aids.tracker), file=out)
    return aids.origin if aids.gps_stats is not None else None


def _feet_status(feet: TwoFeetTracker, modules: list[_Tracked], aids=None, live=None) -> tuple[str, object]:
    """The live line of a two-feet walk (with the aids, what they did so far), and what makes it
    new: a step, a link going up or down, a walk failing."""
    failed = [m.side for m in modules if m.failure is not None]
    devices = {m.side: m.dev for m in modules}
    return (feet_summary_line(feet, devices, failed) + _aids_status(aids, live),
            (len(feet), tuple(dev.link_up for dev in devices.values()), tuple(failed)))


def _check_feet_calibrations(feet: TwoFeetTracker, modules: list[_Tracked], ack_timeout: float) -> None:
    """Refuse a foot's drift or magnetometer calibration made with another module, once both
    modules named themselves (or did not in time: unknown, accepted as the calibrations'
    ``check_module`` does)."""
    for m in modules:
        _await_serial(m.dev, max(2.0, 2 * ack_timeout))
    _check_feet_modules(feet, {m.side: m.dev.session.mcu_serial for m in modules},
                        {m.side: m.dev.name for m in modules})


def _use_saved_calibration(modules: list[_Tracked], aids: Any, args: argparse.Namespace) -> None:
    """Before tracking starts: ask each module its serial number (MCU_ID) and give its compass the
    module's saved magnetometer calibration, if there is one (:func:`_use_saved_calibrations`)."""
    for m in modules:
        m.dev.request_mcu_id()
    for m in modules:
        _await_serial(m.dev, max(2.0, 2 * args.ack_timeout))
    _use_saved_calibrations(args, aids, {m.side: m.dev.session.mcu_serial for m in modules})


def _use_saved_calibrations(args: argparse.Namespace, aids: Any, serials: Mapping[str | None, bytes | None]
                            ) -> None:
    """Before the first step: give the compass of each module (side → its serial number, None
    unknown; side None: the only module) the module's saved magnetometer calibration, if there is
    one (hostlib.calibration.magcal.load_for_module); the summary says which file each came from."""
    for side, serial in serials.items():
        found = _saved_calibration(args, serial)
        if found is None:
            continue
        source = f"saved {found[1]}"
        if side is None:
            aids.tracker.release_compass(found[0])
            aids.calibration_source = source
        else:
            aids.tracker.foot(side).release_compass(found[0])
            aids.foot_calibration_sources[side] = source


def _check_calibrations(dev: Device, drift: DriftCalibration | None, cal: Any, ack_timeout: float) -> None:
    """Refuse another module's drift or magnetometer calibration (*cal*) before the walk starts."""
    _await_serial(dev, max(2.0, 2 * ack_timeout))
    serial = dev.session.mcu_serial
    if serial is None:
        return
    if drift is not None:
        drift.check_module(serial)
    if cal is not None:
        _check_mag_module(cal, serial)


def _fusion_line(tracker) -> str:
    """What the aids did, for the summary (a FusionTracker or a TwoFeetTracker)."""
    f = tracker.fusion
    if tracker.aid_settings.compass and f.compass_updates == 0 and not f.heading_aligned_by:
        return ("fusion: no step packet carried the magnetometers and attitude — record with the fusion "
                "set-up (--fusion); the track is the plain sum")
    aligned = f"heading aligned by {f.heading_aligned_by}" if f.heading_aligned_by else \
        "heading not aligned (the module's initial frame)"
    return (f"fusion: {f.compass_updates} compass updates ({f.compass_skipped} readings skipped), "
            f"{f.gps_updates} GPS updates ({f.gps_skipped} fixes between updates, "
            f"{f.gps_before_alignment} before alignment); {aligned}; declination "
            f"{math.degrees(tracker.declination):+.2f}° ± {math.degrees(tracker.declination_sigma):.2f}°"
            + ("" if tracker.deviation is None else
               f"; local deviation at the end {math.degrees(tracker.deviation):+.2f}° ± "
               f"{math.degrees(tracker.deviation_sigma):.2f}°")
            + ("" if tracker.gps_bias is None else
               "; GPS bias at the end N {:+.2f} ± {:.2f} m, E {:+.2f} ± {:.2f} m".format(
                   *(float(v) for pair in zip(tracker.gps_bias, tracker.gps_bias_sigma, strict=True)
                     for v in pair))))


def _write_outputs(args: argparse.Namespace, track: Track, origin: Sequence[float] | None,
                   geographic_csv: bool = False, feet: TwoFeetTracker | None = None) -> None:
    """The files the options ask for: *track*'s, or with *feet* the body track's (its CSV with each
    foot's columns, its plot with each fused foot's path)."""
    if args.csv:
        from .files.export import write_csv, write_feet_csv

        if feet is not None:
            write_feet_csv(feet, args.csv)
        else:
            write_csv(track, args.csv, origin if geographic_csv else None)
    if args.geojson:
        from .files.export import write_geojson

        write_geojson(track, args.geojson, origin)
    if args.png:
        from .files.plot import plot_track

        paths = None if feet is None else {f"{side} foot": feet.fused_foot(side) for side in FOOT_SIDES}
        title = None if feet is None else (f"body of two feet: {len(track)} steps, {track.distance:.1f} m, "
                                           f"closure {track.closure_error():.2f} m")
        plot_track(track, args.png, every=args.every, paths=paths, title=title,
                   label="track" if feet is None else "body")


def _stats_line(stats: SessionStats) -> str:
    """A session's counters: packets, resends, garbage, bad frames, gaps."""
    return (f"packets {stats.packets} (+{stats.duplicate_packets} resends) "
            f"| garbage {stats.garbage_bytes} B | bad frames {stats.bad_frames} "
            f"| gaps {stats.gaps} (missing {stats.missing_steps})"
            + (f" | {stats.undecoded_packets} packets fit no layout the capture's commands set up"
               if stats.undecoded_packets else ""))


def feet_summary(tracker: TwoFeetTracker, streams: Mapping[str, tuple[str, SessionStats]]) -> list[str]:
    """The summary of a two-feet walk: per foot (side → (where its stream came from, its session's
    counters)) its steps, distance, gaps and duplicates; what the fusion did; the body's end, fused
    and as the average of the two single-module tracks."""
    lines = []
    for side, (name, stats) in streams.items():
        foot = tracker.foot(side)
        lines.append(f"{side} foot ({name}): {len(foot)} step packets, {foot.track.motion_steps} steps, "
                     f"{foot.distance:.2f} m, duplicates {foot.duplicates} | {_stats_line(stats)}")
    settings = tracker.settings
    restarts = ", ".join(f"{side} at fused step {k}" for side, k in tracker.restarts) or "none"
    constraint = (f"constraint γ {settings.max_separation_m:.2f} m, projections {tracker.projections}"
                  if settings.constraint else "constraint off")
    lines.append(f"fusion: {len(tracker)} steps (left {tracker.sides.count('left')}, right "
                 f"{tracker.sides.count('right')}) | {constraint} | steps with a stale foot "
                 f"{tracker.stale_steps} | steps longer than 2γ {tracker.long_steps} | restarts: {restarts}")
    for side, calibration in tracker.drift.items():
        lines.append(f"drift correction, {side} foot: {calibration}")
    if tracker.drift_uncorrected:
        lines.append(f"drift correction: {tracker.drift_uncorrected} steps had no swing time and are "
                     f"uncorrected (record with the fusion set-up)")
    for what, track in (("fused", tracker.body), ("average", tracker.average)):
        label = f"body ({what}):"
        lines.append(f"{label:16s}{_pose_text(track.final_pose, track.closure_sigma())} "
                     f"| {track.distance:.2f} m")
    return lines


def _finish_feet(args: argparse.Namespace, tracker: TwoFeetTracker,
                 streams: Mapping[str, tuple[str, SessionStats]], origin: Sequence[float] | None,
                 out: TextIO) -> None:
    """A two-feet walk's output files and summary (:func:`feet_summary`)."""
    _write_outputs(args, tracker.body, origin, feet=tracker)
    for line in feet_summary(tracker, streams):
        print(line, file=out)


def cmd_log(args: argparse.Namespace, out: TextIO) -> int:
    with open(args.raw, "wb") as raw, _open(args, args.url, raw_log=raw) as dev:
        setup = _HostSetup(dev, args.fusion, args.height_compensation)
        if args.calibrate_mag:
            setup.in_situ = _InSitu(dev, args.mag_cal_dir, "log")
        if args.start:
            dev.start_stepwise_dead_reckoning()
        setup.after_start()
        deadline = _deadline(args.duration)
        live = _LiveLine(out, every_s=LOG_LINE_EVERY_S)
        try:
            while deadline is None or time.monotonic() < deadline:
                dev.recv_packet(timeout=_remaining(deadline))
                setup.poll()
                st = dev.stats
                live.show(f"bytes {st['bytes_received']:9d} | packets {st['packets']:7d} | "
                          f"step packets {st['steps']:5d} | garbage {st['garbage_bytes']}")
                if _enough_steps(args.steps, [setup]):
                    break
        except KeyboardInterrupt:
            pass
        live.close()
        if setup.in_situ is not None:  # log leaves the module's outputs on: the stream is stopped
            setup.in_situ.close(leave_running=True)
    return 0


def cmd_info(args: argparse.Namespace, out: TextIO) -> int:
    with _open(args, args.url) as dev:
        t0 = time.monotonic()
        dev.ping()
        rtt = time.monotonic() - t0
        print(f"port      {dev.name}", file=out)
        print(f"commands  {args.command_set} numbering; ping answered in {rtt * 1000:.1f} ms", file=out)
        got = None
        dev.request_mcu_id()  # 0x04 in both numberings
        deadline = time.monotonic() + 2.0
        while got is None and time.monotonic() < deadline:
            pkt = dev.recv_packet(timeout=_remaining(deadline))
            if pkt is not None and pkt.states and StateId.MCU_ID in pkt.states:
                got = bytes(pkt.states[StateId.MCU_ID].astype("u1"))
        print("mcu id    " + (got.hex(" ").upper() if got else "(no answer)"), file=out)
        print(f"lossless  {dev.session.lossless} (mode bit 0x{int(OutputMode.LOSSLESS):02X})", file=out)
    return 0


def cmd_replay(args: argparse.Namespace, out: TextIO) -> int:
    from .aids.geodesy import parse_origin
    from .files.replay import replay_calibrating, replay_session

    if args.capture2 is not None:
        return _replay_feet(args, out)
    drift = DriftCalibration.load(args.drift[0]) if args.drift else None
    origin = parse_origin(args.origin) if args.origin else None
    data = Path(args.capture).read_bytes()
    saved = None
    if _wants_saved_calibration(args):  # the capture's module's own, if one was saved
        saved = _saved_calibration(args, replay_session(data, command_set=args.command_set).mcu_serial)
    aids = _prepare_aids(args, origin, saved=saved) if _uses_aids(args) else None
    wiggle = None
    if args.calibrate_mag:
        from .calibration.wiggle import WiggleCalibration

        wiggle = WiggleCalibration()
        session = replay_calibrating(data, wiggle, aids.tracker, command_set=args.command_set)
        aids.calibration_source = (_keep_in_situ(wiggle, args.mag_cal_dir, "replay") if wiggle.done
                                   else "the wiggle did not end")
    else:
        session = replay_session(data, command_set=args.command_set,
                                 tracker=None if aids is None else aids.tracker)
    track, stats = session.tracker.track, session.stats
    if aids is not None:
        cal = aids.tracker.settings.mag_calibration
        if cal is not None:
            _check_mag_module(cal, session.mcu_serial)
        origin = _aids_summary(aids, None, out) or origin
    if wiggle is not None:
        print(wiggle.summary(), file=out)
    if drift is not None:
        corrected = drift.apply(track, module_serial=session.mcu_serial, what=args.capture)
        print(f"drift correction: {drift}", file=out)
        print(f"closure {track.closure_error():.3f} m uncorrected → {corrected.closure_error():.3f} m "
              f"corrected (horizontal; 3-D {track.closure_error(False):.3f} → "
              f"{corrected.closure_error(False):.3f} m)", file=out)
        track = corrected
    _write_outputs(args, track, origin, geographic_csv=bool(args.gps))
    print(repr(track), file=out)
    print(_stats_line(stats), file=out)
    return 0


def _replay_feet(args: argparse.Namespace, out: TextIO) -> int:
    """``replay LEFT RIGHT``: each capture decoded by its own session (its counters, resends and
    gaps), the two feet's steps then fused in module-time order."""
    from .aids.geodesy import parse_origin
    from .files.replay import decode_feet, replay_session

    origin = parse_origin(args.origin) if args.origin else None
    paths = dict(zip(FOOT_SIDES, (args.capture, args.capture2), strict=True))
    left, right = (Path(paths[side]).read_bytes() for side in FOOT_SIDES)
    tracker, aids = _feet_tracker(args, origin, last_counter=None, defer=True)
    if aids is not None and _wants_saved_calibration(args):  # each capture's module's own, if saved
        serials = {side: replay_session(data, command_set=args.command_set).mcu_serial
                   for side, data in zip(FOOT_SIDES, (left, right), strict=True)}
        _use_saved_calibrations(args, aids, serials)
    sessions = decode_feet(left, right, tracker, command_set=args.command_set)
    _check_feet_modules(tracker, {side: sessions[side].mcu_serial for side in FOOT_SIDES}, paths)
    tracker.fuse_in_time_order()
    if aids is not None:
        origin = _aids_summary(aids, None, out) or origin  # with GPS, the first fix: on the globe
    streams = {side: (paths[side], sessions[side].stats) for side in FOOT_SIDES}
    _finish_feet(args, tracker, streams, origin, out)
    return 0


def cmd_drift(args: argparse.Namespace, out: TextIO) -> int:
    """``drift calibrate CAPTURE... -o CAL.json``: each capture one closed loop of one module."""
    from .files.replay import replay_capture_session

    sessions = [replay_capture_session(path, command_set=args.command_set) for path in args.captures]
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


def main(argv: Sequence[str] | None = None, out: TextIO | None = None) -> int:
    """Entry point of ``openshoe-host``; returns the exit status."""
    args = build_parser().parse_args(argv)
    out = sys.stdout if out is None else out
    check = {"track": _usage_refusal, "replay": _usage_refusal, "log": _log_refusal}.get(args.cmd)
    refusal = None if check is None else check(args)
    if refusal is not None:
        print(f"openshoe-host {args.cmd}: {refusal}", file=sys.stderr)
        return 2
    try:
        commands = {"track": cmd_track, "log": cmd_log, "info": cmd_info, "replay": cmd_replay,
                    "drift": cmd_drift}
        return commands[args.cmd](args, out)
    except HostError as exc:
        print(f"openshoe-host: {exc}", file=sys.stderr)
        return 1
    except (OSError, ValueError) as exc:
        given = (getattr(args, name, None) for name in ("url", "url2", "capture", "capture2"))
        what = " and ".join(name for name in given if name) or " ".join(args.captures)
        print(f"openshoe-host: cannot use {what}: {exc}", file=sys.stderr)
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
