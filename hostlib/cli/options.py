"""The options the commands share, what they refuse together, and what they become: the argument
groups (the link, the set-up, the heading aids, two feet), their types, the refusals checked before
any port opens, and the objects the rest of the host takes — a
:class:`~hostlib.link.device_options.DeviceOptions`, :class:`~hostlib.run.options.RunOptions`,
:class:`~hostlib.run.options.AidOptions` and :class:`~hostlib.fusion.feet.FeetSettings`, each made
once, here, from argparse's namespace."""

from __future__ import annotations

import argparse
import math
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..errors import HostError
from ..fusion.feet_settings import FeetSettings
from .checks import baud_rate, compass_sigma, declination, port_url, seconds, value_refusal

if TYPE_CHECKING:  # the fusion, the link and the run: imported by the functions that use them, so
    # that a command imports only what it uses and ``openshoe-host --help`` none of them
    from ..fusion.deviation import CompassDeviation
    from ..fusion.hard_iron import HardIron
    from ..fusion.module_errors import ModuleErrors
    from ..link.device import Device
    from ..run.options import AidOptions, RunOptions

__all__ = ["NO_FILE", "add_aid_options", "add_common", "add_feet_options", "add_log_calibration_options",
           "add_setup_options", "aid_options", "compass_deviation_type", "feet_settings", "log_refusal",
           "module_errors_type", "open_device", "per_foot", "positive_metres", "run_options", "second",
           "step_count", "usage_refusal"]

#: Stands for "no calibration for this foot" in a per-module list.
NO_FILE = "-"
#: Options for two feet only: (dest, flag).
_FEET_OPTIONS = (("max_separation", "--max-separation"), ("no_constraint", "--no-constraint"))
#: Options that name one calibration file per module: (dest, flag).
_PER_MODULE_FILES = (("drift", "--drift"), ("mag_cal", "--mag-cal"))


# -- types ------------------------------------------------------------------------------------

def positive_metres(text: str) -> float:
    """The argparse type of ``--max-separation``: a distance > 0 m."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not value > 0 or not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"a distance > 0 m, not {text!r}")
    return value


def step_count(text: str) -> int:
    """The argparse type of ``--steps``: a whole number ≥ 1."""
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"a whole number of step packets ≥ 1, not {text!r}")
    return value


def module_errors_type(text: str) -> ModuleErrors:
    """The argparse type of ``--module-errors`` (:meth:`ModuleErrors.parse
    <hostlib.fusion.module_errors.ModuleErrors.parse>`)."""
    from ..fusion.module_errors import ModuleErrors

    try:
        return ModuleErrors.parse(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def hard_iron_type(text: str) -> str | HardIron:
    """The argparse type of ``--hard-iron``: a prior σ [µT], or "auto" (by the calibration)."""
    from ..fusion.hard_iron import HardIron

    if text == "auto":
        return text
    try:
        return HardIron(float(text))
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"--hard-iron takes the prior σ per axis in µT (> 0): {exc}"
                                         ) from None


def compass_deviation_type(text: str) -> CompassDeviation:
    """The argparse type of ``--compass-deviation`` (:meth:`CompassDeviation.parse
    <hostlib.fusion.deviation.CompassDeviation.parse>`)."""
    from ..fusion.deviation import CompassDeviation

    try:
        return CompassDeviation.parse(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


# -- argument groups --------------------------------------------------------------------------

def add_common(p: argparse.ArgumentParser) -> None:
    """The module's URL and how to talk to it (``track``, ``log``, ``info``)."""
    p.add_argument("url", type=port_url,
                   help="serial device path or pyserial URL (socket://host:port, openshoe://...)")
    p.add_argument("--command-set", choices=("2014", "2015"), default="2015",
                   help="command numbering of the module's firmware (default 2015)")
    p.add_argument("--baudrate", type=baud_rate, default=115200,
                   help="UART baud rate (ignored by URLs and USB)")
    p.add_argument("--ack-timeout", type=seconds, default=1.0, help="seconds to wait for each command ack")


