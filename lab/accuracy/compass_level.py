"""Where the per-step compass's level error comes from, on NavShoe's outage loop (diagnosis only: it
reads the simulator's truth, which no host may).

Per seed s, module 40 + s, the ``navshoe-outage`` walk goes once through the module with the fusion
host (:func:`lab.accuracy.runs.fusion_capture`); each step packet that moved the foot gives a reading
(its magnetometers and attitude, :func:`hostlib.aids.compass.stance_reading`), the true iron removed
(:func:`lab.accuracy.navshoe.shoe_iron`). Its heading error is taken against the true heading less
the simulated declination and deviation at the step's sample (T_INT_K), three ways:

* ``packet``: levelled with the packet's attitude, as the host levels it;
* ``lag removed``: the attitude turned by the truth's rotation between its sample and the sample
  whose reading the magnetometer registers hold (found by matching the simulated registers);
* ``truth at the reading``: levelled with the truth's attitude at that sample.

Each is fitted with A + B sin ψ + C cos ψ over the walk (ψ the true heading). The dip of the packet's
reading (its levelled field's inclination) against the local field's, and against the Earth's alone
(what a host knows, up to the World Magnetic Model's error), gives the swing the dip implies
(:func:`dip_swing`, :mod:`hostlib.fusion.compass_dip`). Per seed also: how
many milliseconds the registers are newer than the attitude; the attitude's roll and pitch against
the truth at its sample, in the first minute and after five (the module's level as its dies warm);
and the horizontal gyros' warm-up (offset temperature coefficient, averaged over the chips in the
board's axes, times the simulated warm-up).

Run: ``python -m lab.accuracy.compass_level 1 2 3`` (docs/heading-aids.md, "Where the level error
comes from").
"""

from __future__ import annotations

import math
import sys
from collections.abc import Sequence
from typing import Any

import numpy as np

__all__ = ["WAYS", "dip_swing", "level_rows", "level_run", "summary_lines", "swing_fit"]

#: the three levellings of each reading (module docstring)
WAYS = ("packet", "lag removed", "truth at the reading")


def swing_fit(errors: np.ndarray, headings: np.ndarray) -> tuple[float, float, float, float]:
    """(RMS, A, B, C) [deg] of heading *errors* [rad] fitted with A + B sin ψ + C cos ψ over the true
    *headings* ψ [rad]."""
    basis = np.column_stack([np.ones_like(headings), np.sin(headings), np.cos(headings)])
    a, b, c = np.linalg.lstsq(basis, errors, rcond=None)[0]
    return (math.degrees(float(np.sqrt(np.mean(errors ** 2)))), math.degrees(a), math.degrees(b),
            math.degrees(c))


def dip_swing(dips: np.ndarray, headings: np.ndarray, inclination_rad: float) -> tuple[float, float]:
    """The heading swing (B, C) [deg], in :func:`swing_fit`'s sense, that the readings' dip errors
    *dips* [rad] at the true *headings* ψ [rad] imply: a level error fixed in the board's frame moves
    the dip by κ (B cos ψ − C sin ψ), κ = cot I (:mod:`hostlib.fusion.compass_dip`)."""
    _, _, b, c = swing_fit(dips, headings)
    kappa = 1.0 / math.tan(inclination_rad)
    return c / kappa, -b / kappa


def _readings(data: bytes) -> list[tuple[Any, float, np.ndarray, np.ndarray]]:
    """Every step packet's (stance reading, module time [s], dx, the magnetometers' registers)."""
    from hostlib.aids.compass import stance_reading
    from hostlib.files.replay import replay_session
    from hostlib.fusion.tracker import FusionSettings, FusionTracker
    from protocol.extensions import FUSION_MAG_IMUS
    from protocol.ids import imu_mag_id

    steps = []

    class Recorder(FusionTracker):
        def add(self, step, swing_time=math.nan, states=None):
            outcome = super().add(step, swing_time, states)
            if outcome.summed and states is not None and imu_mag_id(0) in states:
                steps.append((stance_reading(states), float(self.step_times[-1]),
                              np.asarray(step.dx, dtype=float),
                              np.array([states[imu_mag_id(i)] for i in FUSION_MAG_IMUS])))
            return outcome

    replay_session(data, tracker=Recorder(FusionSettings(), last_counter=None))
    return steps


def _gyro_warmup_deg_s(source: Any) -> np.ndarray:
    """The horizontal gyros' bias change over the simulated warm-up [°/s], board x and y."""
    mounting = source.geometry.mounting.astype(float)
    tempco = np.mean([m.T @ chip.gyro_offset_tempco for m, chip in zip(mounting, source.chips, strict=True)],
                     axis=0)
    return np.degrees(tempco[:2] * source.config.temperature.warmup_c)


