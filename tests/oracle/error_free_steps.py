"""Where an error-free module loses its way: a scenario traced loop by loop against its truth.

The scenario is walked with ``SensorConfig.ideal()`` at 1 kHz (as ``python -m lab.accuracy error-free``)
and the module traced loop by loop (:mod:`.firmware_trace`: the host's pose, the detector's T1 and
ZUPT, the resets), its trace aligned on the sensors (:data:`~.firmware_trace.DESIGN_LAG`). Then:

* **per stride**: the host's pose in the middle of each true stance against the truth's stance
  (both in the frame the track starts in), and what each stride added to the error;
* **the detector**: ZUPT runs that begin in a true swing (a stance started early, or a false one in
  mid-swing), true stances the detector misses or covers only in part, and the smallest T1 and |ω|
  in the middle 80 % of each swing;
* **the resets**: each reset that happens in a true swing (the firmware resets when the ZUPT ends),
  how far into it, the INS's horizontal speed then and the yaw it took away: the reset turns the
  navigation frame by that yaw but leaves the velocity as it was (firmware.md §4);
* **one thing changed at a time**: the ZUPT forced to the true stances (:func:`truth_override`: the
  detector's decision replaced by the truth's stance flag, delayed like the detector's), or the
  detector's own but none in the middle of a swing (:func:`midswing_override`); another TH_ZUPT; the
  gyro half a sample late, which takes the mechanization's skew away (``source_of(midpoint=True)``);
  a reset that also turns the velocity (``trace(turn_velocity=True)``, not the firmware's); another
  rate; another scenario recipe or gait.

``python -m tests.oracle.error_free_steps SCENARIO [--forced | --no-midswing EDGE] [--midpoint]
[--turn-velocity] [--th-zupt TH] [--rate HZ]`` prints the strides, their sums per kind of swing and
the detector's and the resets' events (docs/accuracy.md, "Error-free scenarios at 1 kHz").
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass

import numpy as np

from firmware_sim.mcu.sequence import processing_function
from firmware_sim.nav import frontend, ins
from firmware_sim.nav.firmware import OPENSHOE
from firmware_sim.sensors.scenarios import SCENARIOS
from protocol.ids import ProcId, StateId

from .firmware_trace import DESIGN_LAG, align, quaternion_yaw, trace_module

__all__ = ["StepTrace", "trace", "strides", "detector_events", "resets_in_swings", "source_of",
           "truth_override", "midswing_override", "swing_kinds", "by_kind"]


@dataclass
class StepTrace:
    """A module's run on a simulated walk, aligned on the sensor samples (index k = sample k)."""

    truth: object  #: the walk's GroundTruth
    zupt: np.ndarray  #: (n,) bool
    t1: np.ndarray  #: (n,) the detector's statistic
    reset: np.ndarray  #: (n,) bool, a step ended (FILTER_RESET_FLAG)
    position: np.ndarray  #: (n, 3) the host's pose: summed steps + the INS since the reset
    heading: np.ndarray  #: (n,) [rad]
    velocity: np.ndarray  #: (n, 3) the INS's [m/s], in its frame (turned by the resets' yaw)
    reset_yaw: np.ndarray  #: (n,) the yaw each reset took away (DX's heading) [rad], 0 elsewhere

    @property
    def packets(self) -> int:
        return int(self.reset.sum())


def source_of(scenario: str, rate_hz: float = 1000.0, midpoint: bool = False):
    """The error-free simulated source of *scenario* (a name or a recipe), seed 0; *midpoint*: the
    gyro half a sample late, so that the firmware's one-sample accelerometer delay pairs each rate
    with the middle of the interval it turns the attitude over (the mechanization's skew off)."""
    from dataclasses import replace

    from firmware_sim.sensors.config import SensorConfig
    from firmware_sim.sensors.imu_array import make_source

    config = SensorConfig.ideal()
    if midpoint:
        dlpf = replace(config.dlpf, enabled=True, delays_only=True, accel_delay_s=(0.0,) * 7,
                       gyro_delay_s=(0.5 / rate_hz,) * 7)
        config = replace(config, dlpf=dlpf)
    return make_source(scenario, seed=0, rate_hz=rate_hz, config=config)


def truth_override(truth) -> np.ndarray:
    """An override (:func:`trace`) that makes the ZUPT the truth's stance flag."""
    return truth.stance.astype(np.int8)


def midswing_override(truth, edge: float = 0.2) -> np.ndarray:
    """An override (:func:`trace`) that keeps the detector's decisions but none in the middle of a
    swing (the swing without *edge* of it at either end)."""
    out = np.full(len(truth.stance), -1, np.int8)
    rate = truth.rate_hz
    for a_end, b_start in zip(truth.stance_end[:-1], truth.stance_start[1:], strict=True):
        a, b = int(round(a_end * rate)), int(round(b_start * rate))
        out[a + int(edge * (b - a)):b - int(edge * (b - a))] = 0
    return out


