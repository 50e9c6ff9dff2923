"""The command line of `python -m lab.accuracy` (:mod:`lab.accuracy`)."""

from __future__ import annotations

import argparse
import functools
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["build_parser", "main"]

PROG = "python -m lab.accuracy"


def build_parser() -> argparse.ArgumentParser:
    from firmware_sim.app.batch import worker_count

    from . import __doc__ as doc

    p = argparse.ArgumentParser(prog=PROG, description=(doc or "").split("\n\n")[0])
    sub = p.add_subparsers(dest="experiment", required=True)
    w = sub.add_parser("walks", help="closed-loop recordings: height compensation and leave-one-out drift "
                                     "correction, per walk")
    w.add_argument("files", nargs="+", type=Path, metavar="FILE", help="closed-loop recordings (≥ 2)")
    wc = sub.add_parser("walks-compass",
                        help="closed-loop recordings with magnetometers: closure plain and with the "
                             "per-step compass, uncalibrated and with the shoe's iron fitted on the other "
                             "walks, and why")
    wc.add_argument("files", nargs="+", type=Path, metavar="FILE", help="closed-loop recordings (≥ 2)")
    s = _seeded(sub, "slopes", "simulated ramps up and down, height error with and without compensation",
                "1:6", "modules", "five")
    s.add_argument("--ramps", metavar="NAME,...",
                   help="walk only these of the five ramps (ramp_0, ramp_2.5, ramp_6, ramp_7.5, "
                        "ramp_diagonal), beside the flat control; the picture is ramp_6's when it is walked, "
                        "else the first's")
    v = _seeded(sub, "speeds", "simulated 100 m straight at 3–8 km/h and running, at 1 kHz and 250 Hz: the "
                               "error-free module's and the modules' end errors", "1:6", "modules", "five")
    n = _seeded(sub, "navshoe-outage", "NavShoe's outage experiment: a 1 km hilly loop outdoors, GPS for the "
                                       "first 400 m; compass + GPS, GPS only, compass only, plain",
                "1:21", "walks", "twenty")
    _stance_sway_option(n)
    ns = _seeded(sub, "navshoe-in-situ", "NavShoe's flow through the command lines: calibrate in situ "
                                         "(the wiggle walked before, or inside the walk), then the outage "
                                         "loop with GPS, with and without the compass",
                 "1:6", "walks", "five")
    hi = _seeded(sub, "navshoe-house-in-situ", "NavShoe's house walk through the command lines: calibrate in "
                                          "situ, then the house with the host's defaults, with and "
                                          "without the compass", "1:21", "walks", "twenty")
    hs = _seeded(sub, "navshoe-house", "NavShoe's house walk: 118 m through a two-storey house, indoors; the "
                                       "compass per step, at every reset, continuously, none",
                 "1:21", "walks", "twenty")
    mc = _seeded(sub, "magcal", "NavShoe's in-situ magnetometer calibration: a 30 s wiggle then a walk "
                                "outdoors; the fitted iron (the ellipsoid, turned by the attitude) against "
                                "the simulated, the per-step compass with it, the ellipsoid alone, the true "
                                "one and none; wiggles of less tilt",
                 "1:21", "modules", "twenty")
    f = _seeded(sub, "two-feet-straight", "the module paper's experiment: 100 m straight walks with a module "
                                          "on each foot; each foot, their average and the constrained fusion",
                "1:51", "walkers", "fifty")
    lp = _seeded(sub, "two-feet-loop", "Bachmann's experiment: a 400 m loop, closure per foot, average and "
                                       "fusion", "1:6", "walkers", "five")
    a = _seeded(sub, "two-feet-aids", "NavShoe's outage experiment with a module on each foot: the body's "
                                      "end error fused with compass + GPS, their average, fused plain, one "
                                      "foot", "1:11", "walkers", "ten")
    _stance_sway_option(a)
    d = _seeded(sub, "two-feet-drift", "Bachmann's drift correction with two feet: one walker's modules "
                                       "round a 400 m loop, each corrected with the others' calibrations",
                "1:7", "loops", "six")
    c = _seeded(sub, "consistency", "is the summed covariance honest? the end pose's normalised squared "
                                    "error on walk, rectangle and default, and a constant inflation "
                                    "estimated on the other routes", "0:20", "modules", "twenty")
    _stance_sway_option(c)
    ef = sub.add_parser("error-free", help="every named scenario walked by an error-free module at 1 kHz: "
                                           "the end error in %% of the 3-D path and the height error")
    ef.add_argument("scenarios", nargs="*", metavar="SCENARIO",
                    help="scenarios or recipes (default: every named scenario)")
    h = sub.add_parser("two-feet-heading",
                       help="the feet's headings over a 22-minute walk with and without the constraint, "
                            "and the same walk with the right foot's link down for 30 s")
    h.add_argument("--seed", type=int, default=1, help="the simulated walker (default 1)")
    h.add_argument("--drop", default="600:630", metavar="A:B",
                   help="seconds of the walk the right foot's link is down (default 600:630)")
    for q in (w, wc, s, v, n, ns, hi, hs, mc, f, lp, a, d, c, ef, h):
        where = q.add_mutually_exclusive_group()
        where.add_argument("--workers", type=worker_count, default=2,
                           help="local Dask worker processes, 1 thread each (default 2; 0 = here, one after "
                                "the other)")
        where.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                           help="run on this Dask cluster instead (its workers need the clone's lab/ on "
                                "their path: lab/runner.py)")
        q.add_argument("--out", type=Path, default=Path("accuracy-out"), metavar="DIR",
                       help="write the table (CSV) and the height picture here (default accuracy-out)")
    return p


