"""NavShoe's house walk, simulated (shared/spec/aids.md §1).

One walk of the ``navshoe-house`` scenario per seed — 118 m through a two-storey house, up a
flight of stairs, round the upper floor, down again and back to the front door, indoors: no GPS,
and a building's magnetic deviation of about 20° RMS that changes within a metre — goes once
through the module (``openshoe-emu replay --host fusion``: each step packet carries the
magnetometers and the attitude at the end of its stance). The host then tracks the same bytes
five ways (:class:`hostlib.fusion.tracker.FusionTracker`):

* ``per step``: NavShoe's compass, one reading per step that moved the foot, at the end of its
  stance, σ :data:`INDOOR_COMPASS_SIGMA_DEG`, the declination as simulated;
* ``every reset``: the same readings at every reset, the ones while the wearer stands too;
* ``continuous``: every magnetometer sample of every stance as an independent reading
  (:class:`ContinuousCompassTracker`), the design NavShoe warns against;
* ``plain``: no compass, the step sum given the true initial heading;
* ``per step, WMM declination``: as the first, with the World Magnetic Model's declination (what a
  host indoors knows; it cannot learn it without GPS).

The compass runs remove the shoe's hard and soft iron as simulated. The first compass reading
aligns the heading. Per run: the horizontal and the height error at the end of the walk (back at
the start), the heading error there, and the end error in % of the path. Per walk also: the
building's deviation in heading at the foot's rests (its RMS, its mean, and how alike two successive
rests' deviations are), which the compass σ and the verdict are read against.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from hostlib.fusion.tracker import FusionSettings, FusionTracker

from .runs import stance_words

__all__ = ["SCENARIO", "RUNS", "INDOOR_COMPASS_SIGMA_DEG", "ContinuousCompassTracker", "house_rows",
           "house_run", "summary_lines", "verdict"]

SCENARIO = "navshoe-house"
RUNS = ("per step", "every reset", "continuous", "plain", "per step, WMM declination")
#: 1σ of one compass reading indoors [deg]: the emulator's building deviation, 5 µT per axis against
#: the 15.5 µT horizontal field, is 20° RMS of heading (19° at the rests of these walks: the summary
#: prints it); the compass's own error beyond it (noise, attitude, ≈ 1.5° RMS) adds nothing to
#: speak of.
INDOOR_COMPASS_SIGMA_DEG = 20.0


class ContinuousCompassTracker(FusionTracker):
    """A compass update at every magnetometer sample of every stance, each taken as independent
    with σ_c (a compass run continuously while the foot stands, standing still included).

    The module reports a stance's last reading only; but in a stance the foot does not move, so its
    samples read one and the same field (the chips' noise aside, a degree against σ_c's twenty), and
    M such updates are one update with σ_c/√M. M is the stance's length — the time since the last
    reset less the swing (SWING_TIME) — times the magnetometers' rate. Use it with
    ``compass_mode="every-reset"``.
    """

    def __init__(self, settings: FusionSettings, mag_rate_hz: float, **tracker_args):
        self._per_sample = settings
        self._mag_rate_hz = float(mag_rate_hz)
        self._last_reset_s = 0.0
        #: per summed step: how many magnetometer samples its stance had
        self.stance_samples: list[int] = []
        super().__init__(settings, **tracker_args)

    def add_step(self, dx, dp, counter, swing_time: float = math.nan, *, reading=None,
                 time_s: float = math.nan):
        """The step as :meth:`FusionTracker.add_step` fuses it, its compass reading's σ that of one
        magnetometer sample over √(the stance's samples): a reading per sample since the last one."""
        swing = swing_time if math.isfinite(swing_time) else 0.0
        stance_s = time_s - self._last_reset_s - swing
        samples = max(1, round(stance_s * self._mag_rate_hz)) if math.isfinite(stance_s) else 1
        sigma = self._per_sample.compass_sigma_rad / math.sqrt(samples)
        # the aids this stance's update applies (the filter reads its aid_settings)
        self.aid_settings = replace(self._per_sample, compass_sigma_rad=sigma)
        count = len(self)
        outcome = super().add_step(dx, dp, counter, swing_time, reading=reading, time_s=time_s)
        self.aid_settings = self._per_sample
        if len(self) > count:
            self.stance_samples.append(samples)
            if math.isfinite(time_s):
                self._last_reset_s = time_s
        return outcome


def house_run(seed: int, scenario: str = SCENARIO) -> list[dict[str, Any]]:
    """The five runs' rows of walk *seed* of *scenario* (module docstring)."""
    from firmware_sim.sensors.imu_array import make_source
    from firmware_sim.sensors.truth import walked_distance
    from hostlib.aids.compass import wrap_angle
    from hostlib.files.replay import replay_session

    from .navshoe import shoe_iron, wmm_declination_rad
    from .runs import fusion_capture

    source = make_source(scenario, seed=seed)
    truth = source.truth
    data = fusion_capture(source)
    mag = source.config.mag
    deviation = source.magnetic.heading_deviation(truth.stance_positions)
    true_heading0, true_heading = float(truth.euler[0, 2]), float(truth.euler[-1, 2])
    end = truth.pos[-1] - truth.pos[0]
    path = float(walked_distance(truth.pos)[-1])
    compass = FusionSettings(compass=True, compass_sigma_rad=math.radians(INDOOR_COMPASS_SIGMA_DEG),
                             declination_rad=math.radians(mag.declination_deg),
                             mag_calibration=shoe_iron(source))
    wmm = wmm_declination_rad()
    trackers = {
        "per step": lambda: FusionTracker(compass, last_counter=None),
        "every reset": lambda: FusionTracker(replace(compass, compass_mode="every-reset"), last_counter=None),
        "continuous": lambda: ContinuousCompassTracker(replace(compass, compass_mode="every-reset"),
                                                       mag.rate_hz, last_counter=None),
        "plain": lambda: FusionTracker(FusionSettings(), last_counter=None, heading=true_heading0),
        "per step, WMM declination": lambda: FusionTracker(replace(compass, declination_rad=wmm),
                                                           last_counter=None),
    }
    rows = []
    for run in RUNS:
        tracker = trackers[run]()
        replay_session(data, tracker=tracker)
        pose = tracker.track.final_pose
        error = float(np.hypot(*(pose[:2] - end[:2])))
        rows.append({
            "seed": seed, "run": run, "stance_sway": source.trajectory.stance_sway is not None,
            "distance_m": round(tracker.track.distance, 1), "without_gps_m": round(path, 1),
            "end_error_m": error,
            "height_error_m": float(end[2] - pose[2]),  # z is down: the height estimated too high > 0
            "end_error_pct_without_gps": 100.0 * error / path,
            "heading_error_deg": math.degrees(wrap_angle(float(pose[3]) - true_heading)),
            "declination_deg": math.degrees(tracker.declination),
            "true_declination_deg": mag.declination_deg, "wmm_declination_deg": math.degrees(wmm),
            "compass_updates": tracker.fusion.compass_updates,
            "compass_skipped": tracker.fusion.compass_skipped,
            "compass_rejected": tracker.fusion.compass_rejected,
            "aligned_by": tracker.fusion.heading_aligned_by or "truth",
            "deviation_rms_deg": math.degrees(float(np.sqrt(np.mean(deviation ** 2)))),
            "deviation_mean_deg": math.degrees(float(np.mean(deviation))),
            "deviation_next_rest_corr": float(np.corrcoef(deviation[:-1], deviation[1:])[0, 1]),
        })
    return rows


def house_rows(seeds: Sequence[int], workers: int = 2, scheduler: str | None = None) -> list[dict[str, Any]]:
    """Every seed's rows, seeds in order (:func:`lab.runner.seeded_rows`)."""
    from lab.runner import seeded_rows

    return seeded_rows(house_run, seeds, workers, scheduler)


def summary_lines(rows: Sequence[dict[str, Any]]) -> list[str]:
    """Per run: mean ± sd of the end errors and |heading error| (:func:`~.navshoe.error_table`), the
    building's deviation the walks met, and whether the per-step compass wins."""
    from .navshoe import error_table

    first = [r for r in rows if r["run"] == RUNS[0]]
    rms = np.mean([r["deviation_rms_deg"] for r in first])
    corr = np.mean([r["deviation_next_rest_corr"] for r in first])
    head = [f"{SCENARIO}, {len(first)} seeds{stance_words(rows)}: error back at the start after "
            f"{np.mean([r['without_gps_m'] for r in first]):.0f} m indoors (no GPS); the building's "
            f"deviation at the rests {rms:.1f}° RMS (compass σ {INDOOR_COMPASS_SIGMA_DEG:g}°), "
            f"successive rests correlated {corr:.2f}"]
    return head + error_table(rows, "run", RUNS, height=True) + [verdict(rows)]


def verdict(rows: Sequence[dict[str, Any]]) -> str:
    """Whether the per-step compass ends closer to the truth than each other way of tracking the
    walk, and by how much (the other's mean end error over the per-step one's)."""
    mean = {run: float(np.mean([r["end_error_m"] for r in rows if r["run"] == run])) for run in RUNS}
    step = mean[RUNS[0]]

    def listed(runs: list[str]) -> str:
        return ", ".join(f"{run} ({mean[run]:.2f} m, ×{mean[run] / step:.2f})" for run in runs)

    others = list(RUNS[1:4])
    beaten = [run for run in others if step < mean[run]]
    not_beaten = [run for run in others if run not in beaten]
    text = f"per step ({step:.2f} m at the end) wins over {listed(beaten) if beaten else 'none'}"
    return text + (f"; it does not win over {listed(not_beaten)}" if not_beaten else "")
