"""NavShoe's house walk through the command lines a user types: calibrate in situ, then walk the
house with the host's defaults (shared/spec/aids.md §1–2), with no file from the simulator's truth.

Per seed s, module 40 + s (its own systematic errors and shoe iron, as in
:mod:`lab.accuracy.navshoe_in_situ`): the calibration walk ``navshoe-calibration``, whose capture
``openshoe-host replay --compass --calibrate-mag`` fits and saves for the module; then
``navshoe-house`` walked with the same module (indoors: no GPS), and ``openshoe-host replay`` of its
capture three ways, each with nothing but the defaults:

* ``plain``: no compass (the module's errors held, as by default);
* ``--compass``: the per-step compass, which takes the module's saved calibration (the indoor
  deviation held, as by default without GPS);
* ``--compass, not calibrated``: the same without a calibration (a user who skipped the wiggle).

The walk ends where it starts (the front door), so the end error is the distance between the
track's first and last rows of the CSV, in % of the walk's path (:data:`HOUSE_PATH_M`).
:mod:`lab.accuracy.house` is the paper's experiment instead: the true iron and declination, and a
plain track given the true initial heading.
"""

from __future__ import annotations

import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .navshoe_in_situ import calibrate_in_situ, emu_replay, end_error_m, host_replay, module_for

__all__ = ["HOSTS", "HOUSE_PATH_M", "house_in_situ_rows", "house_in_situ_run", "summary_lines"]

#: the house walk's path [m], its stairs included
HOUSE_PATH_M = 118.4
#: host → its options after the capture (and the folder of saved calibrations)
HOSTS: dict[str, list[str]] = {
    "plain": [],
    "--compass": ["--compass"],
    "--compass, not calibrated": ["--compass"],
}


def house_in_situ_run(seed: int) -> list[dict[str, Any]]:
    """The rows of every host of :data:`HOSTS` on *seed*'s house walk (module docstring)."""
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        walk = calibrate_in_situ(seed, d)
        emu_replay("--scenario", "navshoe-house", *walk, "--wire", str(d / "h.bin"))
        for k, (host, options) in enumerate(HOSTS.items()):
            saved = d / ("none" if host.endswith("not calibrated") else "saved")
            out = d / f"{k}.csv"
            host_replay(str(d / "h.bin"), *options, "--mag-cal-dir", str(saved), "--csv", str(out))
            error = end_error_m(out)
            rows.append({"seed": seed, "module": module_for(seed), "host": host, "end_error_m": error,
                         "end_error_pct": 100.0 * error / HOUSE_PATH_M})
    return rows


def house_in_situ_rows(seeds: Sequence[int], workers: int = 2, scheduler: str | None = None
                       ) -> list[dict[str, Any]]:
    """Every seed's rows, seeds in order (:func:`lab.runner.seeded_rows`)."""
    from lab.runner import seeded_rows

    return seeded_rows(house_in_situ_run, seeds, workers, scheduler)


def summary_lines(rows: Sequence[dict[str, Any]]) -> list[str]:
    """Per host: the end error in % of the path, per seed, the mean and the worst; the seeds on which
    it ends nearer the start than the plain host."""
    seeds = sorted({r["seed"] for r in rows})
    pct = {(r["host"], r["seed"]): r["end_error_pct"] for r in rows}
    out = [f"NavShoe's house walk, calibrated in situ, {len(seeds)} seeds (module 40 + seed), the host's "
           f"defaults: end error, % of the {HOUSE_PATH_M:g} m path"]
    for host in HOSTS:
        values = np.array([pct[host, s] for s in seeds])
        better = sum(pct[host, s] < pct["plain", s] for s in seeds)
        out.append(f"  {host:<26} mean {values.mean():5.3f}  worst {values.max():5.3f}  "
                   f"nearer than plain: {better}/{len(seeds)}   " + " ".join(f"{v:.3f}" for v in values))
    return out