def add_setup_options(p: argparse.ArgumentParser) -> None:
    """What the host sends besides 0x34 (``track``, ``log``)."""
    p.add_argument("--no-fusion", dest="fusion", action="store_false", default=True,
                   help="do not send the fusion set-up after 0x34 (by default the host asks the module "
                        "for each step's swing time, the module's time, attitude and magnetometers, and its "
                        "serial number: protocol.extensions.FUSION_SETUP; the module's warm-up, the "
                        "compass, GPS, --drift, --calibrate-mag and drift calibrate need it): plain 0x34 "
                        "step packets, for an experiment. A module that does not acknowledge the set-up "
                        "is tracked on plain packets without it, said once")
    p.add_argument("--fusion", dest="fusion", action="store_true", default=True,
                   help="the fusion set-up (the default; kept so that earlier commands still work)")
    p.add_argument("--height-compensation", action="store_true",
                   help="turn the module's height compensation (function 0x25) on at the first step "
                        "packet (an emulator extension)")


def add_aid_options(p: argparse.ArgumentParser, live: bool = False) -> None:
    """The heading aids' options; *live*: of ``track`` (one URL, a GPS device read as it talks)."""
    what = "one URL or two, not with --no-fusion" if live else "the capture needs the fusion set-up"
    g = p.add_argument_group(f"heading aids (hostlib.fusion.tracker; {what})")
    g.add_argument("--compass", action="store_true",
                   help="one compass update per step from the magnetometers and attitude at the end of "
                        "each stance")
    g.add_argument("--compass-sigma", type=compass_sigma, default=None, metavar="DEG",
                   help="1σ of one compass reading (the local deviation; default 20, indoors; "
                        "outdoors about 5; with --compass-deviation only the reading's own white error, "
                        "default 1.5)")
    g.add_argument("--no-compass-gate", dest="compass_gate", action="store_false",
                   help="use every compass reading, however far it lies from what the filter expects "
                        "(default: a reading beyond 3σ of its innovation, or whose field's magnitude "
                        "or inclination is not the Earth's there, is rejected and counted)")
    g.add_argument("--no-uncalibrated-weight", dest="uncalibrated_weight", action="store_false",
                   help="weigh an uncalibrated compass as a calibrated one (default: without a "
                        "calibration and without --hard-iron, its deviation gains atan(10 µT / H), the "
                        "heading error an uncalibrated shoe's iron causes against the horizontal field H)")
    g.add_argument("--compass-deviation", type=compass_deviation_type, default=None,
                   metavar="outdoors|indoors|SIGMA_DEG,LENGTH_M",
                   help="the local magnetic deviation held as a state of the filter "
                        "(hostlib.fusion.deviation), "
                        "correlated over the distance walked: 'outdoors' (3° over 9 m), 'indoors' "
                        "(20° over 0.5 m) or its 1σ [deg] and correlation length [m]; with two modules "
                        "one deviation for both feet (with --compass; held by default: outdoors with "
                        "--gps, indoors without)")
    g.add_argument("--no-compass-deviation", action="store_true",
                   help="do not hold the local deviation: each compass reading's deviation is white noise "
                        "of --compass-sigma")
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
    g.add_argument("--hard-iron", type=hard_iron_type, nargs="?", const="auto", default=None,
                   metavar="SIGMA_UT",
                   help="learn the shoe's hard iron as three states of the filter while walking "
                        "(hostlib.fusion.hard_iron): GPS and the walk's turns make it observable, and "
                        "until then the compass counts for as little as the iron's uncertainty says; "
                        "its prior 1σ per axis [µT] (default 10 uncalibrated, 1 with a calibration)")
    g.add_argument("--compass-swing", action="store_true",
                   help="learn a calibrated compass's swing B sin ψ + C cos ψ as two states of the filter "
                        "(hostlib.fusion.compass_swing; with --compass and one module: σ 4° on each term, "
                        "learned while the compass reads with a calibration, from GPS and the walk's turns, "
                        "and with a place (--gps, --origin) from the levelled field's inclination, "
                        "hostlib.fusion.compass_dip; "
                        "by default the swing the module's warming builds is held, σ 0.6°, weighed and not "
                        "learned)")
    g.add_argument("--no-compass-swing", action="store_true",
                   help="hold no swing of a calibrated compass (by default the swing the module's warming "
                        "builds after the calibration is weighed, not learned)")
    g.add_argument("--gps-bias", action="store_true",
                   help="hold the receiver's correlated error as a state of the filter "
                        "(hostlib.fusion.gps_bias): "
                        "a bias wandering over minutes (3 m RMS, τ 120 s) plus 0.3 m white per fix, every "
                        "fix used; with two modules one bias for the body's receiver (with --gps; held by "
                        "default)")
    g.add_argument("--no-gps-bias", action="store_true",
                   help="do not hold the receiver's bias: a fix is white noise of 15 m, one every 10 s")
    g.add_argument("--mag-cal", nargs="+", metavar="CAL.json",
                   help="the shoe's magnetometer calibration (hard/soft iron); with two captures or URLs, "
                        "the left foot's then the right foot's (- for none). Without it, --compass takes the "
                        "module's saved calibration, if there is one (--mag-cal-dir)")
    g.add_argument("--module-errors", type=module_errors_type, default=None,
                   metavar="SCALE,CLIMB[,TURN[,DRIFT_DEG_PER_H[,WARMUP_DEG_PER_S[,TAU_S]]]]",
                   help="hold the module's step-length scale, climb per metre, turn scale, heading drift "
                        "rate and the gyros' warm-up as states of the filter "
                        "(hostlib.fusion.module_errors), with "
                        "these 1σ priors (e.g. 0.001,0.0017,0.01,20,0.05,120: 0.1 %% per metre, 1.7 mm/m, "
                        "1 %% of the angle turned, 20 °/h, and a vertical rate bias settling 0.05 °/s away "
                        "with a warm-up time constant of 120 s, counted from the first step; a drift or "
                        "warm-up of 0 or none: not held), or 'mimu22bt' for a MIMU22BT-class module's from "
                        "its datasheet (the default, with an aid or without; the warm-up counts only "
                        "with the fusion set-up's step times), "
                        "'emulated' (also 'emulated-sway') for the "
                        "emulated module's on a real foot's swaying stance (openshoe-emu's default; its "
                        "warm-up from the sensors' physics), or 'emulated-still' for the emulated module "
                        "on still stances (openshoe-emu --no-stance-sway): the covariance "
                        "then grows with the distance, the angle turned and the time walked, as a module's "
                        "systematic errors do; with two modules each foot's module holds its own")
    g.add_argument("--no-module-errors", action="store_true",
                   help="do not hold the module's errors: the covariance is the steps' own (over-"
                        "confident: it leaves out the scale, climb, turn scale and warm-up every module "
                        "has); without an aid, the plain step sum")
    where = "once tracking started" if live else "the capture's"
    g.add_argument("--calibrate-mag", action="store_true",
                   help=f"calibrate the magnetometers in situ (with --compass, one module): {where} wiggle "
                        "of the shoe in one place, ended by the first step longer than 0.5 m; the compass "
                        "waits for it, and the calibration is saved for the module (--mag-cal-dir)"
                        + ("; the module streams its magnetometers meanwhile" if live else
                           " (a capture of the stream: log --calibrate-mag, or openshoe-emu replay --host "
                           "fusion --calibrate-mag)"))
    _mag_cal_dir_option(g)
    g.add_argument("--declination", type=declination, default=None, metavar="DEG",
                   help="magnetic declination, east positive (default: the World Magnetic Model at the "
                        "first fix or at --origin)")