def level_run(seed: int) -> dict[str, Any]:
    """The row of walk *seed* (module docstring)."""
    from firmware_sim.sensors.imu_array import make_source
    from hostlib.aids.compass import compass_heading, wrap_angle
    from hostlib.aids.field_check import level_field
    from hostlib.track.steps import is_motion_step
    from protocol.extensions import FUSION_MAG_IMUS

    from .navshoe import SCENARIO, shoe_iron
    from .runs import fusion_capture

    module = 40 + seed
    source = make_source(SCENARIO, seed=seed, module=module)
    truth = source.truth
    last = len(truth.t) - 1
    iron = shoe_iron(source)
    declination = math.radians(source.config.mag.declination_deg)
    chips = list(FUSION_MAG_IMUS)
    errors: dict[str, list[float]] = {way: [] for way in WAYS}
    headings, lags, times, level = [], [], [], []
    world = source.magnetic
    earth_dip = level_field(world.earth_ned, np.eye(3))[1]
    dips: dict[str, list[float]] = {"local": [], "earth": []}
    for reading, t, dx, registers in _readings(fusion_capture(source, module)):
        if reading is None or not is_motion_step(dx) or not math.isfinite(t):
            continue
        i = min(int(round(t * source.rate_hz)), last)
        j = next((k for k in range(max(0, i - 5), min(i + 40, last + 1))
                  if np.array_equal(source.mag[k, chips], registers)), None)
        if j is None:
            continue
        expected = truth.euler[i, 2] - declination - float(source.magnetic.heading_deviation(truth.pos[i])[0])
        field = iron.apply(reading.field_board)
        for way, rotation in zip(WAYS, (reading.rotation, reading.rotation @ truth.R[i].T @ truth.R[j],
                                        truth.R[j]), strict=True):
            errors[way].append(wrap_angle(compass_heading(field, rotation) - expected))
        dip = level_field(field, reading.rotation)[1]
        local = world.earth_ned + world.deviation_ned(truth.pos[i:i + 1])[0]
        dips["local"].append(dip - level_field(local, np.eye(3))[1])
        dips["earth"].append(dip - earth_dip)
        headings.append(truth.euler[i, 2])
        lags.append(j - i)
        times.append(t)
        roll, pitch = reading.roll_pitch
        level.append((pitch - truth.euler[i, 1], roll - truth.euler[i, 0]))
    psi, t, level_err = np.array(headings), np.array(times), np.degrees(np.array(level))
    first, later = t < t[0] + 60.0, t > t[0] + 300.0
    lag_ms, counts = np.unique(1000.0 * np.array(lags) / source.rate_hz, return_counts=True)
    return {"seed": seed, "module": module, "readings": len(psi),
            "lag_ms": {float(v): int(n) for v, n in zip(lag_ms, counts, strict=True)},
            **{way: swing_fit(np.array(errors[way]), psi) for way in WAYS},
            **{f"dip_swing_{k}": dip_swing(np.array(v), psi, earth_dip) for k, v in dips.items()},
            "level_first_minute_deg": tuple(level_err[first].mean(axis=0)),
            "level_after_five_deg": tuple(level_err[later].mean(axis=0)),
            "gyro_warmup_deg_s": tuple(_gyro_warmup_deg_s(source))}


def level_rows(seeds: Sequence[int], workers: int = 2, scheduler: str | None = None) -> list[dict[str, Any]]:
    """Every seed's row, seeds in order (through :func:`lab.runner.map_runs`)."""
    from lab.runner import map_runs

    return map_runs(level_run, list(seeds), workers, scheduler)


def summary_lines(rows: Sequence[dict[str, Any]]) -> list[str]:
    """A line per seed: each levelling's RMS, B, C [deg]; the registers' lag; the level's pitch and
    roll error early and late; the horizontal gyros' warm-up."""
    out = ["navshoe-outage, the true iron removed: RMS, B, C [°] of the readings levelled with "
           + " / ".join(WAYS) + "; magnetometers newer than the attitude [ms: readings]; "
           "level error pitch/roll [°] first minute → after five; horizontal gyros' warm-up x/y [°/s]; "
           "the swing B, C [°] the packet's dip implies, against the local field's and the Earth's"]
    for r in rows:
        fits = "  ".join("{:.2f}, {:+.2f}, {:+.2f}".format(*(r[way][k] for k in (0, 2, 3))) for way in WAYS)
        lag = ", ".join(f"{v:g}: {n}" for v, n in r["lag_ms"].items())
        early, late, warm = r["level_first_minute_deg"], r["level_after_five_deg"], r["gyro_warmup_deg_s"]
        out.append(f"  seed {r['seed']:>2}: {fits}   lag {lag}   level {early[0]:+.2f}/{early[1]:+.2f} → "
                   f"{late[0]:+.2f}/{late[1]:+.2f}   warm-up {warm[0]:+.3f}/{warm[1]:+.3f}"
                   + "".join("   dip's swing ({}) {:+.2f}, {:+.2f}".format(k, *r[f"dip_swing_{k}"])
                             for k in ("local", "earth") if f"dip_swing_{k}" in r))
    return out


if __name__ == "__main__":
    print("\n".join(summary_lines(level_rows([int(s) for s in sys.argv[1:]] or [1, 2, 3, 4, 5], workers=0))))
