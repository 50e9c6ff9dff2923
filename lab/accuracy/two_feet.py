"""Two feet, simulated (shared/spec/aids.md §6): a module on each foot of one walker.

Every walk goes through the emulated modules exactly as a user's would — each foot's module
replayed with the fusion host (``openshoe-emu replay --scenario NAME --feet 2 --host fusion``:
each step packet carries its T_INT_K), both captures decoded by their own host session and fused
in module-time order by :class:`hostlib.fusion.feet.TwoFeetTracker` (``openshoe-host replay LEFT RIGHT``).
Four estimates of each walk: each foot's single-module track (``left``, ``right``), the midpoint of
the two (``average``, Bachmann et al.), and the constrained fusion's body (``fused``).

* :func:`straight_rows` — **the module paper's experiment**: fifty 100 m straight walks (scenario
  ``walk``, facing north). Per estimate the end error along the track (length), across it and in
  height, in metres and in % of the 100 m; :func:`plot_end_points` draws the end points with their
  1σ ellipses (the paper's Fig. 7).
* :func:`loop_rows` — **Bachmann's experiment**: a 400 m track walked once per seed; the closure
  (distance from the start at the end, horizontal) per foot, of the average and of the fusion.
* :func:`heading_run` — **the feet's headings over 20 minutes**: five laps of the 400 m track
  (≈ 22 min), with and without the constraint, and constrained with each module's errors held
  (the emulated module's priors, its heading drift among them); the heading difference between
  the feet and their separation after every step (:func:`plot_heading`). With ``drop_s``, the
  right foot's link is lost for that long mid-walk: its packets in that window never reach the
  host, so its counter jumps and the fused track continues on the left foot (the gap and the
  restart are reported).
* :func:`aids_rows` — **NavShoe's outage experiment with two feet**: the ``navshoe-outage`` loop
  (1 km outdoors, GPS for the first 400 m) walked with a module on each foot, the receiver on the
  body, the per-step compass and the declination prior chosen as :mod:`.navshoe` chooses them
  (each foot's compass with its own shoe's iron removed). Per walker the error at the end of the
  outage of :data:`AIDED_ESTIMATES`: the fused body with compass and GPS, the average of the two
  feet's aided single tracks, the fused body without aids (given the true initial heading, like
  NavShoe's ``plain``), the left foot's own aided track, the aided joint filter without the
  inter-foot constraint (both feet and D in one filter, never projected), and the fused body with
  each foot's module's errors held at the priors of the emulated module on a real foot's swaying
  stance, the gyros' warm-up among them (:data:`hostlib.fusion.module_errors.EMULATED_MODULE_SWAYING`: the
  estimate for swaying stances, the default); the declination each learned.
* :func:`drift_rows` — **Bachmann's drift correction with two feet**: walker :data:`DRIFT_WALKER`
  walks the 400 m track once per seed, with the same two modules every time (a module's
  systematic errors belong to the module, its noise and in-run drift to the walk). Leave-one-out:
  each loop is re-fused with each foot's module calibrated (:func:`hostlib.calibration.drift.calibrate`) on
  the other loops' single-module tracks of that foot; its closure per foot, average and fusion,
  with and without the correction.

A single foot's estimates start at its own start (the left foot half the step width left of the
body); errors compare each with the truth of the same point. (An aided single foot starts half the
step width left of the body as if facing north, before its first compass reading turns it about
that start: a few centimetres from its true start, against end errors of metres.)
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .runs import stance_words

if TYPE_CHECKING:
    from firmware_sim.sensors.config import SensorConfig

__all__ = ["AIDED_ESTIMATES", "DRIFT_WALKER", "ESTIMATES", "HEADING_SCENARIO", "LOOP_SCENARIO",
           "STRAIGHT_SCENARIO", "FeetWalk", "aids_rows", "aids_run", "aids_summary", "drift_loop",
           "drift_rows", "drift_summary", "drop_packets", "feet_captures", "feet_walk", "heading_run",
           "loop_rows", "loop_summary", "plot_end_points", "plot_heading", "straight_rows",
           "straight_summary"]

STRAIGHT_SCENARIO = "walk"  # stand 3 s, 100 m north, stand 2 s
LOOP_SCENARIO = "track400"  # one lap of a 400 m running track, turning left
HEADING_SCENARIO = "stand:5+track400:5+stand:5"  # 2 km, about 22 minutes
ESTIMATES = ("left", "right", "average", "fused")
#: What :func:`aids_run` compares on NavShoe's outage loop (module docstring).
AIDED_ESTIMATES = ("fused compass+gps", "average compass+gps", "fused plain", "left compass+gps",
                   "unconstrained compass+gps", "fused compass+gps module errors and warm-up")
#: The walker of :func:`drift_rows`: every loop is walked with this walker's two modules.
DRIFT_WALKER = 1


@dataclass
class FeetWalk:
    """One walker's walk as the host saw it."""

    tracker: Any  #: hostlib.fusion.feet.TwoFeetTracker (constrained)
    free: Any  #: the same steps without the constraint
    truth: dict[str, Any]  #: side → GroundTruth
    dropped: int = 0  #: packets of the right foot that never reached the host
    held: Any = None  #: constrained, each module's errors held (None: not asked for)


