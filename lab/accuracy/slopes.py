"""The slope paper's experiment, simulated: ramps walked up and back down, and a flat control.

Each ramp scenario (:data:`RAMPS`) is walked by simulated modules (one per seed, the default
sensor errors) and replayed with the fusion host, with and without the module's height
compensation (:func:`.runs.replay_track`). The height error is the track's height minus the
true height, up positive: at the top (the highest point of each) and at the end of the walk.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from lab.runner import map_runs

from .runs import height_profile, replay_track

__all__ = ["RAMPS", "FLAT", "slope_run", "slope_rows", "summary_lines"]

#: The ramps: 50 m up and back down on roads of 0°, 2.5°, 6.1° and 7.5°, and 7.8° walked at 45°
#: to the fall line (firmware_sim.sensors.scenarios).
RAMPS = ("ramp_0", "ramp_2.5", "ramp_6", "ramp_7.5", "ramp_diagonal")
#: The flat control: 100 m straight on level ground.
FLAT = "walk"


def slope_run(job: tuple[str, int]) -> list[dict[str, Any]]:
    """Walk *job* = (scenario, seed) once and replay it without and with height compensation: the
    height errors and profile of each (the same simulated walk: only the module's setting differs)."""
    from firmware_sim.sensors.imu_array import make_source

    scenario, seed = job
    source = make_source(scenario, seed=seed)
    dlpf = source.dlpf_cfg
    rows = []
    for hc in (False, True):
        source.set_dlpf(dlpf)  # as simulated, whatever the replay before set
        run = replay_track(source, hc, truth=source.truth)
        d, h = height_profile(run.track)
        true_h = -run.truth.stances_in_start_frame()[:, 2]
        rows.append({"scenario": scenario, "seed": seed, "height_compensation": hc,
                     "true_top_m": float(true_h.max()),
                     "top_error_m": float(h.max() - true_h.max()) if true_h.max() > 0 else float(h.max()),
                     "end_error_m": float(h[-1] - true_h[-1]),
                     "distance_m": float(run.track.distance), "profile": (d, h)})
    return rows


def slope_rows(seeds: Sequence[int], workers: int = 2, scenarios: Sequence[str] = (*RAMPS, FLAT),
               scheduler: str | None = None) -> list[dict[str, Any]]:
    """Every scenario × seed × (off, on), in that order (:func:`lab.runner.map_runs`, a job a walk)."""
    jobs = [(s, seed) for s in scenarios for seed in seeds]
    return [row for rows in map_runs(slope_run, jobs, workers, scheduler) for row in rows]


def summary_lines(rows: Sequence[dict[str, Any]]) -> list[str]:
    """Per scenario, off and on: the height error at the top and at the end, mean and largest |·|."""
    lines = [f"{'scenario':<15}{'true top':>9}  {'height error at the top [m]':>31}  "
             f"{'height error at the end [m]':>31}",
             f"{'':<15}{'[m]':>9}  {'off: mean (max)':>16}{'on: mean (max)':>17}  "
             f"{'off: mean (max)':>16}{'on: mean (max)':>17}"]
    for scenario in dict.fromkeys(r["scenario"] for r in rows):
        cell = ""
        for key in ("top_error_m", "end_error_m"):
            for hc in (False, True):
                v = np.array([r[key] for r in rows if r["scenario"] == scenario
                              and r["height_compensation"] == hc])
                cell += f"{v.mean():>+8.3f} ({np.abs(v).max():.3f}) "
            cell += "  "
        top = next(r["true_top_m"] for r in rows if r["scenario"] == scenario)
        lines.append(f"{scenario:<15}{top:>9.2f}  {cell}")
    n = len({r["seed"] for r in rows})
    lines.append(f"{n} simulated modules per scenario; off: the module as it tracks by default, on: its "
                 "height compensation (function 0x25) turned on by the host")
    return lines
