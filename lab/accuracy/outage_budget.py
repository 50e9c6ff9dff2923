"""What each error costs NavShoe's flow on the outage loop (diagnosis only: it reads the simulator's
truth, which no host may).

Per seed s and flow (``o``: calibrated first, ``w``: the wiggle inside the walk), the captures of
:func:`lab.accuracy.navshoe_in_situ.make_captures` go through ``openshoe-host replay --gps G --compass``
with the defaults (``--calibrate-mag`` with the wiggle inside) once per *oracle*, the truth put into
the host one part at a time:

* ``defaults``: nothing;
* ``deviation removed``: each compass reading corrected by the simulated deviation where the foot
  stood (:meth:`~firmware_sim.sensors.magnetic.MagneticWorld.heading_deviation`);
* ``perfect compass``: each reading the true heading less the true declination;
* ``true declination``: the declination state fixed at the simulated one (its variance 0);
* ``true declination, deviation removed``: both.

Per run: the end error in % of the distance without GPS, the tool's way (the CSV's first and last
rows: the first row is the first fix) and against the truth (the last row against where the walk
ended, in the first fix's frame); the declination learned less the true one where the receiver fell
silent (as the aids' last event at or before the first step at or after the last fix said); the heading
error there and its mean over the outage.

Run: ``python -m lab.accuracy.outage_budget 2:o 3:w`` (docs/heading-aids.md, "Why seed 2 … and seed 3
… still miss").
"""

from __future__ import annotations

import contextlib
import io
import math
import sys
import tempfile
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any
from unittest import mock

import numpy as np

__all__ = ["ORACLES", "budget_run", "summary_lines"]

#: the parts of the truth put into the host, one run each (module docstring)
ORACLES = ("defaults", "deviation removed", "perfect compass", "true declination",
           "true declination, deviation removed")
#: the flows: capture, the options after it (the calibration: saved first, or fitted from the wiggle)
FLOWS = {"o": ("calibrated first", ["--compass", "--mag-cal-dir", "saved"]),
         "w": ("wiggle inside", ["--compass", "--calibrate-mag", "--mag-cal-dir", "fitted"])}


@contextlib.contextmanager
def _oracle(source: Any, oracle: str, trackers: list) -> Iterator[None]:
    """While open, every :class:`~hostlib.fusion.tracker.FusionTracker` made is appended to *trackers*
    with a list its aids' events fill, (step, declination [rad]), and has *oracle*'s truth put in
    (module docstring)."""
    from hostlib.fusion.tracker import FusionTracker

    truth = source.truth
    declination = math.radians(source.config.mag.declination_deg)
    init, heading = FusionTracker.__init__, FusionTracker.compass_heading

    def made(tracker, *args, **kwargs):
        init(tracker, *args, **kwargs)
        history: list[tuple[int, float]] = []
        tracker.observe_aids(lambda event: history.append((event.step, event.declination)))
        trackers.append((tracker, history))
        if oracle.startswith("true declination"):
            f = tracker.filter
            k = f.index("declination")
            f.x[k] = declination
            f.P[k, :] = 0.0
            f.P[:, k] = 0.0

    def read(tracker, reading):
        psi = heading(tracker, reading)
        if psi is None or oracle in ("defaults", "true declination"):
            return psi
        i = min(int(np.searchsorted(truth.t, tracker._time)), len(truth.t) - 1)
        if oracle == "perfect compass":
            r = truth.R[i]
            return math.atan2(r[1, 0], r[0, 0]) - declination
        return psi + float(source.magnetic.heading_deviation(truth.pos[i:i + 1])[0])

    with mock.patch.object(FusionTracker, "__init__", made), \
            mock.patch.object(FusionTracker, "compass_heading", read):
        yield


