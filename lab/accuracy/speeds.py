"""The synthetic speed table: 100 m straight at 3–8 km/h and running, at 1 kHz and at 250 Hz.

Each speed is walked (``pace:v+walk:100``; running is the ``run`` piece) by a simulated module,
once by an error-free module (``SensorConfig.ideal()`` and still walking stances, where the
ZUPT's zero velocity holds exactly: what the navigation itself loses) and by modules with the
default sensor errors and a real foot's swaying stances (one per seed; warm, as in
``python -m lab.spread``: from power-on the gyros' warm-up would turn the slower walks, which last
longer, the more, and the table would compare durations, not speeds), at the module's own 1 kHz
and at the recordings' 250 Hz. The errors are those of :func:`firmware_sim.app.runs.end_errors`
at the last stance: along and across the true path and in height, in % of the 100 m.

The experiment is a sweep spec, :data:`SPEC` (``lab/accuracy/speeds.toml``): ``openshoe-emu sweep
--spec lab/accuracy/speeds.toml`` runs all of it (each model on both stances); the table reads its
runs of the error-free module on still stances (the first seed: on still stances an error-free
module's walk is the same whatever the seed) and of the modules with errors on the simulation's
own stances (:func:`firmware_sim.sensors.stance_sway.stance_sway_on`: swaying, unless
``OPENSHOE_STANCE_SWAY=0``), and runs only those (:func:`table_runs`), as the sweep runs them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from lab.runner import execute

if TYPE_CHECKING:
    from firmware_sim.app.runs import RunSpec
    from firmware_sim.app.sweep import SweepSpec

__all__ = ["SPEC", "SPEEDS_KMH", "RATES_HZ", "speed_recipe", "speed_spec", "table_runs", "speed_run",
           "table_row", "speed_rows", "summary_lines"]

#: The sweep spec of the experiment.
SPEC = Path(__file__).with_name("speeds.toml")
#: Walking speeds [km/h] of the table, and "run".
SPEEDS_KMH: tuple[float | str, ...] = (3.0, 4.0, 5.0, 6.0, 7.0, 8.0, "run")
#: Loop rates [Hz]: the module's own and the recordings'.
RATES_HZ = (1000.0, 250.0)
#: The straight distance of every run [m].
DISTANCE_M = 100.0
#: The spec's settings a run of the table is told by.
RATE, MODEL, SWAY = "scenario.rate_hz", "sensors.model", "scenario.stance_sway"


def speed_recipe(speed: float | str) -> str:
    """The scenario recipe of one row: *speed* in km/h, or ``"run"``."""
    if speed == "run":
        return f"stand:3+run:{DISTANCE_M:g}+stand:2"
    return f"stand:3+pace:{float(speed) / 3.6:.6g}+walk:{DISTANCE_M:g}+stand:2"


def speed_spec(seeds: Sequence[int] | None = None) -> SweepSpec:
    """:data:`SPEC`, walked by *seeds* (None: the spec's own)."""
    from firmware_sim.app.sweep import load_spec_file

    spec = load_spec_file(SPEC)
    if seeds is not None:
        spec = replace(spec, seeds=tuple(seeds))
    spec.check()
    return spec


def table_runs(spec: SweepSpec) -> list[RunSpec]:
    """The runs of *spec* the table reads (module docstring), in the spec's order."""
    from firmware_sim.sensors.stance_sway import stance_sway_on

    sway = stance_sway_on(None)

    def read(run: RunSpec) -> bool:
        s = dict(run.settings)
        if s[MODEL] == "ideal":
            return not s[SWAY] and run.seed == spec.seeds[0]
        return s[SWAY] == sway

    return [run for run in spec.runs() if read(run)]


def speed_run(run: RunSpec) -> dict[str, Any]:
    """The sweep's row of *run* (:func:`firmware_sim.app.runs.run_one`) and the walk's true stances."""
    from firmware_sim.app import runs

    loaded = runs.load(run)
    return {**runs.finish(run, loaded), "true_stances": len(loaded.truth.stance_positions)}


def table_row(run: RunSpec, row: dict[str, Any]) -> dict[str, Any]:
    """The table's row of *run*'s :func:`speed_run` *row*: speed, rate, seed ("ideal" for the
    error-free module), steps, true stances and the end errors in % of the 100 m."""
    speed = {speed_recipe(v): v for v in SPEEDS_KMH}[run.source]
    s = dict(run.settings)
    return {"speed": str(speed), "rate_hz": s[RATE], "seed": "ideal" if s[MODEL] == "ideal" else run.seed,
            "steps": row["steps"], "true_stances": row["true_stances"],
            **{k: 100.0 * row[f"end_{k}_m"] / DISTANCE_M for k in ("along", "across", "height")}}


def speed_rows(seeds: Sequence[int], workers: int = 2, scheduler: str | None = None) -> list[dict[str, Any]]:
    """Every speed × rate × (error-free, *seeds*), in that order: :func:`table_runs` of the spec
    walked by *seeds*, through the project's runner (:func:`lab.runner.execute`)."""
    runs = table_runs(speed_spec(seeds))
    done = execute(runs, workers=workers, scheduler=scheduler, runner=speed_run)
    rows = [table_row(run, row) for run, row in zip(runs, done, strict=True)]
    speeds = [str(v) for v in SPEEDS_KMH]
    order = {"ideal": -1, **{seed: i for i, seed in enumerate(seeds)}}
    return sorted(rows, key=lambda r: (speeds.index(r["speed"]), RATES_HZ.index(r["rate_hz"]),
                                       order[r["seed"]]))


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