def _stance_sway_option(q: argparse.ArgumentParser) -> None:
    """``--stance-sway`` of an experiment on simulated walks."""
    q.add_argument("--stance-sway", action=argparse.BooleanOptionalAction, default=None,
                   help="the walking stances sway and vibrate as a real foot's do (firmware_sim.sensors.gait."
                        "StanceSway): the module's ZARU then seldom holds while walking and its gyro bias "
                        "turns its heading, as on a real module (default: the simulation's default, on; "
                        "--no-stance-sway: still stances)")


def _seeded(sub: Any, name: str, help: str, default: str, what: str, count: str) -> argparse.ArgumentParser:
    """An experiment over simulated ``--seeds`` (default *default*: *count* simulated *what*)."""
    q = sub.add_parser(name, help=help)
    q.add_argument("--seeds", default=default, metavar="A:B",
                   help=f"simulated {what} (default {default}, {count})")
    return q


def _write_csv(path: Path, rows: Sequence[dict[str, Any]]) -> Path:
    """*rows* as CSV, without the height profiles they carry for the pictures."""
    from firmware_sim.app.runs import write_rows

    return write_rows(rows, path, [k for k in rows[0] if k != "profile"])


def _missing_recordings(files: Sequence[Path]) -> bool:
    """Whether a recording of *files* is not there (said on stderr)."""
    missing = [str(f) for f in files if not f.is_file()]
    if missing:
        print(f"{PROG}: no such recording: {', '.join(missing)}", file=sys.stderr)
    return bool(missing)


def _walks(args: argparse.Namespace, out) -> int:
    from . import walks
    from .figure import plot_heights
    from .runs import height_profile

    if _missing_recordings(args.files):
        return 2
    results = walks.walk_results(args.files, workers=args.workers, scheduler=args.scheduler)
    for line in (*walks.table_lines(results), "", *walks.height_lines(results)):
        print(line, file=out)
    first = results[0]
    png = plot_heights(args.out / "height-walk.png", f"{first.name}: a closed loop's height (returns to 0)",
                       height_profile(first.tracks["plain"]), height_profile(first.tracks["height"]))
    _report(out, (), _write_csv(args.out / "walks.csv", walks.rows(results)), png)
    return 0


def _error_free(args: argparse.Namespace, out) -> int:
    from . import error_free

    rows = error_free.error_free_rows(args.scenarios or None, args.workers, args.scheduler)
    _report(out, error_free.table_lines(rows), _write_csv(args.out / "error-free.csv", rows))
    return 0


