"""`make demo`: an emulated module walks the built-in route; a host tracks it through a pty.

What happens, end to end, as with a real module:

1. the sensors of a foot walking the ``default`` route (two laps of a 40 × 20 m
   block over a footbridge) are simulated, with the ground truth kept aside;
2. an emulated module reads them, behind a Bluetooth link model, on a real pty
   (a virtual serial device with a path, like ``/dev/rfcomm0``), running in
   virtual time faster than real time;
3. a host — :class:`hostlib.Device` through pyserial, exactly what an app uses
   on hardware — starts step-wise dead reckoning, acknowledges every step
   packet and sums the steps into a track with its covariance;
4. the summary compares the track with the ground truth, and the track is
   drawn to a PNG.

Nothing here needs the shared recordings. Run ``python -m firmware_sim.app.demo --help``.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from tqdm import tqdm

from firmware_sim.mcu.imu_bus import SensorSource
from firmware_sim.nav.warmup import prepare_compiled_path
from firmware_sim.sensors.playback import served_source
from firmware_sim.sensors.truth import GroundTruth
from firmware_sim.transports.factory import EmulatorSettings, build
from firmware_sim.transports.pacer import Pacer
from hostlib.cli.checks import seconds
from hostlib.track.steps import StepTracker, Track, is_motion_step
from protocol.ids import StateId

from .batch import (
    MODULE_HELP,
    add_stance_sway_argument,
    module_number,
    seed_number,
    speed_factor,
    stance_note,
)
from .progress import progress_bar

#: Virtual seconds the module keeps running after the route ends (the last step's reset).
TAIL_S = 1.5


@dataclass
class DemoResult:
    """What the demo measured."""

    step_packets: int  #: step packets summed: one per INS reset, standing still included
    motion_steps: int  #: of those, the steps that moved the foot (hostlib.track.steps.is_motion_step)
    true_motion_steps: int  #: the walker's steps, counted by the same rule on the ground truth
    distance_m: float
    true_distance_m: float
    closure_error_m: float  #: final position vs the true final position, horizontal
    loop_closure_m: float  #: final position vs the start (the route is a closed loop)
    height_error_m: float  #: final height vs the true final height (up positive)
    sigma_m: float  #: 1σ of the final horizontal position, worst direction
    heading_sigma_deg: float
    virtual_s: float
    wall_s: float
    gaps: int
    missing: int
    png: Path | None
    csv: Path | None
    closed_loop: bool = False  #: the true route ends where it started

    def summary(self) -> str:
        ratio = self.virtual_s / self.wall_s if self.wall_s else 0.0
        rel = 100.0 * self.closure_error_m / self.true_distance_m if self.true_distance_m else math.nan
        standing = self.step_packets - self.motion_steps
        lines = [
            "",
            "OpenShoe demo — summary",
            f"  steps with motion      {self.motion_steps:5d}      "
            f"(the walker took {self.true_motion_steps})",
            f"  step packets           {self.step_packets:5d}      (one per INS reset; {standing} of them "
            f"while standing still)",
            f"  distance               {self.distance_m:8.2f} m   (true {self.true_distance_m:.2f} m)",
            f"  error at the end       {self.closure_error_m:8.2f} m   ({rel:.2f} % of the distance; "
            f"vs ground truth, horizontal)",
            f"  height error           {self.height_error_m:+8.2f} m   (end, vs ground truth)",
        ]
        if self.closed_loop:
            lines.append(f"  loop closure           {self.loop_closure_m:8.2f} m   "
                         f"(end to start: the route is a closed loop)")
        lines += [
            f"  final 1σ               {self.sigma_m:8.2f} m   (worst direction), "
            f"heading {self.heading_sigma_deg:.2f}°",
            f"  link                   {self.gaps} gaps, {self.missing} steps missing",
            f"  time                   {self.virtual_s:.1f} s of walking in {self.wall_s:.1f} s "
            f"({ratio:.1f}× real time)",
        ]
        if self.png:
            lines.append(f"  track picture          {self.png}")
        if self.csv:
            lines.append(f"  track CSV              {self.csv}")
        return "\n".join(lines)


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m firmware_sim.app.demo", description=__doc__.split("\n\n")[0])
    p.add_argument("--scenario", default="default", help="route or recipe (default: the built-in route)")
    p.add_argument("--seed", type=seed_number, default=0, help="sensor and link seed (default 0)")
    p.add_argument("--module", type=module_number, metavar="N", default=None, help=MODULE_HELP)
    add_stance_sway_argument(p)
    p.add_argument("--link", choices=["bt", "usb", "ideal"], default="bt", help="link model (default bt)")
    p.add_argument("--speed", type=speed_factor, default=0.0,
                   help="module time per wall time; 0 (or inf) = as fast as the CPU allows (default)")
    p.add_argument("--out", default="out/demo",
                   help="folder for track.png and track.csv (default out/demo)")
    p.add_argument("--no-plot", action="store_true", help="skip the PNG (no matplotlib needed)")
    p.add_argument("--timeout", type=seconds, default=900.0, help="give up after this many wall seconds")
    p.add_argument("-q", "--quiet", action="store_true", help="only the summary")
    return p


class _Say:
    """The demo's narration on stdout (nothing with --quiet); safe beside a progress bar."""

    def __init__(self, quiet: bool):
        self.quiet = quiet

    def __call__(self, *parts: object) -> None:
        if not self.quiet:
            tqdm.write(" ".join(str(p) for p in parts), file=sys.stdout)