def drop_packets(capture: bytes, start_s: float, end_s: float) -> tuple[bytes, int]:
    """*capture* without the step packets whose step time lies in [start_s, end_s): what a host
    receives when the link is down that long and the module's queue overflows. Returns the bytes
    and the number of packets dropped."""
    from hostlib.events import StepEvent
    from hostlib.files.replay import implied_commands
    from hostlib.fusion.feet import FootTracker
    from hostlib.link.session import HostSession
    from protocol.frames import StatePacket
    from protocol.stream import decode_all

    # the host's own decoding gives each step's packet number and (through its tracker) its time
    foot = FootTracker("right", last_counter=None)
    session = HostSession(ack_policy="never", tracker=foot, implied_commands=implied_commands("2015"))
    events = session.feed(capture)[0] + session.finish()[0]
    numbers = [e.packet_number for e in events if isinstance(e, StepEvent)]
    cut = {n for n, t in zip(numbers, foot.step_times, strict=True) if start_s <= t < end_s}
    out = bytearray()
    for frame in decode_all(capture):
        if not (isinstance(frame, StatePacket) and frame.number in cut):
            out += frame.to_bytes()
    return bytes(out), len(cut)


def feet_captures(scenario: str, seed: int, walker: int | None = None, stance_sway: bool | None = None,
                  config: SensorConfig | None = None) -> tuple[dict[str, Any], dict[str, bytes]]:
    """A module on each foot of a walker walking *scenario* (walk *seed*; *walker*'s two modules,
    None: the seed's own; *stance_sway* and the sensors' *config* as ``make_feet_sources``'s), each
    replayed with the fusion host: side → sensor source, side → the bytes its module sent."""
    from firmware_sim.sensors.imu_array import make_feet_sources

    from .runs import fusion_capture

    sources = make_feet_sources(scenario, seed=seed, walker=walker, stance_sway=stance_sway, config=config)
    return sources, {side: fusion_capture(source, source.module) for side, source in sources.items()}


def feet_walk(scenario: str, seed: int, drop_s: tuple[float, float] | None = None,
              config: SensorConfig | None = None, module_errors: Any = None) -> FeetWalk:
    """Walk *scenario* with a module on each foot (walker *seed*; the sensors' *config*, None: the
    default) and fuse the two captures; with *module_errors* (a ``hostlib.fusion.module_errors.ModuleErrors``)
    also with each module's errors held at those priors (:attr:`FeetWalk.held`)."""
    from hostlib.files.replay import replay_feet
    from hostlib.fusion.feet import FeetSettings, TwoFeetTracker
    from hostlib.fusion.tracker import FusionSettings

    sources, captures = feet_captures(scenario, seed, config=config)
    dropped = 0
    if drop_s is not None:
        captures["right"], dropped = drop_packets(captures["right"], *drop_s)
    trackers = [replay_feet(captures["left"], captures["right"], FeetSettings(constraint=constraint))[0]
                for constraint in (True, False)]
    held = None
    if module_errors is not None:
        held = TwoFeetTracker(last_counter=None, defer=True,
                              aids=FusionSettings(module_errors=module_errors))
        replay_feet(captures["left"], captures["right"], tracker=held)
    return FeetWalk(trackers[0], trackers[1], {side: s.truth for side, s in sources.items()}, dropped,
                    held)