def _forcing_firmware(override: np.ndarray, lag: int):
    """The firmware with STATDET's ZUPT replaced by *override* (1 still, 0 moving, −1 the
    detector's own decision) delayed by *lag* loops (ZARU: the ZUPT and the detector's T2 test)."""
    loop = [0]

    @processing_function(ProcId.FRONTEND_STATDET, cycles=2600)
    def forced_statdet(module) -> None:
        frontend.frontend_statdet(module)
        mem = module.memory
        k = loop[0] - lag
        o = int(override[k]) if 0 <= k < len(override) else -1
        still = bool(mem[StateId.ZUPT]) if o < 0 else bool(o)
        mem[StateId.ZUPT][...] = still
        mem[StateId.ZARU][...] = still and int(mem[StateId.T2S2F]) < int(mem[StateId.TH_ZARU])
        loop[0] += 1

    return OPENSHOE.with_functions(forced_statdet)


@processing_function(ProcId.STEPWISE_SYSTEM_RESET, cycles=2500)
def _reset_turning_velocity(module) -> None:
    """STEPWISE_SYSTEM_RESET that also turns the velocity into the new frame (v ← Rz(−ψ) v): not
    the firmware's, an experiment."""
    mem = module.memory
    yaw = quaternion_yaw(mem[StateId.QUATERNION])
    ins.ins_stepwise_system_reset(module)
    if mem.flag(StateId.FILTER_RESET_FLAG):
        v = mem[StateId.VELOCITY]
        c, s = np.float32(np.cos(yaw)), np.float32(np.sin(yaw))
        v[0], v[1] = c * v[0] + s * v[1], -s * v[0] + c * v[1]


def trace(source, *, override: np.ndarray | None = None, th_zupt: int | None = None,
          turn_velocity: bool = False) -> StepTrace:
    """Run a module on *source* loop by loop as a lossless step-wise host and align the trace on
    the samples; *override* (per sample: 1 still, 0 moving, −1 the detector's decision) replaces the
    detector's ZUPT, *th_zupt* its power-on threshold; *turn_velocity*: the reset also turns the
    velocity into the new frame (:func:`_reset_turning_velocity`)."""
    firmware = OPENSHOE if override is None else _forcing_firmware(override, DESIGN_LAG)
    if turn_velocity:
        firmware = firmware.with_functions(_reset_turning_velocity)
    t = align(trace_module(source, th_zupt=th_zupt, firmware=firmware))
    lag = DESIGN_LAG

    def padded(a: np.ndarray, fill=None) -> np.ndarray:
        """*a* (aligned, *lag* samples short) back to the walk's length: zeros, or its last row."""
        tail = np.zeros((lag, *a.shape[1:]), a.dtype) if fill is None else np.repeat(a[-1:], lag, axis=0)
        return np.r_[a, tail]

    return StepTrace(source.truth, padded(t.zupt), padded(t.t1), padded(t.reset), padded(t.position, "last"),
                     padded(t.heading, "last"), padded(t.velocity, "last"), padded(t.reset_yaw))


def swing_kinds(scenario: str) -> list[str]:
    """What each swing of *scenario* is (the i-th swing ends in true stance i + 1): walk, arc, turn
    (on the spot), side, back, up, down (stairs), run, wiggle."""
    from firmware_sim.sensors import gait
    from firmware_sim.sensors.scenarios import _walked

    kinds = []
    for sw in _walked(scenario, gait.WALKING).swings:
        a, b, p = sw.a, sw.b, sw.params
        c, s = np.cos(a.yaw), np.sin(a.yaw)
        fwd = c * (b.x - a.x) + s * (b.y - a.y)
        right = -s * (b.x - a.x) + c * (b.y - a.y)
        if p.stride_length == 0.0 and p.stance_s == gait.WIGGLE.stance_s:
            kinds.append("wiggle")
        elif p.impact_g == gait.RUNNING.impact_g:
            kinds.append("run")
        elif b.z != a.z and p.swing_roll_deg != 0.0:
            kinds.append("up" if b.z < a.z else "down")
        elif abs(fwd) < 1e-9 and abs(right) < 1e-9:
            kinds.append("turn")
        elif abs(fwd) < 1e-9:
            kinds.append("side")
        elif fwd < 0:
            kinds.append("back")
        else:
            kinds.append("arc" if abs(b.yaw - a.yaw) > 1e-9 else "walk")
    return kinds


