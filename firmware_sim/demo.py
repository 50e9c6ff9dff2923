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

Nothing here needs the shared recordings. Run ``python -m firmware_sim.demo --help``.
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

from hostlib.tracking import StepTracker
from protocol.ids import StateId

from .link import make_link
from .module import Module, ModuleConfig
from .port import IdealPort
from .sensors.playback import served_source
from .transports.pacer import Pacer
from .transports.pty import PtyEndpoint

#: Virtual seconds the module keeps running after the route ends (the last step's reset).
TAIL_S = 1.5


@dataclass
class DemoResult:
    """What the demo measured."""

    steps: int
    true_steps: int
    distance_m: float
    true_distance_m: float
    closure_error_m: float  #: final position vs the true final position, horizontal
    loop_closure_m: float  #: final position vs the start (the route is a closed loop)
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
        lines = [
            "",
            "OpenShoe demo — summary",
            f"  steps tracked          {self.steps}   (the walker took {self.true_steps})",
            f"  distance               {self.distance_m:8.2f} m   (true {self.true_distance_m:.2f} m)",
            f"  error at the end       {self.closure_error_m:8.2f} m   ({rel:.2f} % of the distance; "
            f"vs ground truth, horizontal)",
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
    p = argparse.ArgumentParser(prog="python -m firmware_sim.demo", description=__doc__.split("\n\n")[0])
    p.add_argument("--scenario", default="default", help="route or recipe (default: the built-in route)")
    p.add_argument("--seed", type=int, default=0, help="sensor and link seed (default 0)")
    p.add_argument("--link", choices=["bt", "usb", "ideal"], default="bt", help="link model (default bt)")
    p.add_argument("--speed", type=float, default=0.0,
                   help="module time per wall time; 0 = as fast as the CPU allows (default)")
    p.add_argument("--out", default="out/demo",
                   help="folder for track.png and track.csv (default out/demo)")
    p.add_argument("--no-plot", action="store_true", help="skip the PNG (no matplotlib needed)")
    p.add_argument("--timeout", type=float, default=900.0, help="give up after this many wall seconds")
    p.add_argument("-q", "--quiet", action="store_true", help="only the summary")
    return p


def _say(quiet: bool, *parts: object) -> None:
    if not quiet:
        print(*parts, flush=True)


def run_demo(args: argparse.Namespace) -> DemoResult:
    """Run the demo as *args* say; returns the measurements (raises on failure)."""
    from hostlib import Device

    from .sensors import make_source

    quiet = args.quiet
    t_start = time.monotonic()
    _say(quiet, f"[1/4] simulating the sensors of a foot walking the {args.scenario!r} route "
         f"(seed {args.seed}) …")
    source = make_source(args.scenario, seed=args.seed)
    truth = source.truth
    route_s = len(source) / source.rate_hz
    stances = truth.stance_positions
    _say(quiet, f"      {route_s:.0f} s of walking, {truth.distance_m():.1f} m, {len(stances) - 1} steps; "
         f"built in {time.monotonic() - t_start:.1f} s")

    link = make_link(args.link, seed=args.seed)
    # after the route the walker stands still (the sensors do not go silent)
    # and the route starts when the host starts tracking (the first sensor read), so the
    # result does not depend on how fast the host came
    played = served_source(source)
    module = Module(ModuleConfig(rate_hz=source.rate_hz), played,
                    usb_port=IdealPort(connected=False), bt_port=link)
    # The route's steps are those counted up to TAIL_S after its end: note the module's step
    # counter at that tick (inside the loop, so it is exact however fast virtual time runs).
    route_ticks = int(round((route_s + TAIL_S) * source.rate_hz))
    final: dict[str, int] = {}
    module_step = module.step

    def step_and_mark_the_end() -> None:
        module_step()
        start = played.source.start
        if "counter" not in final and start is not None and module.clock.ticks >= start + route_ticks:
            final["counter"] = int(module.memory[StateId.STEP_COUNTER])

    module.step = step_and_mark_the_end  # type: ignore[method-assign]
    tmp = tempfile.TemporaryDirectory(prefix="openshoe-demo-")
    pty_path = Path(tmp.name) / "openshoe0"
    endpoint = PtyEndpoint(link, pty_path)
    pacer = Pacer(module, [endpoint], speed=args.speed)
    pacer.start()
    wall0 = time.monotonic()
    tracker = StepTracker()
    try:
        _say(quiet, f"[2/4] emulated module on the Bluetooth link, serial device {pty_path}")
        with Device(str(pty_path), ack_timeout=2.0) as dev:
            _say(quiet, "[3/4] host: step-wise dead reckoning (command 0x34), acking every step packet …")
            dev.start_stepwise_dead_reckoning()
            deadline = wall0 + args.timeout
            last_report = 0.0
            while True:
                ev = dev.recv_step(timeout=0.2)
                now = time.monotonic()
                if pacer.error is not None:
                    raise RuntimeError(f"the emulated module stopped: {pacer.error!r}")
                if now > deadline:
                    raise TimeoutError(f"demo did not finish within {args.timeout:.0f} s")
                end = final.get("counter")
                if ev is not None:
                    if end is not None and ev.step.counter > end:
                        break  # a stand-still step after the route
                    tracker.add(ev.step)
                    if not quiet and now - last_report > 1.0:
                        last_report = now
                        x, y = tracker.position[0], tracker.position[1]
                        print(f"      t={pacer.status().virtual_s:6.1f} s  step {ev.step.counter:4d}  "
                              f"at ({x:7.2f}, {y:7.2f}) m", flush=True)
                if end is not None and (tracker.last_counter or 0) >= end:
                    break  # every step of the route has arrived
            track = tracker.track
            gaps, missing = len(track.gaps), track.missing
        wall = time.monotonic() - wall0
        virtual = route_s + TAIL_S
    finally:
        pacer.stop()
        tmp.cleanup()

    # ground truth in the track's frame: origin at the first rest, x along the initial heading
    psi0 = float(truth.euler[0, 2])
    c, s = math.cos(-psi0), math.sin(-psi0)
    rot = np.array([[c, -s], [s, c]])
    true_end = rot @ (stances[-1, :2] - stances[0, :2])
    cov = track.final_covariance
    result = DemoResult(
        steps=len(track),
        true_steps=len(stances) - 1,
        distance_m=float(track.distance),
        true_distance_m=truth.distance_m(),
        closure_error_m=track.error_to(true_end),
        loop_closure_m=track.closure_error(),
        sigma_m=track.closure_sigma(),
        heading_sigma_deg=math.degrees(math.sqrt(max(0.0, float(cov[3, 3])))),
        virtual_s=virtual,
        wall_s=wall,
        gaps=gaps,
        missing=missing,
        png=None,
        csv=None,
        closed_loop=bool(np.linalg.norm(stances[-1, :2] - stances[0, :2]) < 1.0),
    )
    _say(quiet, "[4/4] writing the track …")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    from hostlib.export import write_csv

    result.csv = out / "track.csv"
    write_csv(track, result.csv)
    if not args.no_plot:
        from hostlib.plot import plot_track

        result.png = plot_track(
            track, out / "track.png", reference=stances,
            title=f"OpenShoe demo: {args.scenario} route, {result.steps} steps, {result.distance_m:.0f} m, "
                  f"end error {result.closure_error_m:.2f} m",
        )
    return result


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
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
