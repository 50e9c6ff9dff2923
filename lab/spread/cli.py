"""The command line of `python -m lab.spread` (:mod:`lab.spread`)."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

__all__ = ["build_parser", "main"]

PROG = "python -m lab.spread"


def build_parser() -> argparse.ArgumentParser:
    from firmware_sim.app.batch import worker_count

    from . import __doc__ as doc
    from .experiment import POWERED_S

    p = argparse.ArgumentParser(prog=PROG, description=(doc or "").split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--route", default="walk",
                   help="a scenario (openshoe-emu sweep's names: walk, rectangle, track400, …) or a recipe "
                        "such as stand:2+walk:5 (default walk: 100 m straight)")
    p.add_argument("--seeds", default="1:51", metavar="A:B",
                   help="the walks' seeds: A … B-1, N or N,M,… (default 1:51, fifty walks)")
    who = p.add_mutually_exclusive_group()
    who.add_argument("--module", type=int, metavar="N",
                     help="module N walks every seed (default: a new module each walk)")
    who.add_argument("--compare-module", type=int, metavar="N",
                     help="walk the seeds with a new module each walk and with module N each walk; "
                          "print the ratio of their horizontal spreads")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--workers", type=worker_count, default=2,
                       help="local Dask worker processes, 1 thread each (default 2; 0 = serial, here)")
    where.add_argument("--scheduler", metavar="tcp://HOST:PORT", help="run on this Dask cluster instead")
    p.add_argument("--powered-for", type=float, default=POWERED_S, metavar="SECONDS",
                   help=f"how long each module has been on when its walk starts (default {POWERED_S:g}: "
                        "warm, as in walks one after another; 0: each walk starts at power-on and "
                        "walks through the gyros' warm-up)")
    p.add_argument("--out", type=Path, default=Path("spread-out"), metavar="DIR",
                   help="write spread.csv and spread.png here (default spread-out)")
    p.add_argument("--no-plot", action="store_true", help="skip spread.png")
    return p


def _seeds(text: str) -> list[int]:
    from firmware_sim.app.runs import parse_seeds

    seeds = parse_seeds(text)
    if len(set(seeds)) != len(seeds):
        raise ValueError(f"give each seed once; got {text!r}")
    if len(seeds) < 2:
        raise ValueError(f"a spread needs at least 2 walks; got {text!r}")
    return seeds


def _groups(args: argparse.Namespace, seeds: list[int]) -> list[tuple[str, list[int], int | None]]:
    """(label, seeds, module) of each group of walks the command line asks for."""
    if args.compare_module is not None:
        return [("new module each walk", seeds, None), (f"module {args.compare_module}", seeds,
                                                         args.compare_module)]
    if args.module is not None:
        return [(f"module {args.module}", seeds, args.module)]
    return [("new module each walk", seeds, None)]


def _report(route: str, groups: Sequence[tuple[str, list[dict[str, Any]]]], out: Path,
            plot: bool) -> list[Path]:
    """Print the tables (and, for two groups, the ratio); write spread.csv and spread.png."""
    from .summary import Spread, horizontal_ratio, lines, write_rows

    spreads = [Spread.of(rows) for _, rows in groups]
    for (label, _), spread in zip(groups, spreads, strict=True):
        for line in lines(spread, f"{route}, {label}"):
            print(line)
    if len(groups) == 2:
        (fleet_label, _), (one_label, _) = groups
        ratio = horizontal_ratio(spreads[1], spreads[0])
        print(f"horizontal spread of {one_label} / {fleet_label}: {spreads[1].horizontal_m:.3f} m / "
              f"{spreads[0].horizontal_m:.3f} m = ratio {ratio:.2f}")
    written = [write_rows(groups, out / "spread.csv")]
    if plot:
        from .figure import plot_spread

        title = f"{route}: " + " vs ".join(f"{s.n} walks, {label}" for (label, _), s in
                                             zip(groups, spreads, strict=True))
        png = plot_spread([(label, rows, s) for (label, rows), s in zip(groups, spreads, strict=True)],
                          out / "spread.png", title)
        if png is None:
            print(f"{PROG}: spread.png skipped: matplotlib is not installed (the `plot` extra)",
                  file=sys.stderr)
        else:
            written.append(png)
    return written


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    from .experiment import check_route, walk_groups

    try:
        seeds = _seeds(args.seeds)
        check_route(args.route)
        if not 0.0 <= args.powered_for < float("inf"):
            raise ValueError("--powered-for must be a number of seconds ≥ 0")
    except ValueError as e:
        print(f"{PROG}: {e}", file=sys.stderr)
        return 2
    wanted = _groups(args, seeds)
    quiet = not sys.stderr.isatty()
    try:
        rows = walk_groups(args.route, [(s, m) for _, s, m in wanted], workers=args.workers,
                           scheduler=args.scheduler, quiet=quiet, powered_s=args.powered_for)
    except Exception as e:  # noqa: BLE001 - a walk that failed on every try, or a lost cluster
        print(f"{PROG}: {type(e).__name__}: {e}", file=sys.stderr)
        return 1
    written = _report(args.route, [(label, r) for (label, _, _), r in zip(wanted, rows, strict=True)],
                      args.out, not args.no_plot)
    print("results: " + ", ".join(str(p) for p in written))
    return 0