def _ends(walk: FeetWalk) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Per estimate: its end displacement from its start (3,), the true one (3,) and the end's 3×3
    position covariance."""
    out = {}
    truth = {side: walk.truth[side].stance_positions for side in walk.truth}
    for side in ("left", "right"):
        track = walk.tracker.foot(side).track
        out[side] = (track.final_pose[:3] - track.poses[0][:3], truth[side][-1] - truth[side][0],
                     track.final_covariance[:3, :3])
    body_true = 0.5 * (truth["left"][-1] + truth["right"][-1]) - 0.5 * (truth["left"][0] + truth["right"][0])
    for name, track in (("average", walk.tracker.average), ("fused", walk.tracker.body)):
        out[name] = (track.final_pose[:3] - track.poses[0][:3], body_true, track.final_covariance[:3, :3])
    return out


def straight_run(seed: int) -> list[dict[str, Any]]:
    """The rows of one walker's 100 m straight walk (one per estimate), the modules warm as in the
    module paper's walks one after another (``python -m lab.spread``'s)."""
    from firmware_sim.sensors.config import DEFAULT_CONFIG

    walk = feet_walk(STRAIGHT_SCENARIO, seed, config=DEFAULT_CONFIG.warm())
    rows = []
    for name, (end, true, cov) in _ends(walk).items():
        err = end - true  # north = along the walk, east = across it, down
        rows.append({"seed": seed, "estimate": name, "length_error_m": float(err[0]),
                     "across_error_m": float(err[1]), "height_error_m": float(-err[2]),
                     "along_m": float(end[0]), "across_m": float(end[1]),
                     "sigma_along_m": math.sqrt(cov[0, 0]), "sigma_across_m": math.sqrt(cov[1, 1]),
                     "cov_along_across_m2": float(cov[0, 1]), "projections": walk.tracker.projections})
    return rows


def straight_rows(seeds: Sequence[int], workers: int = 2, scheduler: str | None = None
                  ) -> list[dict[str, Any]]:
    """Every walker's :func:`straight_run`, in order (:func:`lab.runner.seeded_rows`)."""
    from lab.runner import seeded_rows

    return seeded_rows(straight_run, list(seeds), workers, scheduler)


def _per_estimate(rows: Sequence[dict[str, Any]]) -> tuple[int, list[tuple[str, list[dict[str, Any]]]]]:
    """The number of walkers and, per estimate, its rows."""
    return len({r["seed"] for r in rows}), [(name, [r for r in rows if r["estimate"] == name])
                                            for name in ESTIMATES]


def straight_summary(rows: Sequence[dict[str, Any]]) -> list[str]:
    n, by_estimate = _per_estimate(rows)
    out = [f"two feet, {n} straight 100 m walks: end error mean ± sd [m] (1 m is 1 % of the walk)",
           f"{'estimate':<9} {'length':>15} {'across track':>15} {'height':>15} {'mean 1σ across':>15}"]
    for name, sel in by_estimate:
        cols = []
        for key in ("length_error_m", "across_error_m", "height_error_m"):
            v = np.array([r[key] for r in sel])
            cols.append(f"{v.mean():+6.2f} ± {v.std():4.2f}")
        sigma = np.mean([r["sigma_across_m"] for r in sel])
        out.append(f"{name:<9} " + " ".join(f"{c:>15}" for c in cols) + f" {sigma:15.2f}")
    proj = sum(r["projections"] for r in rows if r["estimate"] == "fused")
    out.append(f"the constraint (‖p_L − p_R‖ ≤ 1 m) bound {proj} times in all {n} walks")
    return out