def _walks_compass(args: argparse.Namespace, out) -> int:
    from . import walks_compass

    if _missing_recordings(args.files):
        return 2
    if len(args.files) < 2:
        print(f"{PROG}: walks-compass: each walk's calibration and compass σ come from the other walks: "
              f"give at least two recordings", file=sys.stderr)
        return 2
    results = walks_compass.compass_walk_results(args.files, workers=args.workers, scheduler=args.scheduler)
    csv = _write_csv(args.out / "walks-compass.csv", walks_compass.rows(results))
    _report(out, walks_compass.table_lines(results), csv)
    return 0


def _slopes(args: argparse.Namespace, out) -> int:
    from firmware_sim.sensors.scenarios import recipe

    from . import slopes
    from .figure import plot_heights

    ramps = slopes.RAMPS if args.ramps is None else tuple(dict.fromkeys(args.ramps.split(",")))
    unknown = [r for r in ramps if r not in slopes.RAMPS]
    if unknown:
        print(f"{PROG}: slopes: no ramp {', '.join(unknown)} (the ramps: {', '.join(slopes.RAMPS)})",
              file=sys.stderr)
        return 2
    shown = "ramp_6" if "ramp_6" in ramps else ramps[0]

    def picture(rows, seeds):
        pick = [r for r in rows if r["scenario"] == shown and r["seed"] == seeds[0]]
        off, on = (next(r["profile"] for r in pick if r["height_compensation"] == hc) for hc in (False, True))
        road = "6.1°, 50 m up and back" if shown == "ramp_6" else recipe(shown)
        title = f"{shown} ({road}), module {seeds[0]}"
        return plot_heights(args.out / "height-ramp.png", title, off, on, truth=_true_profile(shown))

    rows_of = functools.partial(slopes.slope_rows, scenarios=(*ramps, slopes.FLAT))
    return _seeded_table(args, out, rows_of, slopes.summary_lines, "slopes.csv", picture)


def _seeds(args: argparse.Namespace) -> list[int] | None:
    """The seeds of ``--seeds``; None (said on stderr) when they do not parse."""
    from firmware_sim.app.runs import parse_seeds

    try:
        return parse_seeds(args.seeds)
    except ValueError as e:
        print(f"{PROG}: {e}", file=sys.stderr)
        return None


def _seeded_table(args: argparse.Namespace, out, rows_of: Any, summary_of: Any, name: str,
                  picture: Any = None) -> int:
    """An experiment over ``--seeds``: its rows, its summary printed, its table written as *name*
    (and *picture(rows, seeds)*'s PNG, when given)."""
    seeds = _seeds(args)
    if seeds is None:
        return 2
    rows = rows_of(seeds, workers=args.workers, scheduler=args.scheduler)
    lines = summary_of(rows)
    csv = _write_csv(args.out / name, rows)
    _report(out, lines, csv, *([picture(rows, seeds)] if picture is not None else []))
    return 0


def _report(out, lines: Sequence[str], *written: Path) -> None:
    """Print a table's *lines*, then where its results were *written*."""
    for line in lines:
        print(line, file=out)
    print(f"results: {', '.join(str(p) for p in written)}", file=out)


def _speeds(args: argparse.Namespace, out) -> int:
    from . import speeds

    return _seeded_table(args, out, speeds.speed_rows, speeds.summary_lines, "speeds.csv")


def _navshoe_outage(args: argparse.Namespace, out) -> int:
    from . import navshoe

    rows_of = functools.partial(navshoe.outage_rows, stance_sway=args.stance_sway)
    return _seeded_table(args, out, rows_of, navshoe.summary_lines, "navshoe-outage.csv")


def _navshoe_in_situ(args: argparse.Namespace, out) -> int:
    from . import navshoe_in_situ

    return _seeded_table(args, out, navshoe_in_situ.in_situ_rows, navshoe_in_situ.summary_lines,
                         "navshoe-in-situ.csv")


def _navshoe_house_in_situ(args: argparse.Namespace, out) -> int:
    from . import house_in_situ

    return _seeded_table(args, out, house_in_situ.house_in_situ_rows, house_in_situ.summary_lines,
                         "navshoe-house-in-situ.csv")


def _navshoe_house(args: argparse.Namespace, out) -> int:
    from . import house

    return _seeded_table(args, out, house.house_rows, house.summary_lines, "navshoe-house.csv")