def _mag_cal_dir_option(g: Any) -> None:
    """``--mag-cal-dir`` in the argument group *g*."""
    g.add_argument("--mag-cal-dir", metavar="DIR", default=None,
                   help="where each module's magnetometer calibration is kept, as <serial>.json (default: "
                        "$OPENSHOE_MAGCAL_DIR, else $XDG_CONFIG_HOME/openshoe/magcal, else "
                        "~/.config/openshoe/magcal)")


def add_log_calibration_options(p: argparse.ArgumentParser) -> None:
    """``log --calibrate-mag``: record the wiggle's stream, and fit and save it as ``track`` does."""
    g = p.add_argument_group("in-situ magnetometer calibration (hostlib.calibration.wiggle; not with "
                             "--no-fusion)")
    g.add_argument("--calibrate-mag", action="store_true",
                   help="after the fusion set-up the module streams its magnetometers and attitude while "
                        "the shoe is wiggled in one place, until the first step longer than 0.5 m: the "
                        "capture holds the stream (replay --compass --calibrate-mag fits it again), and the "
                        "calibration is fitted and saved for the module (--mag-cal-dir) as track does")
    _mag_cal_dir_option(g)


def add_feet_options(p: argparse.ArgumentParser, what: str) -> None:
    """The two feet's fusion (``track`` and ``replay`` with two URLs or captures)."""
    g = p.add_argument_group(f"two feet (with two {what}s: the left foot's, then the right foot's; "
                             "hostlib.fusion.feet)")
    g.add_argument("--max-separation", type=positive_metres, default=None, metavar="M",
                   help="γ: the feet's last rests are never farther apart than M metres (default "
                        f"{FeetSettings.max_separation_m:g}, the longest walking step; a runner's: 1.5); a "
                        "step longer than 2γ is fused without it (the other foot moved meanwhile)")
    g.add_argument("--no-constraint", action="store_true",
                   help="no inter-foot constraint: the body is the average of the two single-module tracks")


