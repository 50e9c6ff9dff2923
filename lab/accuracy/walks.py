"""Closed-loop recordings with the module's height compensation and the host's drift correction.

Every walk is replayed twice with the fusion host (:func:`.runs.replay_track`): as the module
tracks by default, and with height compensation on. Drift correction is leave-one-out: walk *i*
is corrected with :func:`hostlib.calibration.drift.calibrate` of the other walks' tracks (of the same kind,
plain or height-compensated), so no walk ever calibrates itself. Closures are those of
:meth:`hostlib.track.steps.Track.relative_closure_error`, in % of the horizontal distance walked.
The walks are closed loops on level ground, so the height should stay 0: :func:`height_lines`
gives each track's height at its end and its RMS over the track's poses (:func:`.runs.height_profile`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from lab.runner import map_runs

from .runs import Replayed, height_profile, replay_track

__all__ = ["VARIANTS", "WalkResult", "replay_walk", "walk_results", "table_lines", "height_lines"]

#: The four ways a walk is tracked: (name, height compensation in the module, drift correction).
VARIANTS = (("plain", False, False), ("height", True, False), ("drift", False, True), ("both", True, True))


def replay_walk(job: tuple[str, bool]) -> Replayed:
    """Replay the recording *job* = (path, height compensation) with the fusion host."""
    from firmware_sim.sensors.replay import ReplaySource

    path, height_compensation = job
    return replay_track(ReplaySource.from_file(path), height_compensation)


@dataclass
class WalkResult:
    """One walk: its name, distance and, per variant, the corrected track's closures [%] and
    height [m] (up positive: at the end, and the RMS over its poses)."""

    name: str
    distance_m: float
    horizontal_pct: dict[str, float]
    closure_3d_pct: dict[str, float]
    tracks: dict[str, Any]  #: variant → the (corrected) Track
    end_height_m: dict[str, float]
    rms_height_m: dict[str, float]


def walk_results(paths: Sequence[str | Path], workers: int = 2, scheduler: str | None = None
                 ) -> list[WalkResult]:
    """Replay every recording both ways (:func:`lab.runner.map_runs`) and correct each with the
    others' drift calibration."""
    from hostlib.calibration.drift import calibrate

    if len(paths) < 2:
        raise ValueError("leave-one-out drift correction needs at least two walks")
    jobs = [(str(p), hc) for p in paths for hc in (False, True)]
    replayed = dict(zip(jobs, map_runs(replay_walk, jobs, workers, scheduler), strict=True))
    out = []
    for i, path in enumerate(map(str, paths)):
        tracks: dict[str, Any] = {}
        for name, hc, drift in VARIANTS:
            own = replayed[(path, hc)]
            if drift:
                others = [replayed[(str(p), hc)] for j, p in enumerate(paths) if j != i]
                cal = calibrate([o.track for o in others], others[0].serial,
                                names=[Path(p).stem for j, p in enumerate(paths) if j != i])
                tracks[name] = cal.apply(own.track, module_serial=own.serial, what=Path(path).stem)
            else:
                tracks[name] = own.track
        heights = {k: height_profile(t)[1] for k, t in tracks.items()}
        out.append(WalkResult(
            Path(path).stem, float(tracks["plain"].distance),
            {k: 100.0 * t.relative_closure_error() for k, t in tracks.items()},
            {k: 100.0 * t.relative_closure_error(horizontal=False) for k, t in tracks.items()},
            tracks, {k: float(h[-1]) for k, h in heights.items()},
            {k: float(np.sqrt(np.mean(h * h))) for k, h in heights.items()}))
    return out


def table_lines(results: Sequence[WalkResult]) -> list[str]:
    """A per-walk table of horizontal / 3-D closure [%] per variant, and the means."""
    names = [v[0] for v in VARIANTS]
    head = f"{'walk':<16}{'distance':>9}" + "".join(f"{n + ' h/3-D [%]':>22}" for n in names)
    lines = [head]

    def cells(h: dict[str, float], d: dict[str, float]) -> str:
        return "".join(f"{h[n]:>12.3f} /{d[n]:>7.3f}  " for n in names)

    for r in results:
        lines.append(f"{r.name:<16}{r.distance_m:>8.1f}m" + cells(r.horizontal_pct, r.closure_3d_pct))
    mean_h = {n: float(np.mean([r.horizontal_pct[n] for r in results])) for n in names}
    mean_d = {n: float(np.mean([r.closure_3d_pct[n] for r in results])) for n in names}
    lines.append(f"{'mean':<16}{'':>9}" + cells(mean_h, mean_d))
    lines.append("plain: the module as it tracks by default; height: its height compensation on; drift: "
                 "the host's drift correction calibrated on the other walks (leave-one-out); both: the two")
    return lines


def height_lines(results: Sequence[WalkResult], variants: Sequence[str] = ("plain", "height")) -> list[str]:
    """Per walk, each of *variants*' height at the end and its RMS over the walk [m], and the means."""
    lines = [f"{'walk':<16}" + "".join(f"{v + ': end / RMS height [m]':>30}  " for v in variants)]

    def cells(end: dict[str, float], rms: dict[str, float]) -> str:
        return "".join(f"{end[v]:>+21.3f} /{rms[v]:>7.3f}  " for v in variants)

    for r in results:
        lines.append(f"{r.name:<16}" + cells(r.end_height_m, r.rms_height_m))
    lines.append(f"{'mean':<16}" + cells(
        {v: float(np.mean([r.end_height_m[v] for r in results])) for v in variants},
        {v: float(np.mean([r.rms_height_m[v] for r in results])) for v in variants}))
    return lines


def rows(results: Sequence[WalkResult]) -> list[dict[str, Any]]:
    """The table as rows for a CSV."""
    out = []
    for r in results:
        row: dict[str, Any] = {"walk": r.name, "distance_m": r.distance_m}
        for n, _, _ in VARIANTS:
            row[f"{n}_horizontal_pct"] = r.horizontal_pct[n]
            row[f"{n}_3d_pct"] = r.closure_3d_pct[n]
            row[f"{n}_end_height_m"] = r.end_height_m[n]
            row[f"{n}_rms_height_m"] = r.rms_height_m[n]
        out.append(row)
    return out
