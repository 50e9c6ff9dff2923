"""Why the emulated module's heading follows only about 1 % of a vertical gyro bias.

A bias on the board's z rate (the vertical, for a level foot) is added to an error-free scenario's
gyros (``SensorConfig.ideal()``, seed 0, 1 kHz) and the module is traced loop by loop as a lossless
step-wise host; against the same run without the bias:

* **the bias**: :func:`biased_source` adds it in each chip's own axes (board z through the chip's
  mounting: the bottom pair, upside down, reads −z) where the sensor model adds its in-run drift,
  before the rounding to the registers; with no noise to dither it, the registers hold it rounded
  (0.05 °/s = 0.82 LSB reads 1 LSB = 0.061 °/s wherever the true z rate is 0, as in the whole
  straight walk), so the figures use what the registers hold (:func:`register_bias`);
* **the detector**: the fraction of loops with ZARU (in the run without the bias) in the start-up
  stand and in the walking stances (the truth's), where MECHANIZATION drops the vertical rate and
  BIASEST updates;
* **BIASEST**: its estimate of the z rate's bias over time, and when it holds 90 % of the bias;
* **the heading**: its change at the end, against the bias integrated over the time after the
  start-up stand (split into the truth's swings and stances), and against the bias BIASEST had not
  learnt integrated over the loops without ZARU (the prediction if the ZUPT filter leaves the yaw
  alone);
* **one thing changed**: ZARU switched off from the end of the start-up stand
  (:func:`trace_bias` *zaru_off_from*), as in the walking stances of the six shared real walks,
  where ZARU never holds (docs/accuracy.md).

The simulated stance studied here is perfectly still (``stance_sway=False``; a default walk's
stances sway as a real foot's do since, ``stance_sway.STANCE_SWAY_DEFAULT``), so
T2 is the standing noise floor in every walking stance and ZARU holds there: BIASEST re-learns a
vertical bias in every stance (a time constant of √(R/Q) ≈ 550 ZARU loops, about a second of
walking) and the stances' vertical rate is dropped, so the heading keeps only the bias of the
first swings after it appeared.

``python -m tests.oracle.gyro_bias_response [SCENARIO] [--bias DPS ...] [--case CASE ...]
[--all-errors]`` prints one row per bias and case (:data:`CASES`: from t = 0, switched on after
the start-up stand, a ramp from 0 at t = 0 to the bias at the last stand, and after the stand with
ZARU off); ``--all-errors``: the sensors with every error (the run without the bias has them too)
instead of error-free (docs/accuracy.md, the module's heading drift).
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from firmware_sim.mcu.sequence import processing_function
from firmware_sim.nav import config as nav_cfg
from firmware_sim.nav import frontend
from firmware_sim.nav.firmware import OPENSHOE
from protocol.ids import ProcId, StateId

from .firmware_trace import HostPose, stepwise_loops

__all__ = ["BiasRun", "biased_source", "register_bias", "trace_bias", "response", "CASES", "GYRO_LAG"]

#: Loops the filter's gyro sample (U_INT_K) runs behind the sensors: the middle of the detector's
#: N-sample buffer (the accelerometer is one more, firmware.md §3).
GYRO_LAG = nav_cfg.N // 2

DEG = math.pi / 180.0


def biased_source(scenario: str, bias: Callable[[np.ndarray], np.ndarray] | None, *, rate_hz: float = 1000.0,
                  config=None, seed: int = 0, stance_sway: bool = False):
    """The simulated source of *scenario* (``SensorConfig.ideal()`` unless *config*; still walking
    stances unless *stance_sway*) with *bias* (sample times [s] → the board z rate's bias [rad/s])
    added to every chip's gyro, in its own axes, before the rounding to the registers."""
    from firmware_sim.sensors.config import SensorConfig
    from firmware_sim.sensors.imu_array import make_source

    src = make_source(scenario, seed=seed, rate_hz=rate_hz, config=config or SensorConfig.ideal(),
                      stance_sway=stance_sway)
    if bias is not None:
        b = np.asarray(bias(src.truth.t), dtype=float)
        mount = src.geometry.mounting.astype(float)
        for i, m in enumerate(mount):
            src._random_gyro[:, i, :] += b[:, None] * m[:, 2][None, :]  # board z in chip i's axes
        src._build_imu()
    return src


def register_bias(biased, plain) -> np.ndarray:
    """The board z rate's bias the registers hold [rad/s] per sample: the four chips' mean of the
    difference between the two sources' registers, back in board axes."""
    mount = biased.geometry.mounting.astype(float)
    d = biased.imu[:, :, 3:].astype(float) - plain.imu[:, :, 3:].astype(float)
    board_z = np.mean([d[:, i] @ m[:, 2] for i, m in enumerate(mount)], axis=0)
    return board_z / nav_cfg.GYRO_LSB_PER_DPS * DEG


def _zaru_off_firmware(from_loop: int):
    """The firmware with STATDET's ZARU false from loop *from_loop* on (ZUPT as the detector's)."""
    loop = [0]

    @processing_function(ProcId.FRONTEND_STATDET, cycles=2600)
    def statdet_without_zaru(module) -> None:
        frontend.frontend_statdet(module)
        if loop[0] >= from_loop:
            module.memory[StateId.ZARU][...] = False
        loop[0] += 1

    return OPENSHOE.with_functions(statdet_without_zaru)


@dataclass
class BiasRun:
    """A traced run, per loop (index = loop number; the filter's sample is GYRO_LAG loops older)."""

    zupt: np.ndarray  #: (n,) bool
    zaru: np.ndarray  #: (n,) bool
    bias_z: np.ndarray  #: (n,) BIASEST's estimate of the board z rate's bias [rad/s]
    heading: np.ndarray  #: (n,) the host's heading: summed steps + the INS's yaw [rad]
    register_bias: np.ndarray | None = None  #: (n,) the z bias the registers hold, per sample [rad/s]


def trace_bias(source, *, zaru_off_from: float | None = None) -> BiasRun:
    """Run a module on *source* loop by loop as a lossless step-wise host and trace ZUPT, ZARU,
    BIASEST's z estimate and the host's heading; *zaru_off_from* [s]: ZARU never holds for the
    samples from that time on (the filter's loops GYRO_LAG later)."""
    firmware = None
    if zaru_off_from is not None:
        firmware = _zaru_off_firmware(int(round(zaru_off_from * source.rate_hz)) + GYRO_LAG)
    n = len(source)
    zupt, zaru = np.zeros(n, bool), np.zeros(n, bool)
    bias_z, heading = np.zeros(n), np.zeros(n)
    host = HostPose()
    for k, module in stepwise_loops(source, firmware=firmware):
        mem, work = module.memory, frontend.frontend_work(module)
        zupt[k] = mem.flag(StateId.ZUPT)
        zaru[k] = mem.flag(StateId.ZARU)
        bias_z[k] = float(work.gyro_bias[2])
        _, heading[k], _ = host.after_loop(mem)
    return BiasRun(zupt, zaru, bias_z, heading)


#: The cases of :func:`response`: name → (the bias's time profile (times [s], size [rad/s], the end
#: of the start-up stand [s], the walk's end [s]) → [rad/s], ZARU switched off after the stand).
CASES: dict[str, tuple[Callable, bool]] = {
    "from t=0": (lambda t, b, t0, t1: np.full_like(t, b), False),
    "after the stand": (lambda t, b, t0, t1: np.where(t >= t0, b, 0.0), False),
    "ramp 0 → b": (lambda t, b, t0, t1: b * np.clip(t / t1, 0.0, 1.0), False),
    "after the stand, no ZARU": (lambda t, b, t0, t1: np.where(t >= t0, b, 0.0), True),
}


def _walking(truth) -> tuple[float, float]:
    """The end of the start-up stand and the start of the last stand [s]."""
    return float(truth.stance_end[0]), float(truth.stance_start[-1])


def response(scenario: str, bias_dps: float, case: str, base: BiasRun | None = None, config=None) -> dict:
    """The figures of one *case* (:data:`CASES`) of a *bias_dps* [°/s] bias on *scenario*; *base*:
    the run without the bias (traced if not given; pass it to share it between cases); *config*:
    the sensors' (default ``SensorConfig.ideal()``)."""
    profile, no_zaru = CASES[case]
    plain = biased_source(scenario, None, config=config)
    truth = plain.truth
    t0, t1 = _walking(truth)
    src = biased_source(scenario, lambda t: profile(t, bias_dps * DEG, t0, t1), config=config)
    if base is None:
        base = trace_bias(plain)
    run = trace_bias(src, zaru_off_from=t0 if no_zaru else None)
    run.register_bias = register_bias(src, plain)
    rate = src.rate_hz
    n = len(run.zaru)
    lag = GYRO_LAG
    # the filter's sample of loop k is sample k − lag: the registers' bias it was given
    b_in = np.r_[np.zeros(lag), run.register_bias[:n - lag]]
    k0 = int(round(t0 * rate)) + lag
    sample_stance = np.r_[np.zeros(lag, bool), truth.stance[:n - lag]]
    after = np.arange(n) >= k0  # the loops of the samples after the start-up stand
    walking = after & (np.arange(n) < int(round(t1 * rate)) + lag)
    residual = b_in - (run.bias_z - base.bias_z)  # the bias BIASEST has not learnt
    b_end = float(np.mean(b_in[-int(rate):]))  # the last second's: noise dithers the rounding
    step = case != "ramp 0 → b" and not no_zaru
    learnt = np.flatnonzero((np.abs(residual) <= 0.1 * abs(b_end)) & after)
    t_on = max(t0, float(np.flatnonzero(b_in != 0.0)[0] - lag) / rate) if b_end else t0
    return {
        "case": case, "bias_dps": bias_dps, "register_bias_dps": b_end / DEG,
        "heading_deg": math.degrees(run.heading[-1] - base.heading[-1]),
        "bias_x_after_deg": math.degrees(float(np.sum(b_in[after])) / rate),
        "bias_x_swing_deg": math.degrees(float(np.sum(b_in[after & ~sample_stance])) / rate),
        "bias_x_stance_deg": math.degrees(float(np.sum(b_in[after & sample_stance])) / rate),
        "unlearnt_no_zaru_deg": math.degrees(float(np.sum(residual[after & ~run.zaru])) / rate),
        "estimate_at_walk_dps": (run.bias_z[k0] - base.bias_z[k0]) / DEG,
        "estimate_at_end_dps": (run.bias_z[-1] - base.bias_z[-1]) / DEG,
        "t90_s": (learnt[0] - lag) / rate - t_on if step and len(learnt) else math.nan,
        "zaru_stand": float(base.zaru[lag:k0].mean()),  # the run without the bias
        "zaru_walk_stances": float(base.zaru[walking & sample_stance].mean()),
        "zaru_walking": float(base.zaru[walking].mean()),
        "walk_s": float(walking.sum()) / rate,
        "after_s": float(after.sum()) / rate,
    }


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scenario", nargs="?", default="walk")
    ap.add_argument("--bias", type=float, nargs="+", default=[0.05, 1.0], metavar="DPS",
                    help="the vertical (board z) gyro bias [°/s]")
    ap.add_argument("--case", choices=list(CASES), nargs="+", default=list(CASES))
    ap.add_argument("--all-errors", action="store_true",
                    help="the sensors with all their errors (DEFAULT_CONFIG, module 0), not error-free")
    args = ap.parse_args(argv)
    config = None
    if args.all_errors:
        from firmware_sim.sensors.config import DEFAULT_CONFIG as config
    base = trace_bias(biased_source(args.scenario, None, config=config))
    rows = [response(args.scenario, b, c, base, config) for b in args.bias for c in args.case]
    r0 = rows[0]
    print(f"{args.scenario}: {r0['walk_s']:.1f} s walked, {r0['after_s']:.1f} s after the start-up stand; "
          f"without the bias ZARU holds in {100 * r0['zaru_stand']:.1f} % of the stand's loops, "
          f"{100 * r0['zaru_walk_stances']:.1f} % of the walking stances' and "
          f"{100 * r0['zaru_walking']:.1f} % of the walk's")
    print("  bias [°/s] registers  case                      heading [°]   b×t after the stand [°]  "
          "ratio    unlearnt w/o ZARU [°]  BIASEST at walk / end [°/s]  90 % learnt [s]")
    print(" " * 64 + "(swing + stance)")
    for r in rows:
        ratio = r["heading_deg"] / r["bias_x_after_deg"] if r["bias_x_after_deg"] else math.nan
        print(f"  {r['bias_dps']:9.3f} {r['register_bias_dps']:9.4f}  {r['case']:24s}  "
              f"{r['heading_deg']:+11.4f}  {r['bias_x_after_deg']:7.3f} ({r['bias_x_swing_deg']:.2f} + "
              f"{r['bias_x_stance_deg']:.2f})  {100 * ratio:6.2f} %  {r['unlearnt_no_zaru_deg']:+20.4f}  "
              f"{r['estimate_at_walk_dps']:+12.4f} / {r['estimate_at_end_dps']:+.4f}  {r['t90_s']:14.2f}")

if __name__ == "__main__":
    main()