def by_kind(rows: list[dict], kinds: list[str]) -> dict[str, dict]:
    """The strides' added errors (:func:`strides`) summed per kind of swing (:func:`swing_kinds`)."""
    out: dict[str, dict] = {}
    for r in rows[1:]:
        k = kinds[r["stance"] - 1]
        o = out.setdefault(k, {"strides": 0, "added": np.zeros(4), "path_m": 0.0})
        o["strides"] += 1
        o["added"] = o["added"] + r["added"]
        o["path_m"] += float(np.linalg.norm(r["step_m"]))
    return out


def _start_frame(truth, p: np.ndarray) -> np.ndarray:
    first = truth.stance_positions[0]
    psi0 = float(truth.euler[0, 2])
    c, s = np.cos(-psi0), np.sin(-psi0)
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return (p - first) @ rot.T


def strides(tr: StepTrace) -> list[dict]:
    """Per true stance: the host's error in its middle (start frame, [m]; heading [deg]) and what
    the stride into it added."""
    truth = tr.truth
    rate = truth.rate_hz
    rows, prev = [], np.zeros(4)
    stances = _start_frame(truth, truth.stance_positions)
    psi0 = float(truth.euler[0, 2])
    n = len(tr.zupt)
    for i, (t0, t1) in enumerate(zip(truth.stance_start, truth.stance_end, strict=True)):
        k = min(n - 1, int(round(0.5 * (t0 + t1) * rate)))
        true_heading = float(truth.stance_poses[i, 5]) - psi0
        e = np.r_[tr.position[k] - stances[i],
                  np.degrees(np.remainder(tr.heading[k] - true_heading + np.pi, 2 * np.pi) - np.pi)]
        step = stances[i] - stances[i - 1] if i else np.zeros(3)
        rows.append({"stance": i, "t": 0.5 * (t0 + t1), "step_m": step, "error": e, "added": e - prev})
        prev = e
    return rows


def detector_events(tr: StepTrace, edge: float = 0.1) -> dict:
    """The detector against the truth: ZUPT runs that begin in a true swing (with their time, the
    swing's fraction and length), true stances without any ZUPT or covered only in part, and per
    swing the smallest T1 and |ω| in its middle (the swing without *edge* of it at either end)."""
    truth = tr.truth
    rate = truth.rate_hz
    stance = truth.stance[:len(tr.zupt)]
    z = tr.zupt
    rises = np.flatnonzero(z[1:] & ~z[:-1]) + 1
    false = []
    swings = []
    starts, ends = truth.stance_start, truth.stance_end
    for a_end, b_start in zip(ends[:-1], starts[1:], strict=True):
        a, b = int(round(a_end * rate)), int(round(b_start * rate))
        length = b - a
        mid = slice(a + int(edge * length), b - int(edge * length))
        w = np.degrees(np.linalg.norm(truth.omega_b[mid], axis=1))
        swings.append({"t": a / rate, "swing_s": length / rate, "min_t1": int(tr.t1[mid].min()),
                       "min_rate_dps": float(w.min()), "below_th": int(np.sum(~stance[mid] & z[mid]))})
        for r in rises[(rises > a) & (rises < b)]:
            run = int(np.argmin(z[r:])) if not z[r:].all() else len(z) - r
            false.append({"t": r / rate, "fraction": (r - a) / length, "samples": run,
                          "speed": float(np.linalg.norm(truth.vel[r]))})
    covered = []
    for t0, t1 in zip(starts, ends, strict=True):
        a, b = int(round(t0 * rate)), min(len(z), int(round(t1 * rate)))
        covered.append(float(z[a:b].mean()) if b > a else 0.0)
    return {"false_stances": false, "swings": swings, "stance_coverage": np.array(covered),
            "reset_times": np.flatnonzero(tr.reset) / rate}