def _closures(seed: int, tracker: Any, feet: dict[str, Any] | None = None, **extra: Any
              ) -> list[dict[str, Any]]:
    """The rows of one loop fused by *tracker*: closure per estimate. *feet* (side → Track) stand
    for the feet's own single-module tracks (e.g. drift-corrected); *extra* goes in every row."""
    own = {side: tracker.foot(side).track for side in ("left", "right")}
    feet = feet or own
    both = 0.5 * (own["left"].distance + own["right"].distance)
    rows = []
    for name, track in (*feet.items(), ("average", tracker.average), ("fused", tracker.body)):
        end = track.final_pose[:3] - track.poses[0][:3]
        distance = own[name].distance if name in own else both
        closure = float(np.hypot(*end[:2]))
        rows.append({"seed": seed, "estimate": name, **extra, "closure_m": closure, "distance_m": distance,
                     "closure_pct": 100.0 * closure / distance, "height_closure_m": float(-end[2]),
                     "projections": tracker.projections})
    return rows


def loop_run(seed: int) -> list[dict[str, Any]]:
    """The rows of one walker's 400 m loop: closure per estimate."""
    return _closures(seed, feet_walk(LOOP_SCENARIO, seed).tracker)


def loop_rows(seeds: Sequence[int], workers: int = 2, scheduler: str | None = None) -> list[dict[str, Any]]:
    """Every walker's :func:`loop_run`, in order."""
    from lab.runner import seeded_rows

    return seeded_rows(loop_run, list(seeds), workers, scheduler)


def loop_summary(rows: Sequence[dict[str, Any]]) -> list[str]:
    n, by_estimate = _per_estimate(rows)
    out = [f"two feet, a 400 m loop walked {n} times: horizontal closure",
           f"{'estimate':<9} {'closure [m]':>15} {'% of distance':>15} {'worst %':>8}"]
    for name, sel in by_estimate:
        c = np.array([r["closure_m"] for r in sel])
        pct = np.array([r["closure_pct"] for r in sel])
        out.append(f"{name:<9} {c.mean():7.2f} ± {c.std():5.2f} {pct.mean():15.2f} {pct.max():8.2f}")
    return out


def drift_loop(seed: int) -> dict[str, bytes]:
    """The two captures of :data:`DRIFT_WALKER`'s walk *seed* round the loop."""
    return feet_captures(LOOP_SCENARIO, seed, walker=DRIFT_WALKER)[1]


def drift_rows(seeds: Sequence[int], workers: int = 2, scheduler: str | None = None) -> list[dict[str, Any]]:
    """Every loop's closures without the drift correction and with it, leave-one-out (module
    docstring): each loop's modules calibrated on the other loops' uncorrected single tracks."""
    from firmware_sim.sensors.feet import SIDES, foot_module
    from firmware_sim.transports.factory import module_serial
    from hostlib.calibration.drift import calibrate
    from hostlib.files.replay import replay_feet
    from hostlib.fusion.feet import TwoFeetTracker
    from lab.runner import map_runs

    seeds = list(seeds)
    if len(seeds) < 2:
        raise ValueError("leave-one-out drift correction needs at least two loops")
    captures = map_runs(drift_loop, seeds, workers, scheduler)
    plain = [replay_feet(c["left"], c["right"])[0] for c in captures]
    serials = {side: module_serial(foot_module(DRIFT_WALKER, side)) for side in SIDES}
    rows = []
    for i, seed in enumerate(seeds):
        others = [j for j in range(len(seeds)) if j != i]
        drift = {side: calibrate([plain[j].foot(side).track for j in others], serials[side],
                                 names=[f"loop {seeds[j]}" for j in others]) for side in SIDES}
        corrected = TwoFeetTracker(last_counter=None, defer=True, drift=drift)
        replay_feet(captures[i]["left"], captures[i]["right"], tracker=corrected)
        feet = {side: drift[side].apply(corrected.foot(side).track, module_serial=serials[side])
                for side in SIDES}
        speeds = {f"{side}_drift_mm_s": 1e3 * math.hypot(*drift[side].dv[:2]) for side in SIDES}
        rows += _closures(seed, plain[i], drift_correction=False, **{k: math.nan for k in speeds})
        rows += _closures(seed, corrected, feet, drift_correction=True, **speeds)
    return rows