# -- refusals ---------------------------------------------------------------------------------

def second(args: argparse.Namespace) -> str | None:
    """The right foot's URL or capture (None: one module)."""
    return getattr(args, "url2", None) or getattr(args, "capture2", None)


def _track_aid_refusal(args: argparse.Namespace) -> str | None:
    """Why the aid options of ``track`` do not go together, or None."""
    for flag, why in (("compass", "the compass needs the magnetometers and the attitude at the end of each "
                                  "stance"),
                      ("gps", "a fix is put on the module's clock, which only the step packets' time "
                              "(T_INT_K) gives")):
        if getattr(args, flag) and not args.fusion:
            return _no_fusion(f"--{flag}", why)
    return None


def _no_fusion(flag: str, why: str) -> str:
    """The refusal of *flag* with ``--no-fusion``: *why* it needs the fusion set-up."""
    return (f"{flag} needs the fusion set-up, which --no-fusion turns off: {why}, which the set-up asks "
            "the module for")


def usage_refusal(args: argparse.Namespace) -> str | None:
    """Why the options of ``track`` or ``replay`` do not go together, or a value is refused
    (:func:`~hostlib.cli.checks.value_refusal`), or None."""
    if (refusal := value_refusal(args)) is not None:
        return refusal
    what = "URL" if args.cmd == "track" else "capture"
    two = second(args) is not None
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
        return _no_fusion("--drift", "the drift correction needs every step's swing time and the module's "
                                     "serial number")
    if args.compass_deviation is not None and not args.compass:
        return ("--compass-deviation needs --compass: it is the local deviation of the compass's "
                "readings")
    if args.gps_bias and not args.gps:
        return "--gps-bias needs --gps: it is the error of the receiver's fixes"
    for on, off in (("module_errors", "no_module_errors"), ("compass_deviation", "no_compass_deviation"),
                    ("gps_bias", "no_gps_bias"), ("compass_swing", "no_compass_swing")):
        if getattr(args, on) not in (None, False) and getattr(args, off):
            return f"--{on.replace('_', '-')} or --{off.replace('_', '-')}: one or the other, not both"
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


def log_refusal(args: argparse.Namespace) -> str | None:
    """Why the options of ``log`` do not go together, or None (as ``track``: the calibration needs the
    fusion set-up; without --start the module is taken to track already, as with ``track --attach``;
    a value refused: :func:`~hostlib.cli.checks.value_refusal`)."""
    if (refusal := value_refusal(args)) is not None:
        return refusal
    if args.calibrate_mag and not args.fusion:
        return _no_fusion("--calibrate-mag", "the calibration is saved for the module under its serial "
                                             "number, and a replay of the capture with --compass takes the "
                                             "magnetometers and the attitude at the end of each stance from "
                                             "the set-up's steps")
    return None