def budget_run(seed: int, flow: str, oracles: Sequence[str] = ORACLES) -> list[dict[str, Any]]:
    """A row per oracle of *seed*'s *flow* (module docstring)."""
    from firmware_sim.sensors.imu_array import make_source
    from hostlib.cli import main

    from .navshoe import walk_fixes
    from .navshoe_in_situ import make_captures, module_for

    scenario = "navshoe-outage" if flow == "o" else "navshoe-wiggle-outage"
    source = make_source(scenario, seed=seed, module=module_for(seed))
    truth = source.truth
    fixes = walk_fixes(scenario, truth.t, truth.pos, truth.vel, seed)
    yaw = np.unwrap(np.arctan2(truth.R[:, 1, 0], truth.R[:, 0, 0]))
    declination = math.radians(source.config.mag.declination_deg)
    name, options = FLOWS[flow]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        make_captures(seed, d)
        for k, oracle in enumerate(oracles):
            trackers: list = []
            out = d / f"{flow}{k}.csv"
            argv = [str(d / f"{flow}.bin"), "--gps", str(d / f"{flow}.nmea"), *options[:-1],
                    str(d / f"{options[-1]}{k}" if flow == "w" else d / options[-1]), "--csv", str(out)]
            with _oracle(source, oracle, trackers):
                if main(["replay", *argv], io.StringIO()) != 0:
                    raise RuntimeError(f"openshoe-host replay {' '.join(argv)} failed")
            rows.append({"seed": seed, "flow": name, "oracle": oracle,
                         **_errors(*trackers[-1], out, truth, yaw, fixes, declination)})
    return rows


def _errors(tracker: Any, history: Sequence[tuple[int, float]], csv_path: Path, truth: Any, yaw: np.ndarray,
            fixes: Any, declination: float) -> dict[str, float]:
    """The row's figures of a run whose *tracker* wrote *csv_path*, its aids' events' (step, declination)
    in *history*, against the walk's *truth*, its true heading *yaw*, receiver *fixes* and *declination*
    (module docstring)."""
    from hostlib.aids.compass import wrap_angle

    from .navshoe_in_situ import WITHOUT_GPS_M, end_error_m

    times = np.asarray(tracker.step_times)
    poses = np.asarray(tracker.track.poses)[1:]
    i = np.clip(np.searchsorted(truth.t, times), 0, len(truth.t) - 1)
    heading = np.array([wrap_angle(a - b) for a, b in zip(poses[:, 3], yaw[i], strict=True)])
    silent = min(int(np.searchsorted(times, fixes.times_s[-1])), len(times) - 1)
    end = truth.pos[-1, :2] - fixes.first_fix
    learned = [d for step, d in history if step <= silent + 1] or [math.nan]
    return {"end_error_pct_csv": 100.0 * end_error_m(csv_path) / WITHOUT_GPS_M,
            "end_error_pct_truth": 100.0 * float(np.hypot(*(poses[-1, :2] - end))) / WITHOUT_GPS_M,
            "declination_error_silent_deg": math.degrees(learned[-1] - declination),
            "heading_error_silent_deg": math.degrees(heading[silent]),
            "heading_error_outage_deg": math.degrees(float(np.mean(heading[silent:])))}


def summary_lines(rows: Sequence[dict[str, Any]]) -> list[str]:
    """A line per seed, flow and oracle."""
    out = ["navshoe-outage, NavShoe's flow with the defaults, the truth put in one part at a time: end error "
           "% of 631 m (the CSV's first and last rows / against the truth); declination − true where the "
           "receiver fell silent; heading − true there, and its mean over the outage"]
    for r in rows:
        out.append(f"  seed {r['seed']:>2} {r['flow']:<16} {r['oracle']:<37} {r['end_error_pct_csv']:5.2f} / "
                   f"{r['end_error_pct_truth']:5.2f} %   D {r['declination_error_silent_deg']:+5.2f}°   "
                   f"heading {r['heading_error_silent_deg']:+5.2f}°, {r['heading_error_outage_deg']:+5.2f}°")
    return out


if __name__ == "__main__":
    walks = [(int(a), b) for a, b in (w.split(":") for w in sys.argv[1:] or ["2:o", "3:w"])]
    print("\n".join(summary_lines([row for seed, flow in walks for row in budget_run(seed, flow)])))