def drift_summary(rows: Sequence[dict[str, Any]]) -> list[str]:
    from firmware_sim.sensors.feet import foot_module

    n, by_estimate = _per_estimate(rows)
    modules = ", ".join(f"{foot_module(DRIFT_WALKER, side)} {side}" for side in ("left", "right"))
    out = [f"two feet, walker {DRIFT_WALKER}'s modules ({modules}) round a 400 m loop {n} times, each loop "
           f"corrected with the drift calibrations of the other {n - 1}: horizontal closure [% of distance]",
           f"{'estimate':<9} {'uncorrected':>12} {'worst':>6} {'corrected':>12} {'worst':>6}"]
    for name, sel in by_estimate:
        cols = []
        for correction in (False, True):
            pct = np.array([r["closure_pct"] for r in sel if r["drift_correction"] == correction])
            cols.append(f"{pct.mean():5.2f} ± {pct.std():4.2f} {pct.max():6.2f}")
        out.append(f"{name:<9} " + " ".join(cols))
    corrected = [r for r in rows if r["drift_correction"] and r["estimate"] == "fused"]
    speeds = ", ".join(f"{side} {np.mean([r[f'{side}_drift_mm_s'] for r in corrected]):.2f} mm/s"
                       for side in ("left", "right"))
    out.append(f"the calibrations' horizontal drift velocity |Δv|: {speeds}")
    return out


def aids_run(seed: int, stance_sway: bool | None = None) -> list[dict[str, Any]]:
    """The rows of one walker's walk of NavShoe's outage loop: one per :data:`AIDED_ESTIMATES`
    (*stance_sway*: the walking stances sway as a real foot's; None: the simulation's default)."""
    from dataclasses import replace

    from firmware_sim.sensors.feet import body_truth
    from hostlib.aids.compass import wrap_angle
    from hostlib.files.replay import replay_feet
    from hostlib.fusion.feet import FeetSettings, TwoFeetTracker
    from hostlib.fusion.module_errors import EMULATED_MODULE_SWAYING
    from hostlib.fusion.tracker import FusionSettings

    from .navshoe import SCENARIO, outdoor_compass, shoe_iron, walk_fixes

    sources, captures = feet_captures(SCENARIO, seed, stance_sway=stance_sway)
    t, pos, vel, yaw = body_truth(sources["left"].truth, sources["right"].truth)
    gps = walk_fixes(SCENARIO, t, pos, vel, seed)  # the receiver on the body
    aids = FusionSettings(gps=True, **outdoor_compass())
    irons = {side: shoe_iron(source) for side, source in sources.items()}
    aided, unconstrained = (
        TwoFeetTracker(FeetSettings(constraint=constraint), last_counter=None, defer=True, aids=aids,
                       mag_calibrations=irons)
        for constraint in (True, False))
    warmup = TwoFeetTracker(last_counter=None, defer=True, mag_calibrations=irons,
                            aids=replace(aids, module_errors=EMULATED_MODULE_SWAYING))
    plain = TwoFeetTracker(last_counter=None, defer=True, heading=float(yaw[0]))
    for tracker in (aided, unconstrained, warmup, plain):
        if tracker.aids.gps:
            tracker.add_fixes(gps.times_s, gps.north_east)
        replay_feet(captures["left"], captures["right"], tracker=tracker)
    left = sources["left"].truth
    body_end = np.r_[pos[-1, :2], yaw[-1]]
    # estimate → its track, where its origin lies in the walk's frame (a GPS run's: the first fix;
    # a plain run's: the body's true start), the true end [north, east, heading], its declination
    estimates = {
        "fused compass+gps": (aided.body, gps.first_fix, body_end, aided.declination),
        "average compass+gps": (aided.average, gps.first_fix, body_end,
                                0.5 * (aided.left.declination + aided.right.declination)),
        "fused plain": (plain.body, pos[0, :2], body_end, plain.declination),
        "left compass+gps": (aided.left.track, gps.first_fix, np.r_[left.pos[-1, :2], left.euler[-1, 2]],
                             aided.left.declination),
        "unconstrained compass+gps": (unconstrained.body, gps.first_fix, body_end, unconstrained.declination),
        "fused compass+gps module errors and warm-up": (warmup.body, gps.first_fix, body_end,
                                                        warmup.declination),
    }
    rows = []
    for name, (track, origin, true_end, declination) in estimates.items():
        pose = track.final_pose
        error = float(np.hypot(*(pose[:2] + origin - true_end[:2])))
        rows.append({
            "seed": seed, "estimate": name, "stance_sway": sources["left"].trajectory.stance_sway is not None,
            "without_gps_m": round(gps.without_gps_m, 1),
            "end_error_m": error, "end_error_pct_without_gps": 100.0 * error / gps.without_gps_m,
            "heading_error_deg": math.degrees(wrap_angle(float(pose[3]) - true_end[2])),
            "declination_deg": math.degrees(declination),
            "true_declination_deg": sources["left"].config.mag.declination_deg,
            "wmm_declination_deg": math.degrees(aids.declination_rad),
        })
    return rows