# -- the objects the options become -------------------------------------------------------------

def per_foot(files: Sequence[str] | None) -> dict[str, str]:
    """Side → each foot's file of a per-module option (none: -)."""
    from protocol.board import FOOT_SIDES

    return {side: path for side, path in zip(FOOT_SIDES, files or (), strict=False) if path != NO_FILE}


def aid_options(args: argparse.Namespace, origin: tuple[float, float, float] | None) -> AidOptions:
    """The aids and calibrations the options of ``track`` or ``replay`` ask for (*origin*: the
    parsed ``--origin``). ``track --gps`` names a receiver read as it talks, unless it is a file."""
    from ..fusion.compass_swing import CALIBRATED_SWING
    from ..fusion.gps_bias import GpsBias
    from ..run.options import AidOptions

    two = second(args) is not None
    live = args.cmd == "track" and bool(args.gps) and not Path(args.gps).is_file()
    return AidOptions(
        compass=args.compass, compass_sigma_deg=args.compass_sigma,
        compass_deviation=_held(args.compass_deviation, args.no_compass_deviation),
        compass_gate=args.compass_gate, uncalibrated_weight=args.uncalibrated_weight,
        hard_iron=args.hard_iron,
        compass_swing=_held(CALIBRATED_SWING if args.compass_swing else None, args.no_compass_swing),
        gps_log=None if live else args.gps, gps_receiver=args.gps if live else None,
        gps_bias=_held(GpsBias() if args.gps_bias else None, args.no_gps_bias),
        module_errors=_held(args.module_errors, args.no_module_errors),
        mag_calibration=args.mag_cal[0] if args.mag_cal and not two else None,
        foot_mag_calibrations=per_foot(args.mag_cal) if two else {},
        saved_calibration=bool(args.compass and not (args.mag_cal or args.calibrate_mag)),
        calibrate_mag=args.calibrate_mag, mag_cal_dir=args.mag_cal_dir, declination_deg=args.declination,
        origin=origin)


def _held(given: Any, off: bool) -> Any:
    """A model's option for :class:`~hostlib.run.options.AidOptions`: *given* (a model), None where
    *off* (its ``--no-`` switch), else :data:`~hostlib.run.options.AUTO`, the default's to resolve."""
    from ..run.options import AUTO

    return None if off else AUTO if given is None else given


def run_options(args: argparse.Namespace) -> RunOptions:
    """How ``track`` drives its modules and when the walk ends."""
    from ..run.options import RunOptions

    return RunOptions(attach=args.attach, fusion=args.fusion, height_compensation=args.height_compensation,
                      heading_deg=args.heading, duration_s=args.duration, steps=args.steps,
                      leave_running=args.leave_running)


def feet_settings(args: argparse.Namespace) -> FeetSettings:
    """The two feet's fusion (``--max-separation``, ``--no-constraint``)."""
    gamma = FeetSettings.max_separation_m if args.max_separation is None else args.max_separation
    return FeetSettings(constraint=not args.no_constraint, max_separation_m=gamma)


def open_device(args: argparse.Namespace, url: str, *, queue_packets: bool = True, **kw: Any) -> Device:
    """The device at *url*, talking as the link options say (*queue_packets*: to
    :class:`DeviceOptions`, *kw*: to :class:`Device`); a port that does not open is a
    :class:`~hostlib.errors.HostError` naming it (one of two feet's)."""
    from ..link.device import Device
    from ..link.device_options import DeviceOptions

    try:
        return Device(url, DeviceOptions(command_set=args.command_set, baudrate=args.baudrate,
                                         ack_timeout=args.ack_timeout, queue_packets=queue_packets), **kw)
    except (OSError, ValueError) as exc:  # pyserial's SerialException is an OSError
        raise HostError(f"cannot use {url}: {exc}") from None