@dataclass
class _Route:
    """The simulated walk: its sensor source, ground truth and length in time."""

    source: SensorSource
    truth: GroundTruth
    seconds: float

    @property
    def ticks(self) -> int:
        """Loop cycles from the route's start to its last step's reset (TAIL_S after its end)."""
        return int(round((self.seconds + TAIL_S) * self.source.rate_hz))


def _simulate(args: argparse.Namespace, say: _Say) -> _Route:
    from firmware_sim.sensors import make_source
    from firmware_sim.sensors.stance_sway import stance_sway_on

    t0 = time.monotonic()
    module = "" if args.module is None else f"module {args.module}, "
    sway = stance_note(stance_sway_on(args.stance_sway))
    say(f"[1/4] simulating the sensors of a foot walking the {args.scenario!r} route "
        f"({module}seed {args.seed}{sway}) …")
    source = make_source(args.scenario, seed=args.seed, module=args.module, stance_sway=args.stance_sway)
    route = _Route(source, source.truth, len(source) / source.rate_hz)
    say(f"      {route.seconds:.0f} s of walking, {route.truth.distance_m():.1f} m, "
        f"{true_motion_steps(route.truth)} steps; built in {time.monotonic() - t0:.1f} s")
    return route


class _EmulatedModule:
    """The module on a Bluetooth link model behind a pty, run by a pacer; a context manager.

    Built like every served module (:func:`firmware_sim.transports.factory.build`), playing
    the route the demo simulated.

    The route starts when the host starts tracking (the module's first sensor read), and
    after it the walker stands still. :attr:`last_step` is the module's step counter
    :data:`TAIL_S` after the route's end — noted inside the loop, so it is exact however
    fast virtual time runs.
    """

    def __init__(self, route: _Route, args: argparse.Namespace):
        self.played = served_source(route.source)
        self._tmp = tempfile.TemporaryDirectory(prefix="openshoe-demo-")
        self.pty_path = Path(self._tmp.name) / "openshoe0"
        settings = EmulatorSettings(scenario=args.scenario, seed=args.seed, module=args.module,
                                    stance_sway=args.stance_sway, link=args.link, interface="bt",
                                    speed=args.speed, pty=str(self.pty_path))
        try:
            built = build(settings, sensors=self.played)
        except BaseException:
            self._tmp.cleanup()
            raise
        self.link = built.link
        self.module = built.module
        self.route_ticks = route.ticks
        self.last_step: int | None = None
        self.pacer = Pacer(self.module, built.endpoints, speed=settings.speed)
        self._step = self.module.step
        self.module.step = self._step_and_note_the_end  # type: ignore[method-assign]

    def _step_and_note_the_end(self) -> None:
        self._step()
        start = self.played.source.start
        ticks = self.module.clock.ticks
        if self.last_step is None and start is not None and ticks >= start + self.route_ticks:
            self.last_step = int(self.module.memory[StateId.STEP_COUNTER])

    def route_seconds(self) -> float:
        """Virtual seconds since the route started (0 before the host started tracking)."""
        start = self.played.source.start
        clock = self.module.clock
        return 0.0 if start is None else max(0.0, (clock.ticks - start) / clock.rate_hz)

    def __enter__(self) -> _EmulatedModule:
        self.pacer.start(announce=None)  # prepared before (run_demo), with the demo's own narration
        return self

    def __exit__(self, *exc: object) -> None:
        try:
            self.pacer.stop()
        finally:
            self._tmp.cleanup()