def _magcal(args: argparse.Namespace, out) -> int:
    from . import magcal

    seeds = _seeds(args)
    if seeds is None:
        return 2
    code = _seeded_table(args, out, magcal.calibration_rows, magcal.summary_lines, "magcal.csv")
    rows = magcal.tilt_rows(seeds, workers=args.workers, scheduler=args.scheduler)
    _report(out, magcal.tilt_lines(rows), _write_csv(args.out / "magcal-tilt.csv", rows))
    return code


def _two_feet_straight(args: argparse.Namespace, out) -> int:
    from . import two_feet

    def picture(rows, _seeds):
        return two_feet.plot_end_points(args.out / "two-feet-straight.png", rows)

    return _seeded_table(args, out, two_feet.straight_rows, two_feet.straight_summary,
                         "two-feet-straight.csv", picture)


def _two_feet_loop(args: argparse.Namespace, out) -> int:
    from . import two_feet

    return _seeded_table(args, out, two_feet.loop_rows, two_feet.loop_summary, "two-feet-loop.csv")


def _two_feet_aids(args: argparse.Namespace, out) -> int:
    from . import two_feet

    rows_of = functools.partial(two_feet.aids_rows, stance_sway=args.stance_sway)
    return _seeded_table(args, out, rows_of, two_feet.aids_summary, "two-feet-aids.csv")


def _two_feet_drift(args: argparse.Namespace, out) -> int:
    from . import two_feet

    seeds = _seeds(args)
    if seeds is None:
        return 2
    if len(seeds) < 2:
        print(f"{PROG}: two-feet-drift: each loop is corrected with the other loops' calibrations: "
              f"give at least two seeds, got {args.seeds!r}", file=sys.stderr)
        return 2
    return _seeded_table(args, out, two_feet.drift_rows, two_feet.drift_summary, "two-feet-drift.csv")


def _consistency(args: argparse.Namespace, out) -> int:
    from . import consistency

    rows_of = functools.partial(consistency.consistency_rows, stance_sway=args.stance_sway)
    return _seeded_table(args, out, rows_of, consistency.summary_lines, "consistency.csv")


def _two_feet_heading(args: argparse.Namespace, out) -> int:
    from . import two_feet

    try:
        a, b = (float(v) for v in args.drop.split(":"))
    except ValueError:
        print(f"{PROG}: --drop: expected START:END in seconds, got {args.drop!r}", file=sys.stderr)
        return 2
    if not 0 <= a < b:
        print(f"{PROG}: --drop: need 0 ≤ START < END, got {args.drop!r}", file=sys.stderr)
        return 2
    from lab.runner import map_runs

    plain, dropped = map_runs(functools.partial(two_feet.heading_run, args.seed), [None, (a, b)],
                              args.workers, args.scheduler)
    pngs = []
    for result, name in ((plain, "two-feet-heading.png"), (dropped, "two-feet-link-drop.png")):
        for line in two_feet.heading_summary(result):
            print(line, file=out)
        pngs.append(two_feet.plot_heading(args.out / name, result))
    _report(out, (), *pngs)
    return 0


def _true_profile(scenario: str) -> tuple[np.ndarray, np.ndarray]:
    from firmware_sim.sensors.scenarios import trajectory

    p = trajectory(scenario).sample(100.0).stances_in_start_frame()
    from firmware_sim.sensors.truth import walked_distance

    return walked_distance(p), -p[:, 2]


def main(argv: Sequence[str] | None = None, out=None) -> int:
    args = build_parser().parse_args(argv)
    out = out or sys.stdout
    return {"walks": _walks, "walks-compass": _walks_compass,
            "slopes": _slopes, "speeds": _speeds, "navshoe-outage": _navshoe_outage,
            "navshoe-in-situ": _navshoe_in_situ, "navshoe-house-in-situ": _navshoe_house_in_situ,
            "navshoe-house": _navshoe_house, "magcal": _magcal,
            "two-feet-straight": _two_feet_straight, "two-feet-loop": _two_feet_loop,
            "two-feet-aids": _two_feet_aids, "two-feet-drift": _two_feet_drift,
            "consistency": _consistency, "error-free": _error_free,
            "two-feet-heading": _two_feet_heading}[args.experiment](args, out)