def aids_rows(seeds: Sequence[int], workers: int = 2, stance_sway: bool | None = None,
              scheduler: str | None = None) -> list[dict[str, Any]]:
    """Every walker's :func:`aids_run`, in order (*stance_sway* as there)."""
    from lab.runner import seeded_rows

    return seeded_rows(functools.partial(aids_run, stance_sway=stance_sway), list(seeds), workers, scheduler)


def aids_summary(rows: Sequence[dict[str, Any]]) -> list[str]:
    from .navshoe import error_table

    walked = np.mean([r["without_gps_m"] for r in rows])
    sway = stance_words(rows)
    walkers = len({r["seed"] for r in rows})
    return [f"two feet on navshoe-outage, {walkers} walkers{sway}: the body's error at the end of the "
            f"outage ({walked:.0f} m walked without GPS; left compass+gps: the left foot's own track "
            f"against that foot)"] + error_table(rows, "estimate", AIDED_ESTIMATES)


def heading_run(seed: int = 1, drop_s: tuple[float, float] | None = None) -> dict[str, Any]:
    """The 20-minute walk: per fused step its time, the heading difference between the feet and
    their separation, with and without the constraint, and constrained with each module's errors
    held (the emulated module's priors, swaying or still as the walk's stances); and what the link
    drop did."""
    from firmware_sim.sensors.stance_sway import stance_sway_on
    from hostlib.fusion.module_errors import EMULATED_MODULE, EMULATED_MODULE_SWAYING

    priors = EMULATED_MODULE_SWAYING if stance_sway_on(None) else EMULATED_MODULE
    walk = feet_walk(HEADING_SCENARIO, seed, drop_s, module_errors=priors)
    result: dict[str, Any] = {"seed": seed, "drop_s": drop_s, "dropped_packets": walk.dropped}
    for name, tracker in (("fused", walk.tracker), ("free", walk.free), ("held", walk.held)):
        left, right = tracker.fused_foot("left"), tracker.fused_foot("right")
        result[name] = {"heading_difference_deg": np.degrees(left[:, 3] - right[:, 3]),
                        "separation_m": tracker.separation(), "projections": tracker.projections}
    times = {side: iter(walk.tracker.foot(side).step_times) for side in ("left", "right")}
    result["time_s"] = np.array([0.0] + [next(times[s]) for s in walk.tracker.sides])
    result["gaps"] = {side: [(g.missing, g.index) for g in walk.tracker.foot(side).gaps] for side in times}
    result["restarts"] = list(walk.tracker.restarts)
    result["stale_steps"] = walk.tracker.stale_steps
    truth = walk.truth
    body_true = 0.5 * (truth["left"].stance_positions[-1] + truth["right"].stance_positions[-1])
    result["body_end_error_m"] = {
        name: float(np.hypot(*(track.final_pose[:2] - track.poses[0][:2] - body_true[:2])))
        for name, track in (("fused", walk.tracker.body), ("average", walk.tracker.average),
                            ("held", walk.held.body))}
    result["duration_s"] = float(truth["left"].t[-1])
    return result