def _track(emu: _EmulatedModule, route: _Route, args: argparse.Namespace, say: _Say) -> Track:
    """Be the host: start step-wise dead reckoning, sum every step of the route; returns the track."""
    from hostlib import Device

    tracker = StepTracker()
    deadline = time.monotonic() + args.timeout
    say(f"[2/4] emulated module on the Bluetooth link, serial device {emu.pty_path}")
    with Device(str(emu.pty_path), ack_timeout=2.0) as dev, \
            progress_bar(round(route.seconds, 1), "      walking", "s", quiet=args.quiet,
                         bar_format="{desc} {percentage:3.0f}%|{bar}| {n:.0f}/{total:.0f} s of the route "
                                    "[{elapsed}<{remaining}, {rate_fmt}]") as bar:
        say("[3/4] host: step-wise dead reckoning (command 0x34), acking every step packet …")
        dev.start_stepwise_dead_reckoning()
        while True:
            ev = dev.recv_step(timeout=0.2)
            if emu.pacer.error is not None:
                raise RuntimeError(f"the emulated module stopped: {emu.pacer.error!r}")
            if time.monotonic() > deadline:
                raise TimeoutError(f"demo did not finish within {args.timeout:.0f} s")
            bar.update(min(emu.route_seconds(), route.seconds) - bar.n)
            end = emu.last_step
            if ev is not None:
                if end is not None and ev.step.counter > end:
                    break  # a stand-still step after the route
                tracker.add(ev.step)
            if end is not None and (tracker.last_counter or 0) >= end:
                break  # every step of the route has arrived
    return tracker.track


def true_motion_steps(truth: GroundTruth) -> int:
    """The walker's steps counted by the host's rule (:func:`hostlib.track.steps.is_motion_step`):
    from each rest of the foot to the next."""
    poses = truth.stance_poses
    moves = np.hstack([np.diff(poses[:, :3], axis=0), np.diff(poses[:, 5:6], axis=0)])
    return sum(is_motion_step(m) for m in moves)


def _measure(track: Track, route: _Route, wall_s: float) -> DemoResult:
    truth = route.truth
    ref = truth.stances_in_start_frame()
    cov = track.final_covariance
    return DemoResult(
        step_packets=len(track),
        motion_steps=track.motion_steps,
        true_motion_steps=true_motion_steps(truth),
        distance_m=float(track.distance),
        true_distance_m=truth.distance_m(),
        closure_error_m=track.error_to(ref[-1, :2]),
        loop_closure_m=track.closure_error(),
        height_error_m=-(float(track.final_pose[2]) - float(ref[-1, 2])),
        sigma_m=track.closure_sigma(),
        heading_sigma_deg=math.degrees(math.sqrt(max(0.0, float(cov[3, 3])))),
        virtual_s=route.seconds + TAIL_S,
        wall_s=wall_s,
        gaps=len(track.gaps),
        missing=track.missing,
        png=None,
        csv=None,
        closed_loop=bool(np.linalg.norm(ref[-1, :2]) < 1.0),
    )


def _write(result: DemoResult, track: Track, route: _Route, args: argparse.Namespace) -> None:
    from hostlib.files.export import write_csv

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    result.csv = out / "track.csv"
    write_csv(track, result.csv)
    if not args.no_plot:
        from hostlib.files.plot import plot_track

        result.png = plot_track(
            track, out / "track.png", reference=route.truth.stances_in_start_frame(),
            title=f"OpenShoe demo: {args.scenario} route, {result.motion_steps} steps, "
                  f"{result.distance_m:.0f} m, end error {result.closure_error_m:.2f} m",
        )


def run_demo(args: argparse.Namespace) -> DemoResult:
    """Run the demo as *args* say; returns the measurements (raises on failure)."""
    say = _Say(args.quiet)
    route = _simulate(args, say)
    prepare_compiled_path(announce=say)  # before the module's clock starts: no host waits on it
    with _EmulatedModule(route, args) as emu:
        wall0 = time.monotonic()
        track = _track(emu, route, args, say)
        wall = time.monotonic() - wall0
    result = _measure(track, route, wall)
    say("[4/4] writing the track …")
    _write(result, track, route, args)
    return result


def refusal(args: argparse.Namespace) -> str | None:
    """Why the demo would not run as *args* say, said before anything is walked, or None: a
    scenario that is no name and no recipe (the piece refused and its range), an ``--out`` that is
    no folder."""
    from firmware_sim.sensors.scenarios import RecipeError, check

    try:
        check(args.scenario)
    except RecipeError as exc:
        return f"--scenario: {exc}"
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        return f"--out {out} is a file: name a folder for track.png and track.csv"
    return None


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    why = refusal(args)
    if why is not None:
        print(f"demo: {why}", file=sys.stderr)
        return 2
    try:
        result = run_demo(args)
    except KeyboardInterrupt:
        print("\ndemo interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # noqa: BLE001 - one clear line for a user, not a traceback
        print(f"demo failed: {type(exc).__name__}: {exc}", file=sys.stderr)
        return 1
    print(result.summary())
    return 0


if __name__ == "__main__":
    sys.exit(main())
