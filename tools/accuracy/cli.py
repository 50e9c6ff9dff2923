"""The command line of `openshoe-accuracy` (:mod:`tools.accuracy`)."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["build_parser", "main"]

PROG = "openshoe-accuracy"


def build_parser() -> argparse.ArgumentParser:
    from . import __doc__ as doc

    p = argparse.ArgumentParser(prog=PROG, description=(doc or "").split("\n\n")[0])
    sub = p.add_subparsers(dest="experiment", required=True)
    w = sub.add_parser("walks", help="closed-loop recordings: height compensation and leave-one-out drift "
                                     "correction, per walk")
    w.add_argument("files", nargs="+", type=Path, metavar="FILE", help="closed-loop recordings (≥ 2)")
    s = sub.add_parser("slopes",
                       help="simulated ramps up and down, height error with and without compensation")
    s.add_argument("--seeds", default="1:6", metavar="A:B", help="simulated modules (default 1:6, five)")
    v = sub.add_parser("speeds", help="simulated 100 m straight at 3–8 km/h and running, at 1 kHz and "
                                      "250 Hz: the error-free module's and the modules' end errors")
    v.add_argument("--seeds", default="1:6", metavar="A:B", help="simulated modules (default 1:6, five)")
    n = sub.add_parser("navshoe-outage",
                       help="NavShoe's outage experiment: a 1 km hilly loop outdoors, GPS for the first "
                            "400 m; compass + GPS, GPS only, compass only, plain")
    n.add_argument("--seeds", default="1:21", metavar="A:B", help="simulated walks (default 1:21, twenty)")
    for q in (w, s, v, n):
        q.add_argument("--workers", type=int, default=2,
                       help="local Dask worker processes (default 2; 0 = here, one after the other)")
        q.add_argument("--out", type=Path, default=Path("accuracy-out"), metavar="DIR",
                       help="write the table (CSV) and the height picture here (default accuracy-out)")
    return p


def _write_csv(path: Path, rows: Sequence[dict[str, Any]]) -> Path:
    """*rows* as CSV, without the height profiles they carry for the pictures."""
    from firmware_sim.app.runs import write_rows

    return write_rows(rows, path, [k for k in rows[0] if k != "profile"])


def _walks(args: argparse.Namespace, out) -> int:
    from . import walks
    from .figure import plot_heights
    from .runs import height_profile

    missing = [str(f) for f in args.files if not f.is_file()]
    if missing:
        print(f"{PROG}: no such recording: {', '.join(missing)}", file=sys.stderr)
        return 2
    results = walks.walk_results(args.files, workers=args.workers)
    for line in walks.table_lines(results):
        print(line, file=out)
    first = results[0]
    png = plot_heights(args.out / "height-walk.png", f"{first.name}: a closed loop's height (returns to 0)",
                       height_profile(first.tracks["plain"]), height_profile(first.tracks["height"]))
    print(f"results: {_write_csv(args.out / 'walks.csv', walks.rows(results))}, {png}", file=out)
    return 0


def _slopes(args: argparse.Namespace, out) -> int:
    from . import slopes
    from .figure import plot_heights

    seeds = _seeds(args)
    if seeds is None:
        return 2
    rows = slopes.slope_rows(seeds, workers=args.workers)
    for line in slopes.summary_lines(rows):
        print(line, file=out)
    pick = [r for r in rows if r["scenario"] == "ramp_6" and r["seed"] == seeds[0]]
    off, on = (next(r["profile"] for r in pick if r["height_compensation"] == hc) for hc in (False, True))
    png = plot_heights(args.out / "height-ramp.png", f"ramp_6 (6.1°, 50 m up and back), module {seeds[0]}",
                       off, on, truth=_true_profile("ramp_6"))
    print(f"results: {_write_csv(args.out / 'slopes.csv', rows)}, {png}", file=out)
    return 0


def _seeds(args: argparse.Namespace) -> list[int] | None:
    """The seeds of ``--seeds``; None (said on stderr) when they do not parse."""
    from firmware_sim.app.runs import parse_seeds

    try:
        return parse_seeds(args.seeds)
    except ValueError as e:
        print(f"{PROG}: {e}", file=sys.stderr)
        return None


def _seeded_table(args: argparse.Namespace, out, rows_of: Any, summary_of: Any, name: str) -> int:
    """An experiment over ``--seeds``: its rows, its summary printed, its table written as *name*."""
    seeds = _seeds(args)
    if seeds is None:
        return 2
    rows = rows_of(seeds, workers=args.workers)
    for line in summary_of(rows):
        print(line, file=out)
    print(f"results: {_write_csv(args.out / name, rows)}", file=out)
    return 0


def _speeds(args: argparse.Namespace, out) -> int:
    from . import speeds

    return _seeded_table(args, out, speeds.speed_rows, speeds.summary_lines, "speeds.csv")


def _navshoe_outage(args: argparse.Namespace, out) -> int:
    from . import navshoe

    return _seeded_table(args, out, navshoe.outage_rows, navshoe.summary_lines, "navshoe-outage.csv")


def _true_profile(scenario: str) -> tuple[np.ndarray, np.ndarray]:
    from firmware_sim.sensors.scenarios import trajectory

    p = trajectory(scenario).sample(100.0).stances_in_start_frame()
    from firmware_sim.sensors.truth import walked_distance

    return walked_distance(p), -p[:, 2]


def main(argv: Sequence[str] | None = None, out=None) -> int:
    args = build_parser().parse_args(argv)
    out = out or sys.stdout
    if args.workers < 0:
        print(f"{PROG}: --workers must be ≥ 0, got {args.workers}", file=sys.stderr)
        return 2
    return {"walks": _walks, "slopes": _slopes, "speeds": _speeds,
            "navshoe-outage": _navshoe_outage}[args.experiment](args, out)