def heading_summary(result: dict[str, Any]) -> list[str]:
    minutes = result["duration_s"] / 60.0
    out = [f"the feet's headings over {minutes:.0f} minutes (walker {result['seed']})"]
    for name in ("free", "fused", "held") if result["drop_s"] is None else ():  # a silent foot's stale pose
        r = result[name]
        d = np.abs(r["heading_difference_deg"])
        out.append(f"{name:<6} |χ_L − χ_R| max {d.max():6.2f}°, at the end {d[-1]:6.2f}°; separation max "
                   f"{r['separation_m'].max():6.2f} m ({r['projections']} projections)")
    ends = result["body_end_error_m"]
    out.append(f"body end error: fused {ends['fused']:.2f} m, average {ends['average']:.2f} m, fused "
               f"with each module's errors held {ends['held']:.2f} m")
    if result["drop_s"] is not None:
        a, b = result["drop_s"]
        gaps = "; ".join(f"{side}: {len(g)} gap(s), {sum(m for m, _ in g)} steps missing"
                         for side, g in result["gaps"].items())
        out.append(f"right foot's link down {a:.0f}–{b:.0f} s: {result['dropped_packets']} packets lost; "
                   f"{gaps}; {result['stale_steps']} steps fused with one foot; "
                   f"restarts {result['restarts']}")
    return out


# -- pictures ------------------------------------------------------------------------------------


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_end_points(path: Path, rows: Sequence[dict[str, Any]]) -> Path:
    """The end points of the straight walks, per estimate, with their 1σ ellipses (Fig. 7)."""
    from matplotlib.patches import Ellipse

    from hostlib.files.plot import ellipse_params

    plt = _pyplot()
    fig, grid = plt.subplots(2, 2, figsize=(11, 5.5), sharex=True, sharey=True)
    axes = grid.ravel()
    for ax, name in zip(axes, ESTIMATES, strict=True):
        sel = [r for r in rows if r["estimate"] == name]
        for r in sel:
            cov = np.array([[r["sigma_along_m"] ** 2, r["cov_along_across_m2"]],  # north, east
                            [r["cov_along_across_m2"], r["sigma_across_m"] ** 2]])
            w, h, angle = ellipse_params(cov)  # in the plot's east (across), north (along) axes
            ax.add_patch(Ellipse((r["across_error_m"], r["length_error_m"]), w, h, angle=angle, fill=False,
                                 color="C0", alpha=0.35, lw=0.8))
        ax.plot([r["across_error_m"] for r in sel], [r["length_error_m"] for r in sel], "k.", ms=4)
        across = np.std([r["across_error_m"] for r in sel])
        ax.set_title(f"{name} (across sd {across:.2f} m)")
        ax.axhline(0, color="0.7", lw=0.6)
        ax.axvline(0, color="0.7", lw=0.6)
        ax.set_aspect("equal", adjustable="box")
        ax.grid(True, alpha=0.3)
    for ax in grid[:, 0]:
        ax.set_ylabel("along track [m]")
    for ax in grid[1]:
        ax.set_xlabel("across track [m] (east)")
    fig.suptitle(f"end points of {len({r['seed'] for r in rows})} straight 100 m walks, 1σ ellipses")
    return _save(plt, fig, path)


def plot_heading(path: Path, result: dict[str, Any]) -> Path:
    """Heading difference between the feet and their separation over time, free and fused."""
    plt = _pyplot()
    t = result["time_s"] / 60.0
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(9, 6), sharex=True)
    for name, label in (("free", "no constraint (two single modules)"), ("fused", "constrained fusion"),
                        ("held", "constrained fusion, each module's errors held")):
        ax1.plot(t, result[name]["heading_difference_deg"], label=label)
        ax2.plot(t, result[name]["separation_m"], label=label)
    ax2.axhline(1.0, color="k", ls="--", lw=0.8, label="bound γ = 1 m")
    if result["drop_s"] is not None:
        for ax in (ax1, ax2):
            ax.axvspan(result["drop_s"][0] / 60.0, result["drop_s"][1] / 60.0, color="0.85",
                       label="right foot's link down")
    ax1.set_ylabel("χ_left − χ_right [°]")
    ax2.set_ylabel("feet apart [m]")
    ax2.set_xlabel("time [min]")
    ax1.set_title(f"heading of the two feet over {result['duration_s'] / 60:.0f} minutes")
    for ax in (ax1, ax2):
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    return _save(plt, fig, path)


def _save(plt, fig, path: Path) -> Path:
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
