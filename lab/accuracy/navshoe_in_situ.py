"""NavShoe's flow on the outage loop, through the command lines a user types: calibrate in situ, then
walk (shared/spec/aids.md §2–3), with no file from the simulator's truth.

Per seed s, module 40 + s (its own systematic errors and shoe iron on every walk):

* ``separate``: ``openshoe-emu replay --scenario navshoe-calibration --seed s --module 40+s --host
  fusion --calibrate-mag``, whose capture ``openshoe-host replay --compass --calibrate-mag`` fits and
  saves for the module (``--mag-cal-dir``); then ``navshoe-outage`` walked with the same module and
  its GPS log, and ``openshoe-host replay --gps G [--compass [--compass-swing]]`` takes the saved
  calibration;
* ``in the walk``: ``navshoe-wiggle-outage`` (the wiggle where the loop starts), one capture that
  ``openshoe-host replay --gps G --compass --calibrate-mag [--compass-swing]`` calibrates and
  navigates.

The end error is the distance between the track's first and last rows of the CSV (the loop closes
within centimetres), as % of the distance walked without GPS (631 m on the outage loop).
"""

from __future__ import annotations

import csv
import io
import math
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["HOSTS", "WITHOUT_GPS_M", "calibrate_in_situ", "emu_replay", "end_error_m", "host_replay",
           "in_situ_rows", "in_situ_run", "make_captures", "module_for", "summary_lines"]

#: the distance the outage loop walks after the receiver's last fix [m]
WITHOUT_GPS_M = 631.0
#: (flow, host) → the host's options after the capture and its GPS log
HOSTS: dict[tuple[str, str], list[str]] = {
    ("separate", "--gps"): [],
    ("separate", "--gps --compass"): ["--compass"],
    ("separate", "--gps --compass --compass-swing"): ["--compass", "--compass-swing"],
    ("in the walk", "--gps"): [],
    ("in the walk", "--gps --compass --calibrate-mag"): ["--compass", "--calibrate-mag"],
    ("in the walk", "--gps --compass --calibrate-mag --compass-swing"): ["--compass", "--calibrate-mag",
                                                                        "--compass-swing"],
}


def emu_replay(*argv: str) -> None:
    """``openshoe-emu replay ARGV -q``, in this process."""
    from firmware_sim.app.cli import main

    if main(["replay", *argv, "-q"]) != 0:
        raise RuntimeError(f"openshoe-emu replay {' '.join(argv)} failed")


def host_replay(*argv: str) -> None:
    """``openshoe-host replay ARGV`` (its printout dropped), in this process."""
    from hostlib.cli import main

    if main(["replay", *argv], io.StringIO()) != 0:
        raise RuntimeError(f"openshoe-host replay {' '.join(argv)} failed")


def end_error_m(csv_path: Path) -> float:
    """The distance [m] between the first and the last row of a track's CSV."""
    with open(csv_path, newline="") as f:
        rows = list(csv.DictReader(f))
    first, last = rows[0], rows[-1]
    return math.hypot(float(last["x_north_m"]) - float(first["x_north_m"]),
                      float(last["y_east_m"]) - float(first["y_east_m"]))


def module_for(seed: int) -> int:
    """The module that walks *seed*'s walks: a new one each seed, numbered apart from the seeds."""
    return 40 + seed


def calibrate_in_situ(seed: int, d: Path) -> list[str]:
    """NavShoe's calibration walk of *seed*'s module, captured in *d* (``c.bin``) and its fit saved for
    the module in ``d/saved``; the options that walk the same module again."""
    walk = ["--seed", str(seed), "--module", str(module_for(seed)), "--host", "fusion"]
    emu_replay("--scenario", "navshoe-calibration", *walk, "--calibrate-mag", "--wire", str(d / "c.bin"))
    host_replay(str(d / "c.bin"), "--compass", "--calibrate-mag", "--mag-cal-dir", str(d / "saved"))
    return walk


def make_captures(seed: int, d: Path) -> None:
    """*seed*'s walks in directory *d* (module docstring): the calibration's capture ``c.bin`` and its
    fit saved in ``saved/``; the outage loop ``o.bin`` and the loop with the wiggle inside ``w.bin``,
    each with its GPS log (``o.nmea``, ``w.nmea``)."""
    walk = calibrate_in_situ(seed, d)
    emu_replay("--scenario", "navshoe-outage", *walk, "--gps", str(d / "o.nmea"), "--wire", str(d / "o.bin"))
    emu_replay("--scenario", "navshoe-wiggle-outage", *walk, "--calibrate-mag", "--gps", str(d / "w.nmea"),
         "--wire", str(d / "w.bin"))


def in_situ_run(seed: int) -> list[dict[str, Any]]:
    """The rows of every host of :data:`HOSTS` on *seed*'s walks (module docstring)."""
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        make_captures(seed, d)
        for k, ((flow, host), options) in enumerate(HOSTS.items()):
            capture = "o" if flow == "separate" else "w"
            cal_dir = d / ("saved" if flow == "separate" else f"fitted{k}")
            out = d / f"{k}.csv"
            host_replay(str(d / f"{capture}.bin"), "--gps", str(d / f"{capture}.nmea"), *options,
                  "--mag-cal-dir", str(cal_dir), "--csv", str(out))
            error = end_error_m(out)
            rows.append({"seed": seed, "module": module_for(seed), "flow": flow, "host": host,
                         "end_error_m": error, "end_error_pct_without_gps": 100.0 * error / WITHOUT_GPS_M})
    return rows


def in_situ_rows(seeds: Sequence[int], workers: int = 2, scheduler: str | None = None
                 ) -> list[dict[str, Any]]:
    """Every seed's rows, seeds in order (:func:`lab.runner.seeded_rows`)."""
    from lab.runner import seeded_rows

    return seeded_rows(in_situ_run, seeds, workers, scheduler)


def summary_lines(rows: Sequence[dict[str, Any]]) -> list[str]:
    """Per flow and host: the end error as % of the distance without GPS, per seed, the mean and the
    worst; how many seeds end within 1 % and within half the GPS-only host's error."""
    seeds = sorted({r["seed"] for r in rows})
    out = [f"NavShoe's flow, calibrated in situ, navshoe-outage, {len(seeds)} seeds (module 40 + seed): "
           f"end error, % of the {WITHOUT_GPS_M:g} m without GPS"]
    for flow, host in HOSTS:
        pct = _percent(rows, flow, host)
        gps = _percent(rows, flow, "--gps")
        values = np.array([pct[s] for s in seeds])
        half = sum(pct[s] <= 0.5 * gps[s] for s in seeds)
        out.append(f"  {flow:<12} {host:<48} mean {values.mean():5.2f}  worst {values.max():5.2f}  "
                   f"≤ 1 %: {int((values <= 1.0).sum())}/{len(seeds)}  ≤ 0.5× --gps: {half}/{len(seeds)}   "
                   + " ".join(f"{v:.2f}" for v in values))
    return out


def _percent(rows: Sequence[dict[str, Any]], flow: str, host: str) -> dict[int, float]:
    """Seed → the end error [% of the distance without GPS] of *flow*'s *host*."""
    return {r["seed"]: r["end_error_pct_without_gps"] for r in rows if (r["flow"], r["host"]) == (flow, host)}
