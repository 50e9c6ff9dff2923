"""The synthetic speed table: 100 m straight at 3–8 km/h and running, at 1 kHz and at 250 Hz.

Each speed is walked (``pace:v+walk:100``; running is the ``run`` piece) by a simulated module,
once by an error-free module (``SensorConfig.ideal()`` and still walking stances, where the
ZUPT's zero velocity holds exactly: what the navigation itself loses) and by modules with the
default sensor errors and a real foot's swaying stances (one per seed; warm, as in
``openshoe-spread``: from power-on the gyros' warm-up would turn the slower walks, which last
longer, the more, and the table would compare durations, not speeds), at the module's own 1 kHz
and at the recordings' 250 Hz. The errors are those of :func:`firmware_sim.app.runs.end_errors`
at the last stance: along and across the true path and in height, in % of the 100 m.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from .runs import map_runs

__all__ = ["SPEEDS_KMH", "RATES_HZ", "speed_recipe", "speed_run", "speed_rows", "summary_lines"]

#: Walking speeds [km/h] of the table, and "run".
SPEEDS_KMH: tuple[float | str, ...] = (3.0, 4.0, 5.0, 6.0, 7.0, 8.0, "run")
#: Loop rates [Hz]: the module's own and the recordings'.
RATES_HZ = (1000.0, 250.0)
#: The straight distance of every run [m].
DISTANCE_M = 100.0


def speed_recipe(speed: float | str) -> str:
    """The scenario recipe of one row: *speed* in km/h, or ``"run"``."""
    if speed == "run":
        return f"stand:3+run:{DISTANCE_M:g}+stand:2"
    return f"stand:3+pace:{float(speed) / 3.6:.6g}+walk:{DISTANCE_M:g}+stand:2"


def speed_run(job: tuple[float | str, float, int | None]) -> dict[str, Any]:
    """One run: *job* = (speed, rate, seed); seed None is the error-free module."""
    from firmware_sim.app.batch import run_replay
    from firmware_sim.app.runs import end_errors
    from firmware_sim.sensors.config import DEFAULT_CONFIG, SensorConfig
    from firmware_sim.sensors.imu_array import make_source
    from hostlib.files.replay import replay_bytes

    speed, rate, seed = job
    if seed is None:
        kwargs = {"config": SensorConfig.ideal(), "stance_sway": False}
    else:  # a warm module: the warm-up would turn the slower walks, which last longer, the more
        kwargs = {"config": DEFAULT_CONFIG.warm()}
    source = make_source(speed_recipe(speed), seed=0 if seed is None else seed, rate_hz=rate, **kwargs)
    track, _ = replay_bytes(run_replay(source, announce=None))
    err = end_errors(track, source.truth)
    return {"speed": str(speed), "rate_hz": rate, "seed": "ideal" if seed is None else seed,
            "steps": track.motion_steps, "true_stances": len(source.truth.stance_positions),
            **{k: 100.0 * err[f"end_{k}_m"] / DISTANCE_M for k in ("along", "across", "height")}}


def speed_rows(seeds: Sequence[int], workers: int = 2) -> list[dict[str, Any]]:
    """Every speed × rate × (error-free, *seeds*), in that order."""
    jobs = [(v, r, s) for v in SPEEDS_KMH for r in RATES_HZ for s in (None, *seeds)]
    return map_runs(speed_run, jobs, workers)


def summary_lines(rows: Sequence[dict[str, Any]]) -> list[str]:
    """Per speed and rate: the error-free module's errors, and the modules' mean ± sd."""
    lines = [f"{'speed':>6} {'rate':>6} {'steps':>6}   {'error-free: along across height [%]':>36}   "
             f"{'with sensor errors, mean ± sd: along / across / height [%]':>58}"]
    for v in SPEEDS_KMH:
        for r in RATES_HZ:
            group = [x for x in rows if x["speed"] == str(v) and x["rate_hz"] == r]
            ideal = next(x for x in group if x["seed"] == "ideal")
            real = [x for x in group if x["seed"] != "ideal"]
            label = "run" if v == "run" else f"{v:g} km/h"
            cells = " / ".join(f"{np.mean([x[k] for x in real]):+.3f} ± {np.std([x[k] for x in real]):.3f}"
                               for k in ("along", "across", "height")) if real else "–"
            lines.append(f"{label:>8} {r:5.0f} {ideal['steps']:>5}   {ideal['along']:+10.3f} "
                         f"{ideal['across']:+7.3f} {ideal['height']:+7.3f}         {cells}")
    return lines