def resets_in_swings(tr: StepTrace) -> list[dict]:
    """Every reset that happens in a true swing: when, how far into the swing [s], the INS's
    horizontal speed then [m/s], the yaw it took away [rad] and the velocity error that leaves (the
    speed times 2|sin(ψ/2)|: the frame turned by ψ, the velocity not)."""
    truth = tr.truth
    rate = truth.rate_hz
    out = []
    for k in np.flatnonzero(tr.reset):
        i = int(np.searchsorted(truth.stance_end, k / rate, side="right")) - 1
        if i < 0 or i + 1 >= len(truth.stance_start) or k / rate >= truth.stance_start[i + 1]:
            continue
        speed = float(np.linalg.norm(tr.velocity[k, :2]))
        psi = float(tr.reset_yaw[k])
        out.append({"t": k / rate, "into_s": k / rate - float(truth.stance_end[i]), "speed": speed,
                    "yaw": psi, "velocity_error": speed * 2.0 * abs(np.sin(0.5 * psi))})
    return out


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scenario")
    ap.add_argument("--forced", action="store_true", help="ZUPT forced to the true stances")
    ap.add_argument("--no-midswing", type=float, default=None, metavar="EDGE",
                    help="no ZUPT in a swing but its first and last EDGE (a fraction of it)")
    ap.add_argument("--th-zupt", type=int, default=None)
    ap.add_argument("--turn-velocity", action="store_true",
                    help="the reset also turns the velocity into the new frame (not the firmware's)")
    ap.add_argument("--midpoint", action="store_true", help="the gyro half a sample late (no skew)")
    ap.add_argument("--rate", type=float, default=1000.0, help="the module's loop rate [Hz]")
    args = ap.parse_args(argv)
    src = source_of(args.scenario, rate_hz=args.rate, midpoint=args.midpoint)
    override = (truth_override(src.truth) if args.forced
                else midswing_override(src.truth, args.no_midswing) if args.no_midswing is not None else None)
    tr = trace(src, override=override, th_zupt=args.th_zupt, turn_velocity=args.turn_velocity)
    ev = detector_events(tr)
    path = src.truth.distance_m()
    rows = strides(tr)
    end = rows[-1]["error"]
    print(f"{args.scenario}: path {path:.2f} m, {tr.packets} packets, {len(rows)} true stances; end error "
          f"{np.linalg.norm(end[:3]):.4f} m = {100 * np.linalg.norm(end[:3]) / path:.3f} % "
          f"(x {end[0]:+.4f} y {end[1]:+.4f} z {end[2]:+.4f} m, heading {end[3]:+.3f}°)")
    print(" stance      t   step x/y/z [m]            error x/y/z [mm]  heading[°]  "
          "added x/y/z [mm]  heading")
    for r in rows:
        s, e, d = r["step_m"], r["error"], r["added"]
        print(f" {r['stance']:4d} {r['t']:7.2f}  {s[0]:+6.3f} {s[1]:+6.3f} {s[2]:+6.3f}   "
              f"{1e3 * e[0]:+7.1f} {1e3 * e[1]:+7.1f} {1e3 * e[2]:+7.1f} {e[3]:+7.3f}   "
              f"{1e3 * d[0]:+6.1f} {1e3 * d[1]:+6.1f} {1e3 * d[2]:+6.1f} {d[3]:+7.3f}")
    if args.scenario in SCENARIOS or "+" in args.scenario:
        for kind, o in by_kind(rows, swing_kinds(args.scenario)).items():
            a = o["added"]
            print(f"{kind:7s} {o['strides']:4d} strides {o['path_m']:7.2f} m: added x {1e3 * a[0]:+7.1f} "
                  f"y {1e3 * a[1]:+7.1f} z {1e3 * a[2]:+7.1f} mm, heading {a[3]:+.4f}°")
    runs: dict[tuple, list[float]] = {}
    for f in ev["false_stances"]:
        runs.setdefault((round(100 * f["fraction"]), f["samples"] if f["samples"] < 100 else None,
                         round(f["speed"], 2)), []).append(f["t"])
    print(f"ZUPT runs beginning in a true swing: {len(ev['false_stances'])}")
    for (pct, samples, speed), times in runs.items():
        length = f"{samples} samples" if samples is not None else "into the stance"
        print(f"  {len(times):3d} × at {pct} % of the swing, {length}, the foot at {speed:.2f} m/s "
              f"(first at {times[0]:.3f} s)")
    cov = ev["stance_coverage"]
    print(f"true stances covered by ZUPT: min {cov.min():.2f}, missed {int(np.sum(cov == 0))}")
    sw = ev["swings"]
    print("swings: smallest T1 in the middle 80 %: " + " ".join(str(s["min_t1"]) for s in sw))
    print("swings: smallest |ω| there [°/s]:      " + " ".join(f"{s['min_rate_dps']:.1f}" for s in sw))
    print("resets at [s]: " + " ".join(f"{t:.2f}" for t in ev["reset_times"]))
    moving = [r for r in resets_in_swings(tr) if abs(r["yaw"]) > np.radians(1.0)]
    print(f"resets in a swing that took away more than 1° of yaw: {len(moving)}")
    for r in moving:
        print(f"  t {r['t']:.3f} s, {1e3 * r['into_s']:.0f} ms into the swing, |v_h| {r['speed']:.3f} m/s, "
              f"yaw {np.degrees(r['yaw']):+.1f}°: velocity error {1e3 * r['velocity_error']:.1f} mm/s")


if __name__ == "__main__":
    main()
