"""Batch replay: a sensor source through the emulated module → the bytes it transmitted.

``openshoe-emu replay FILE --wire OUT`` (and :func:`run_replay`) run one
:class:`~firmware_sim.mcu.module.Module` in batch mode (virtual time, as fast as
the host machine goes) with the recording as its sensors, its main loop at the
recording's own rate (250 Hz for the OpenShoe walks). The session is the one a
host app runs over Bluetooth:

* at power-on the host sends ``34 00 34`` (start step-wise dead reckoning);
* it acknowledges every state packet at once (``01 nn nn cc cc``, lossless mode),
  i.e. the acknowledgement reaches the module in the next loop cycle;
* OUT receives exactly the bytes the module transmitted on its Bluetooth
  interface, in order: the command ack ``A0 34 00 D4``, then one 64-byte step
  packet per step.

When the source runs out the process sequence is emptied (the foot stops being
sensed) and the loop keeps running until the packet queue has drained, so the
last step is on the wire too. ``--scenario NAME`` replays a simulated walk
(:func:`firmware_sim.sensors.imu_array.make_source`, 1 kHz by default) instead and
writes its ground truth beside OUT (``OUT.truth.csv``) and the shoe's iron as simulated, as the
host's magnetometer calibration of the module (``OUT.iron.json``, :mod:`.truth_files`);
``--module N`` makes it module N's walk
(module N's own systematic errors, the walk's noise from ``--seed``; default: the seed's own module);
its walking stances sway and vibrate as a real foot's do
(:class:`firmware_sim.sensors.stance_sway.StanceSway`; the default, ``--stance-sway``), or with
``--no-stance-sway`` stand perfectly still; the run's announcement says which.

The replayed host may also use the emulator's extensions, as a host app would:
``--host fusion`` sends :data:`protocol.extensions.FUSION_SETUP` after the ack of 0x34 (the
step packets then carry each step's swing time, and the module outputs its serial number
once), and ``--height-compensation`` turns the module's height compensation on when the first
step packet arrives (:func:`protocol.extensions.height_compensation_on`). ``--calibrate-mag``
(with ``--host fusion``) runs the in-situ magnetometer calibration as ``openshoe-host track
--calibrate-mag`` does, with the same :class:`hostlib.calibration.wiggle.WiggleCalibration`: after the fusion
set-up the host starts the magnetometer stream (:data:`protocol.extensions.MAG_STREAM_START`) and
stops it (:data:`~protocol.extensions.MAG_STREAM_STOP`) at the first step longer than 0.5 m, so
that ``openshoe-host replay OUT --compass --calibrate-mag`` fits the calibration from the capture
(walk the ``navshoe-calibration`` scenario, which starts with a wiggle). Each command goes
out once the module acknowledged the one before. What is sent when is ``openshoe-host``'s own
policy, the same code (:class:`hostlib.run.host_setup.HostSetup`), carried out over a host session
without I/O (:class:`hostlib.run.host_setup.SessionSetup`). Without them the host sends ``34 00 34``
only, and the bytes are those of before. A module made with ``--module N`` has the MCU serial number
``OSEMU-M`` + N in 8 digits (:func:`firmware_sim.mcu.module.module_serial`).

``--wire-dir DIR`` replays many in one process — every FILE, or the scenario with every seed
of ``--seeds A:B`` — into ``DIR/<name>.bin`` (:mod:`firmware_sim.app.replay_cli`); each file's
bytes are the ones a replay of it alone writes.

``--scenario NAME --feet 2 --wire OUT`` puts a module on each foot of the walker
(:mod:`firmware_sim.sensors.feet`; each module its own errors, seed and serial number) and replays
them one after the other on the same virtual clock from power-on: ``OUT.left`` and ``OUT.right``,
each foot's ``.truth.csv`` and the body's, ``OUT.body.truth.csv`` (the feet's midpoint); ``--gps``
puts the receiver on the body.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Callable
from pathlib import Path

from firmware_sim.mcu.imu_bus import SensorSource
from firmware_sim.mcu.module import MAX_MODULE, Module, ModuleConfig, module_serial
from firmware_sim.mcu.port import Port
from firmware_sim.nav.firmware import build_module
from firmware_sim.nav.profiles import PROFILES, profile_for
from firmware_sim.nav.warmup import Announce, prepare_compiled_path, prepare_module, to_stderr
from protocol.frames import StatePacket, build_packet_ack
from protocol.ids import Command
from protocol.stream import StreamDecoder

from .progress import progress_bar, say
from .truth_files import write_truth_files

__all__ = ["HOSTS", "MODULE_HELP", "START_STEPWISE", "STANCE_SWAY_HELP", "LosslessHost", "ReplayResult",
           "run_replay", "source_length", "start_replay",
           "stance_note", "add_arguments", "add_receiver_arguments", "add_stance_sway_argument",
           "check_arguments", "error_text", "load_walk", "main", "module_number", "rate_hz", "seed_number"]

#: The host's first frame: STEPWISE_DEAD_RECKONING (0x34) with its checksum.
START_STEPWISE = bytes([Command.STEPWISE_DEAD_RECKONING, 0x00, Command.STEPWISE_DEAD_RECKONING])
#: Loop cycles allowed for the queue to drain after the source ended.
DRAIN_TICKS = 2000
#: The replayed hosts: "plain" sends 0x34 only; "fusion" then the fusion set-up (FUSION_SETUP).
HOSTS = ("plain", "fusion")


class ReplayResult(bytes):
    """The transmitted bytes, with the run's counters as attributes.

    ``ticks`` loops run, ``packets`` state packets acknowledged,
    ``samples`` sensor samples consumed.
    """

    ticks: int = 0
    packets: int = 0
    samples: int = 0
    module: Module | None = None  #: the module after the run (its counters, clock and states)


def source_length(source: SensorSource) -> int | None:
    try:
        return len(source)  # type: ignore[arg-type]
    except TypeError:
        return None


def run_replay(source: SensorSource, *, config: ModuleConfig | None = None,
               progress: Callable[[int, int | None], None] | None = None,
               progress_every: int = 5000, announce: Announce | None = to_stderr,
               bt_port: Port | None = None, host: str = "plain",
               height_compensation: bool = False, calibrate_mag: bool = False) -> ReplayResult:
    """Run the module on *source* as a lossless Bluetooth host would; returns the bytes sent.

    *config* defaults to ``ModuleConfig(rate_hz=source.rate_hz)``; without its own ``ins`` noise
    figures the module navigates with the source's sensor profile
    (:func:`firmware_sim.nav.profiles.profile_for`, :meth:`~.SensorProfile.configure`).
    *progress(samples_done, samples_total_or_None)* is called every
    *progress_every* loops. *announce* hears about a slow first start (the compiled
    path being prepared, :mod:`firmware_sim.nav.warmup`) or a fallback to the pure path.
    *bt_port* is the Bluetooth interface's port (default: an ideal one; a link model
    with faults makes the host receive what that link delivers). *host* is the replayed host
    (:data:`HOSTS`); *height_compensation*: it turns height compensation on at the first step;
    *calibrate_mag* (the fusion host only): it runs the in-situ magnetometer calibration.
    """
    replayed = start_replay(source, config=config, announce=announce, bt_port=bt_port, host=host,
                            height_compensation=height_compensation, calibrate_mag=calibrate_mag)
    replayed.run_source(source_length(source), progress, progress_every)
    replayed.drain()
    return replayed.result()


def start_replay(source: SensorSource, *, config: ModuleConfig | None = None,
                 announce: Announce | None = to_stderr, bt_port: Port | None = None, host: str = "plain",
                 height_compensation: bool = False, calibrate_mag: bool = False) -> LosslessHost:
    """:func:`run_replay`'s module on *source* with its host, the start command sent, before its first
    loop (the arguments as :func:`run_replay`'s); :mod:`firmware_sim.app.replay_group` runs many so."""
    if host not in HOSTS:
        raise ValueError(f"host must be one of {', '.join(HOSTS)}, not {host!r}")
    if calibrate_mag and host != "fusion":
        raise ValueError("the in-situ magnetometer calibration goes with the fusion host")
    if config is None:
        config = ModuleConfig(rate_hz=float(source.rate_hz))
    if config.ins is None:
        config = profile_for(source).configure(config)
    module = build_module(config, sensors=source, bt_port=bt_port)
    prepare_module(module, announce)
    return LosslessHost(module, fusion=host == "fusion", height_compensation=height_compensation,
                        calibrate_mag=calibrate_mag)


class LosslessHost:
    """The host side of a batch replay: starts step-wise tracking over Bluetooth, keeps every
    byte the module sends and acknowledges each state packet, as a lossless host does.

    With *fusion*, *height_compensation* or *calibrate_mag* it also sends the extensions' commands,
    as ``openshoe-host`` does: :class:`hostlib.run.host_setup.HostSetup` says which and when, a
    :class:`hostlib.run.host_setup.SessionSetup` builds their frames, follows the module's bytes
    (acks, and packets split by what was asked for) and says which packets to acknowledge: every one
    while the module is lossless, only the steps while the magnetometer stream has it lossy."""

    def __init__(self, module: Module, *, fusion: bool = False, height_compensation: bool = False,
                 calibrate_mag: bool = False):
        self.module = module
        self.port = module.bt.port
        self.decoder = StreamDecoder()
        self.out = bytearray()
        self.packets = 0
        self.ticks = 0
        self.setup = None
        if fusion or height_compensation:
            from hostlib.calibration.wiggle import WiggleCalibration
            from hostlib.run.host_setup import HostSetup, SessionSetup

            wiggle = WiggleCalibration() if calibrate_mag else None
            self.setup = SessionSetup(HostSetup(fusion=fusion, height_compensation=height_compensation,
                                                wiggle=wiggle))
        self.port.host_write(START_STEPWISE if self.setup is None else self.setup.start())

    def loop_once(self, max_ticks: int = 1) -> int:
        """Run up to *max_ticks* loops (quiet stretches compiled, when available), then read and
        acknowledge; returns the number of bytes read."""
        module = self.module
        return self.after_loops(module.advance(max_ticks) if max_ticks > 1 else _step(module))

    def after_loops(self, loops: int) -> int:
        """Count *loops* the module ran, then read and acknowledge what it sent; returns the bytes read."""
        self.ticks += loops
        data = self.port.host_read()
        if not data:
            return 0
        self.out.extend(data)
        if self.setup is None:
            for frame in self.decoder.feed(data):
                if isinstance(frame, StatePacket):
                    self.port.host_write(build_packet_ack(frame.number))
                    self.packets += 1
            return len(data)
        acks, command = self.setup.received(data)
        self.port.host_write(acks + command)
        self.packets += len(acks) // len(build_packet_ack(0))
        return len(data)

    def run_source(self, total: int | None, progress: Callable[[int, int | None], None] | None,
                   progress_every: int) -> None:
        """Loop until the source's *total* samples ran or it is exhausted."""
        next_progress = progress_every
        while True:
            loops = self.source_loops(total, progress_every)
            if not loops:
                break
            self.loop_once(loops)
            if progress is not None and self.ticks >= next_progress:
                progress(self.ticks, total)
                next_progress += progress_every

    def source_loops(self, total: int | None, most: int) -> int:
        """:meth:`run_source`'s next loops (at most *most*); 0 once *total* samples ran or it ended."""
        module = self.module
        if (total is not None and module.clock.ticks >= total) or module.sensors_exhausted:
            return 0
        return min(total - module.clock.ticks, most) if total is not None else 1

    def result(self) -> ReplayResult:
        """The bytes the module sent, with the run's counters."""
        result = ReplayResult(bytes(self.out))
        result.ticks = self.ticks
        result.packets = self.packets
        total = source_length(self.module.sensors)
        result.samples = self.ticks if total is None else min(total, self.ticks)
        result.module = self.module
        return result

    def drain(self) -> None:
        """The source has ended: stop processing and let the queue drain (at most DRAIN_TICKS)."""
        module = self.module
        module.sequence.empty()
        quiet = 0
        for _ in range(DRAIN_TICKS):
            if self.loop_once() == 0 and self.port.rx_pending() == 0:
                quiet += 1
                if quiet > 2 and len(module.bt.queue) == 0:
                    break
            else:
                quiet = 0


def _step(module: Module) -> int:
    module.step()
    return 1


# ---------------------------------------------------------------------------------------------
# command line (wired into `openshoe-emu` by firmware_sim.app.cli)


#: The help of ``--module`` (replay, serve, the demo).
MODULE_HELP = ("the simulated module's identity: its own systematic errors (offsets, scale, misalignment, "
               "g-sensitivity, shoe iron) stay the same across seeds; default: the seed's own module")


def module_number(text: str) -> int:
    """The argparse type of ``--module``: a module identity, an integer >= 0."""
    try:
        number = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a module number >= 0, got {text!r}") from None
    if number < 0:
        raise argparse.ArgumentTypeError(f"a module number is >= 0, got {number}")
    if number > MAX_MODULE:
        raise argparse.ArgumentTypeError(f"a module number is at most {MAX_MODULE} (its serial number has "
                                         f"8 digits), got {number}")
    return number


#: The highest sample rate a simulated module takes [Hz] (its loop runs once per sample).
MAX_RATE_HZ = 10000.0


def rate_hz(text: str) -> float:
    """The argparse type of ``--rate``: a simulated module's sample rate, > 0 and at most
    :data:`MAX_RATE_HZ` [Hz] (0 divided by zero, a NaN or a huge one never ended)."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and 0.0 < value <= MAX_RATE_HZ):
        raise argparse.ArgumentTypeError(f"a sample rate in Hz > 0 and at most {MAX_RATE_HZ:g}, not {text!r}")
    return value


def seed_number(text: str) -> int:
    """The argparse type of ``--seed``: a whole number >= 0 (what the random generators take)."""
    try:
        value = int(text)
    except ValueError:
        value = -1
    if value < 0:
        raise argparse.ArgumentTypeError(f"a whole number >= 0, not {text!r}")
    return value


def speed_factor(text: str) -> float:
    """The argparse type of ``serve --speed``: module time per wall time, a number >= 0; 0 and
    ``inf`` both run the modules as fast as the CPU allows (the pacer's *speed*)."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not value >= 0:  # NaN too
        raise argparse.ArgumentTypeError(f"module time per wall time, >= 0 (1: real time; 0 or inf: as fast "
                                         f"as possible), not {text!r}")
    return value


#: The most worker processes of a local Dask cluster (each a Python process holding the compiled
#: kernels, some 200 MB): more belong on a real cluster (``--scheduler``).
MAX_LOCAL_WORKERS = 64


def worker_count(text: str) -> int:
    """The argparse type of ``--workers``: local Dask worker processes, a whole number from 0 (the
    runs one after the other, here) to :data:`MAX_LOCAL_WORKERS`."""
    try:
        value = int(text)
    except ValueError:
        value = -1
    if not 0 <= value <= MAX_LOCAL_WORKERS:
        raise argparse.ArgumentTypeError(f"a whole number of processes from 0 (here, one run after the "
                                         f"other) to {MAX_LOCAL_WORKERS} (more: --scheduler), not {text!r}")
    return value


def load_walk(path: str | Path):
    """The :class:`~firmware_sim.sensors.replay.ReplaySource` of the recording at *path*; a file
    that cannot be read (no such file, a directory, a device, an I/O error) is an
    :class:`~hostlib.inputs.InputFileError` naming it, a file that is no recording a
    :class:`~firmware_sim.sensors.replay.RecordingFormatError` with its line."""
    from firmware_sim.sensors.replay import ReplaySource
    from hostlib.inputs import InputFileError, check_input

    try:
        return ReplaySource.from_file(check_input(path, "walk recording", pipes=False))
    except OSError as exc:
        raise InputFileError(f"{path}: cannot read the walk recording: {exc.strerror or exc}") from None


def start_errors() -> tuple[type[Exception], ...]:
    """What a run that cannot start raises while its recording is read or its scenario made: the file
    unreadable or no recording, an unknown scenario or setting (imported when asked: start-up)."""
    from firmware_sim.sensors.replay import RecordingFormatError

    return (OSError, RecordingFormatError, KeyError, ValueError)


def error_text(exc: BaseException) -> str:
    """An error's message as one line: a KeyError's own text, not its repr in quotes."""
    if isinstance(exc, KeyError) and len(exc.args) == 1 and isinstance(exc.args[0], str):
        return exc.args[0]
    return str(exc)


#: The help of ``--stance-sway`` (replay, serve, the demo).
STANCE_SWAY_HELP = ("walking stances sway and vibrate as a real foot's do (stance_sway.StanceSway, "
                    "measured on the shared walks): the module's ZARU then seldom holds while walking "
                    "and its heading drifts, as on a real module; on by default (--no-stance-sway: every "
                    "walking stance perfectly still, the ZARU re-learning the gyros' bias in each)")


def add_stance_sway_argument(p: argparse.ArgumentParser | argparse._ArgumentGroup) -> None:
    """``--stance-sway`` / ``--no-stance-sway`` (replay, serve, the demo): ``args.stance_sway`` is True,
    False or None (not given: :data:`firmware_sim.sensors.stance_sway.STANCE_SWAY_DEFAULT`), as the
    sources' *stance_sway* takes it."""
    p.add_argument("--stance-sway", action=argparse.BooleanOptionalAction, default=None,
                   help=STANCE_SWAY_HELP)


def stance_note(swaying: bool) -> str:
    """``", stance sway"`` or ``", still stances"``: how a simulated walk's stances move, for a run's
    announcement, so that its result can be reproduced whatever the default."""
    return ", stance sway" if swaying else ", still stances"


def _stance_sway_note(source: object) -> str:
    """:func:`stance_note` of simulated *source*."""
    trajectory = getattr(source, "trajectory", None)
    return stance_note(getattr(trajectory, "stance_sway", None) is not None)


def add_receiver_arguments(p: argparse.ArgumentParser | argparse._ArgumentGroup) -> None:
    """``--origin`` and ``--gps-outage``: where a simulated GPS receiver's walk is on the globe, and
    when it has no fix (replay's ``--gps``, serve's ``--gps-pty``)."""
    p.add_argument("--origin", metavar="LAT,LON[,ALT]", default=None,
                   help="where the scenario is on the globe (WGS84; default 59.3498,18.0707,30: KTH, "
                        "Stockholm)")
    p.add_argument("--gps-outage", action="append", default=[], metavar="START:END",
                   help="seconds of the walk without a fix (END may be 'end'); repeatable")


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("files", nargs="*", type=Path, metavar="FILE",
                   help="recording(s) to replay (OpenShoe walk .txt or our CSV), each at its own rate")
    p.add_argument("--scenario", metavar="NAME",
                   help="replay a simulated scenario instead (see firmware_sim.sensors.scenarios)")
    out = p.add_mutually_exclusive_group(required=True)
    out.add_argument("--wire", type=Path, metavar="OUT",
                     help="write the bytes the module transmitted (Bluetooth) to OUT (one replay)")
    out.add_argument("--wire-dir", type=Path, metavar="DIR",
                     help="replay every FILE (or the scenario with every seed of --seeds) in this process, "
                          "writing DIR/<name>.bin each, and print a summary table")
    p.add_argument("--seed", type=seed_number, default=0, help="seed of the simulated scenario (default 0)")
    p.add_argument("--module", type=module_number, metavar="N", default=None, help=MODULE_HELP)
    add_stance_sway_argument(p)
    p.add_argument("--seeds", metavar="A:B",
                   help="with --scenario and --wire-dir: seeds A … B-1 (also N or N,M,…)")
    p.add_argument("--rate", type=rate_hz, default=1000.0,
                   help=f"loop/sample rate of a simulated scenario [Hz] (default 1000; at most "
                        f"{MAX_RATE_HZ:g})")
    p.add_argument("--host", choices=HOSTS, default="plain",
                   help="the replayed host: plain sends 0x34 only (default); fusion then asks for each "
                        "step's swing time and the module's serial number (protocol.extensions.FUSION_SETUP)")
    p.add_argument("--height-compensation", action="store_true",
                   help="the replayed host turns the module's height compensation (function 0x25) on when "
                        "the first step packet arrives")
    p.add_argument("--calibrate-mag", action="store_true",
                   help="with --host fusion (one replay, or every run of --wire-dir): the replayed host "
                        "runs the in-situ magnetometer "
                        "calibration (hostlib.calibration.wiggle): it streams the magnetometers after the "
                        "fusion set-up "
                        "and stops the stream at the first step longer than 0.5 m (walk a scenario that "
                        "starts with a wiggle, e.g. navshoe-calibration); openshoe-host replay OUT --compass "
                        "--calibrate-mag then fits the calibration from the capture")
    p.add_argument("--profile", choices=sorted(PROFILES), default=None,
                   help="the sensor profile (the filter's noise figures) to navigate with; default: the "
                        "recording's sensor (an OpenShoe walk: 3dm-gx2; a CSV: the module's own, mimu22bt), "
                        "a simulated module's own for --scenario. Printed with the run")
    p.add_argument("--gps", type=Path, metavar="OUT.nmea",
                   help="with --scenario and --wire: also write what a GPS receiver on the walker says, "
                        "GGA and RMC at 1 Hz (firmware_sim/sensors/gps.py: a few metres RMS, correlated over "
                        "minutes)")
    add_receiver_arguments(p)
    p.add_argument("--feet", type=int, choices=(1, 2), default=1,
                   help="with --scenario and --wire: 2 puts a module on each foot of the walker (each "
                        "its own errors and seed; --module N: modules 2N and 2N+1) and writes OUT.left and "
                        "OUT.right, their truth and the body's (OUT.body.truth.csv)")
    p.add_argument("--table", type=Path, metavar="CSV",
                   help="with --wire-dir: also write the summary, one row per run, as CSV")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar or notices on stderr")


def check_arguments(args: argparse.Namespace) -> str | None:
    """What is wrong with a combination argparse cannot express, or None."""
    if bool(args.files) == (args.scenario is not None):
        return "give recording FILE(s) or --scenario NAME (one of them)"
    if args.wire is not None and len(args.files) > 1:
        return "several files replay into a folder: use --wire-dir DIR"
    if args.wire is not None and (args.seeds is not None or args.table is not None):
        return "--seeds and --table go with --wire-dir"
    if args.seeds is not None and args.scenario is None:
        return "--seeds goes with --scenario"
    if getattr(args, "profile", None) is not None and args.wire_dir is not None:
        return "--profile goes with --wire (one replay); many runs take each recording's own sensor profile"
    if args.module is not None and args.scenario is None:
        return "--module goes with --scenario: a recording carries its own module's sensors"
    if getattr(args, "stance_sway", None) is not None and args.scenario is None:
        return "--stance-sway goes with --scenario: a recording carries its own foot's motion"
    gps = getattr(args, "gps", None) is not None
    if gps and (args.scenario is None or args.wire is None):
        return "--gps goes with --scenario and --wire: the receiver follows a simulated walk's truth"
    if not gps and (getattr(args, "origin", None) is not None or getattr(args, "gps_outage", None)):
        return "--origin and --gps-outage go with --gps"
    if getattr(args, "feet", 1) == 2 and (args.scenario is None or args.wire is None):
        return "--feet 2 goes with --scenario and --wire: a walker's two feet are simulated"
    if getattr(args, "calibrate_mag", False) and args.host != "fusion":
        return ("--calibrate-mag goes with --host fusion: the calibration streams the magnetometers "
                "after the fusion set-up")
    if getattr(args, "calibrate_mag", False) and getattr(args, "feet", 1) == 2:
        return ("--calibrate-mag calibrates one module: the wiggle turns one shoe while you stand on the "
                "other; replay each foot's wiggle alone")
    return _output_refusal(args)


def _output_refusal(args: argparse.Namespace) -> str | None:
    """Why a file the replay writes could not be, or None: checked before anything runs, so that no
    walk is replayed for a file it cannot write."""
    from hostlib.inputs import output_refusal

    for flag in ("wire", "gps", "table"):
        refusal = output_refusal(getattr(args, flag, None), f"--{flag}")
        if refusal is not None:
            return refusal
    wire_dir = getattr(args, "wire_dir", None)
    if wire_dir is not None and wire_dir.exists() and not wire_dir.is_dir():
        return f"--wire-dir {wire_dir} is a file, not a folder"
    return None


def _gps_errors(args: argparse.Namespace):
    """The receiver's origin and errors from the command line (ValueError naming the problem)."""
    from firmware_sim.sensors.gps import DEFAULT_ORIGIN, GpsErrors, parse_outages
    from hostlib.aids.geodesy import parse_origin

    origin = DEFAULT_ORIGIN if args.origin is None else parse_origin(args.origin)
    return origin, GpsErrors(outages=parse_outages(args.gps_outage))


def _write_gps(args: argparse.Namespace, t, pos, vel, origin, errors) -> None:
    """The receiver on the walker (sample times *t*, NED *pos* and *vel*) into ``--gps``."""
    from firmware_sim.sensors.gps import scenario_errors, simulate_fixes, write_nmea

    errors = scenario_errors(errors, args.scenario, t, pos)
    fixes = simulate_fixes(t, pos, vel, origin, errors, seed=args.seed)
    write_nmea(args.gps, fixes, errors=errors)
    if not args.quiet:
        valid = sum(f.valid for f in fixes)
        print(f"GPS: {valid} fixes, {len(fixes) - valid} epochs without a fix, origin "
              f"{origin[0]:.6f},{origin[1]:.6f},{origin[2]:g} → {args.gps}", file=sys.stderr)


def main(args: argparse.Namespace) -> int:
    """One replay: ``FILE --wire OUT`` or ``--scenario NAME --wire OUT`` (``--feet 2``: both feet)."""
    if getattr(args, "feet", 1) == 2:
        return _main_feet(args)
    truth = gps = None
    try:
        if args.scenario is not None:
            from firmware_sim.sensors.imu_array import make_source

            if getattr(args, "gps", None) is not None:
                gps = _gps_errors(args)  # a bad origin or outage is refused before the run
            source = make_source(args.scenario, seed=args.seed, rate_hz=args.rate, module=args.module,
                                 stance_sway=getattr(args, "stance_sway", None))
            truth = source.truth
            module = "" if args.module is None else f"module {args.module}, "
            name = (f"scenario {args.scenario!r} ({module}seed {args.seed}, {args.rate:g} Hz"
                    f"{_stance_sway_note(source)})")
        else:
            source = load_walk(args.files[0])
            name = str(args.files[0])
            if source.filled_samples and not args.quiet:
                print(f"{name}: {source.filled_samples} samples the recorder skipped (gaps in its sample "
                      f"numbers, the longest {source.longest_gap}) are served interpolated",
                      file=sys.stderr)
    except start_errors() as e:
        print(f"openshoe-emu replay: {error_text(e)}", file=sys.stderr)
        return 2
    _replay_to(args, source, name, args.module, args.wire)
    if truth is not None:
        write_truth_files(source, args.wire, module_serial(args.module))
    if gps is not None:
        _write_gps(args, truth.t, truth.pos, truth.vel, *gps)
    return 0


def _main_feet(args: argparse.Namespace) -> int:
    """``--scenario NAME --feet 2 --wire OUT``: a module on each foot of one walker, replayed one
    after the other into ``OUT.left`` and ``OUT.right``, each with its truth, and the body's."""
    from firmware_sim.sensors.feet import SIDES, body_truth, write_body_truth
    from firmware_sim.sensors.imu_array import make_feet_sources

    try:
        gps = _gps_errors(args) if getattr(args, "gps", None) is not None else None
        sources = make_feet_sources(args.scenario, seed=args.seed, rate_hz=args.rate, walker=args.module,
                                    stance_sway=getattr(args, "stance_sway", None))
    except (KeyError, ValueError) as e:
        print(f"openshoe-emu replay: {error_text(e)}", file=sys.stderr)
        return 2
    for side in SIDES:
        source = sources[side]
        wire = args.wire.with_name(f"{args.wire.name}.{side}")
        name = (f"scenario {args.scenario!r}, {side} foot (module {source.module}, seed {source.seed}, "
                f"{args.rate:g} Hz{_stance_sway_note(source)})")
        _replay_to(args, source, name, source.module, wire)  # each foot's own serial number
        write_truth_files(source, wire, module_serial(source.module))
    body = body_truth(sources["left"].truth, sources["right"].truth)
    write_body_truth(body, args.wire.with_name(args.wire.name + ".body.truth.csv"))
    if gps is not None:
        t, pos, vel, _yaw = body
        _write_gps(args, t, pos, vel, *gps)
    return 0


def _replay_to(args: argparse.Namespace, source: SensorSource, name: str, module: int | None,
               wire: Path) -> None:
    """Replay *source* as the command line says and write its bytes to *wire*."""
    announce = None if args.quiet else say
    profile = profile_for(source, args.profile)
    if not args.quiet:
        print(f"{name}: {profile.summary()}", file=sys.stderr)
    prepare_compiled_path(announce)  # before the clock: the time below is the replay's own
    t0 = time.monotonic()
    with progress_bar(source_length(source), name, "samples", quiet=args.quiet,
                      unit_scale=True) as bar:
        config = profile.configure(ModuleConfig(rate_hz=float(source.rate_hz),
                                                mcu_serial=module_serial(module)))
        data = run_replay(source, config=config, progress=lambda done, _total: bar.update(done - bar.n),
                          announce=announce, host=args.host, height_compensation=args.height_compensation,
                          calibrate_mag=getattr(args, "calibrate_mag", False))
    wire.write_bytes(data)
    if not args.quiet:
        elapsed = time.monotonic() - t0
        print(f"{name}: {data.samples} samples in {elapsed:.1f} s, {data.packets} packets, "
              f"{len(data)} bytes → {wire}", file=sys.stderr)
