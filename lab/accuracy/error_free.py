"""The error-free scenario table: every named scenario walked by an error-free module at 1 kHz.

Each scenario (:func:`firmware_sim.sensors.scenarios.list_scenarios`) is simulated with
``SensorConfig.ideal()``, still walking stances (where the ZUPT's zero velocity holds exactly) and
seed 0 at the module's own 1 kHz, replayed through the module
(:func:`firmware_sim.app.batch.run_replay`) and its steps summed by a host
(:func:`hostlib.files.replay.replay_bytes`). Each row: the end error of the summed steps against the
truth's last stance (in the frame the track starts in) in % of the true 3-D path (the straight
lines between the foot's rests), the height error (track minus truth, up positive), the step
packets and the true stances. What the navigation itself loses, with no sensor error to blame
(docs/accuracy.md, "Error-free scenarios at 1 kHz"). Beside it, the same error-free module on a
real foot's swaying stances (the emulator's default walk, ``stance_sway.StanceSway``): what the sway
alone adds.

``python -m lab.accuracy error-free [SCENARIO...]`` prints the table as docs/accuracy.md has it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from lab.runner import map_runs

__all__ = ["RATE_HZ", "error_free_run", "error_free_rows", "table_lines"]

#: The module's own loop rate [Hz].
RATE_HZ = 1000.0


def _walk(scenario: str, stance_sway: bool):
    """The error-free module's source of *scenario*, its end error [m] (3-vector, start frame) and
    its summed steps."""
    from firmware_sim.app.batch import run_replay
    from firmware_sim.sensors.config import SensorConfig
    from firmware_sim.sensors.imu_array import make_source
    from hostlib.files.replay import replay_bytes

    source = make_source(scenario, seed=0, rate_hz=RATE_HZ, config=SensorConfig.ideal(),
                         stance_sway=stance_sway)
    track, _ = replay_bytes(run_replay(source, announce=None))
    return source, track.final_pose[:3] - source.truth.stances_in_start_frame()[-1], track


def error_free_run(scenario: str) -> dict[str, Any]:
    """One scenario walked by an error-free module (module docstring)."""
    from firmware_sim.app.runs import end_errors

    source, error, track = _walk(scenario, stance_sway=False)
    truth = source.truth
    _, sway_error, sway_track = _walk(scenario, stance_sway=True)
    path = truth.distance_m()

    def pct(e: np.ndarray) -> float:
        return 100.0 * float(np.linalg.norm(e)) / path if path > 0 else math.nan

    return {"scenario": scenario, "path_m": path, "end_error_m": float(np.linalg.norm(error)),
            "end_error_pct": pct(error), "north_m": float(error[0]), "east_m": float(error[1]),
            "height_m": end_errors(track, truth)["end_height_m"], "step_packets": len(track),
            "steps": track.motion_steps, "true_stances": len(truth.stance_positions),
            "swaying_end_error_pct": pct(sway_error),
            "swaying_height_m": end_errors(sway_track, truth)["end_height_m"]}


def error_free_rows(scenarios: Sequence[str] | None = None, workers: int = 2, scheduler: str | None = None
                    ) -> list[dict[str, Any]]:
    """:func:`error_free_run` of every named scenario (or of *scenarios*), in that order
    (:func:`lab.runner.map_runs`)."""
    from firmware_sim.sensors.scenarios import list_scenarios

    return map_runs(error_free_run, list(scenarios or list_scenarios()), workers, scheduler)


def table_lines(rows: Sequence[dict[str, Any]]) -> list[str]:
    """The rows as docs/accuracy.md's Markdown table; scenarios without a path (standing, turning
    on the spot) are left out."""
    lines = ["| scenario | 3-D % | height [m] | step packets | true stances | swaying: 3-D % | height [m] |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        if math.isnan(r["end_error_pct"]):
            continue
        height, sway_height = (f"{r[k]:+.3f}".replace("-", "−") for k in ("height_m", "swaying_height_m"))
        lines.append(f"| {r['scenario']} | {r['end_error_pct']:.3f} | {height} | {r['step_packets']} | "
                     f"{r['true_stances']} | {r['swaying_end_error_pct']:.3f} | {sway_height} |")
    return lines
