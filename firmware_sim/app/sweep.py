"""Sweep recordings or scenarios × seeds × settings, serially or on a Dask cluster; a results table.

``openshoe-emu sweep`` runs the product of its sources (recording files, or ``--scenario``
names), its seeds (``--seeds A:B``) and the values of every setting (``--set NAME=V1,V2``,
repeatable; the names are those of :mod:`firmware_sim.app.settings`), one batch replay each
(:func:`firmware_sim.app.runs.run_one`). A spec file (``--spec FILE``, TOML or JSON) says the
same, and the command line adds to it::

    recordings = ["walks/walk_100521_2.txt"]     # or: scenarios = ["rectangle", "walk"]
    seeds = "0:8"                                # A:B, N, or a list
    rate_hz = 1000.0                             # of the scenarios
    leave_one_out = "closure_pct"                # optional: choose on all sources but one
    group_by = ["source", "sensors.model"]       # optional: mean ± sd per group
    group_metrics = ["end_along_m", "end_height_m"]
    [settings]
    "frontend.zupt_threshold" = [8000, 16000, 32000]
    "link.byte_loss" = [0.0, 1e-3]

It writes ``OUT/runs.parquet`` and ``OUT/runs.csv`` (one row per run, sorted by run key:
source, seed, then the settings in their order; the settings are columns; metrics and timings
as :mod:`firmware_sim.app.runs` describes) and ``OUT/closure.png`` (closure per setting, when
matplotlib is installed), and prints the table. The runs go to a local Dask cluster of
``--workers`` processes (default 2), to an existing one (``--scheduler tcp://HOST:PORT``), or
one after the other in this process (``--workers 0``); the table is the same every way, but for
the timing columns.

Two readings of the table (:mod:`firmware_sim.app.sweep_summary`) can go with it:
``--leave-one-out METRIC`` chooses the settings on all sources but one and scores the one left
out, for each (``OUT/leave_one_out.csv``); ``--group-by COLUMN,…`` gives the mean ± sd of
``--group-metrics`` per group of runs (``OUT/groups.csv``).
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import sys
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from . import settings as run_settings
from .batch import MAX_RATE_HZ, rate_hz, worker_count
from .progress import say
from .runs import RunSpec, columns, parse_seeds, summary_lines, write_csv, write_rows

__all__ = ["SweepSpec", "add_arguments", "build_spec", "load_spec_file", "main", "run_sweep", "spec_from_doc",
           "write_tables"]


#: The most runs one sweep makes (its table is made whole in memory).
MAX_RUNS = 1_000_000
#: What a grouped table averages unless told otherwise: the end error against the truth.
DEFAULT_GROUP_METRICS = ("end_along_m", "end_across_m", "end_height_m", "closure_pct")


@dataclass(frozen=True)
class SweepSpec:
    """What a sweep runs: sources × seeds × every combination of the settings' values."""

    recordings: tuple[str, ...] = ()
    scenarios: tuple[str, ...] = ()
    seeds: tuple[int, ...] = (0,)
    rate_hz: float = 1000.0
    settings: tuple[tuple[str, tuple[Any, ...]], ...] = ()
    #: how to read the table: the metric a leave-one-out minimises (None: none)
    leave_one_out: str | None = None
    #: columns to group the runs by (empty: no grouped table), and the metrics averaged per group
    group_by: tuple[str, ...] = ()
    group_metrics: tuple[str, ...] = DEFAULT_GROUP_METRICS

    @property
    def setting_names(self) -> tuple[str, ...]:
        return tuple(name for name, _ in self.settings)

    def check(self) -> None:
        """Refuse an empty or ambiguous sweep, unknown scenarios, recordings that cannot be read,
        unknown settings, repeated values, more runs than :data:`MAX_RUNS`."""
        from firmware_sim.sensors.scenarios import check as check_scenario
        from hostlib.inputs import check_input

        from .batch import error_text

        if bool(self.recordings) == bool(self.scenarios):
            raise ValueError("a sweep needs recording files or --scenario names (one of them)")
        run_settings.check(self.setting_names, recordings=bool(self.recordings))
        for what, values in [("seeds", self.seeds), *self.settings]:
            if not values or len(set(values)) != len(values):
                raise ValueError(f"{what}: give each value once, and at least one")
        known = set(columns(self.setting_names))
        for what, names in (("--leave-one-out", [self.leave_one_out] if self.leave_one_out else []),
                            ("--group-by", self.group_by), ("--group-metrics", self.group_metrics)):
            unknown = [n for n in names if n not in known]
            if unknown:
                raise ValueError(f"{what}: no column {', '.join(unknown)} in the table "
                                 f"(columns: {', '.join(columns(self.setting_names))})")
        if self.leave_one_out and not self.settings:
            raise ValueError("--leave-one-out needs a setting with several values to choose from (--set)")
        for name in self.scenarios:
            try:
                check_scenario(name)  # each piece's numbers too: milliseconds, nothing is computed
            except KeyError as exc:
                raise ValueError(error_text(exc)) from None
        missing = [path for path in self.recordings if not Path(path).exists()]
        if missing:
            raise ValueError(f"no such recording: {', '.join(missing)}")
        for path in self.recordings:
            check_input(path, "walk recording", pipes=False)
        runs = (len(self.recordings) + len(self.scenarios)) * len(self.seeds) * math.prod(
            len(v) for _, v in self.settings)
        if runs > MAX_RUNS:
            raise ValueError(f"the sweep is {runs} runs: at most {MAX_RUNS} in one sweep")

    def runs(self) -> list[RunSpec]:
        """Every run, sorted by run key."""
        kind, sources = ("file", self.recordings) if self.recordings else ("scenario", self.scenarios)
        out = []
        for source, seed, values in itertools.product(sources, self.seeds,
                                                      itertools.product(*(v for _, v in self.settings))):
            chosen = tuple(zip(self.setting_names, values, strict=True))
            name = _run_name(kind, source, seed, chosen)
            out.append(RunSpec(kind, source, seed, self.rate_hz, chosen, name))
        return sorted(out, key=lambda r: r.key)


def _run_name(kind: str, source: str, seed: int, chosen: tuple[tuple[str, Any], ...]) -> str:
    import re

    stem = Path(source).stem if kind == "file" else source
    parts = [stem, f"seed{seed}", *(f"{n.rsplit('.', 1)[-1]}={v}" for n, v in chosen)]
    return re.sub(r"[^A-Za-z0-9._=-]+", "_", "_".join(parts))


def _values(name: str, values: Any) -> tuple[Any, ...]:
    items = values.split(",") if isinstance(values, str) else values if isinstance(values, list) else [values]
    return tuple(run_settings.parse_value(name, v) for v in items)


#: The keys of a spec file.
SPEC_KEYS = ("recordings", "scenarios", "seeds", "rate_hz", "settings", "leave_one_out", "group_by",
             "group_metrics")


def load_spec_file(path: Path) -> SweepSpec:
    """A spec from a TOML (``.toml``) or JSON file (module docstring); ValueError naming the file
    and what is wrong with it (TOML's and JSON's errors say the line)."""
    from hostlib.inputs import read_text

    text = read_text(path, "sweep spec")
    if path.suffix == ".toml":
        try:
            import tomllib
        except ImportError:  # pragma: no cover - Python 3.10
            raise ValueError(f"{path}: TOML specs need Python ≥ 3.11; write the spec as JSON") from None
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise ValueError(f"{path}: not a sweep spec: invalid TOML ({exc})") from None
    else:
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise ValueError(f"{path}: not a sweep spec: invalid JSON ({exc})") from None
        except RecursionError:
            raise ValueError(f"{path}: not a sweep spec: JSON nested too deep") from None
    try:
        return spec_from_doc(data)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None


def spec_from_doc(data: Any) -> SweepSpec:
    """The spec a parsed file holds (:data:`SPEC_KEYS`); ValueError saying which key is wrong."""
    if not isinstance(data, dict):
        raise ValueError(f"a spec is a table of keys ({', '.join(SPEC_KEYS)}), not a {type(data).__name__}")
    unknown = set(data) - set(SPEC_KEYS)
    if unknown:
        raise ValueError(f"unknown keys {sorted(map(str, unknown))}")
    seeds = data.get("seeds", [0])
    if isinstance(seeds, str):
        seeds = parse_seeds(seeds)
    elif not all(_whole(s) and s >= 0 for s in _as_list(seeds)):
        raise ValueError(f"'seeds' is \"A:B\", a whole number >= 0 or a list of them, not {seeds!r}")
    rate = data.get("rate_hz", 1000.0)
    if not (isinstance(rate, (int, float)) and not isinstance(rate, bool) and _finite(rate)
            and 0 < rate <= MAX_RATE_HZ):
        raise ValueError(f"'rate_hz' is a sample rate in Hz > 0 and at most {MAX_RATE_HZ:g}, not {rate!r}")
    settings = data.get("settings", {})
    if not isinstance(settings, dict):
        raise ValueError(f"'settings' is a table of a setting's name and its values, not {settings!r}")
    leave_one_out = data.get("leave_one_out")
    if leave_one_out is not None and not isinstance(leave_one_out, str):
        raise ValueError(f"'leave_one_out' is a column's name, not {leave_one_out!r}")
    return SweepSpec(
        recordings=_texts(data, "recordings"), scenarios=_texts(data, "scenarios"),
        seeds=tuple(int(s) for s in _as_list(seeds)), rate_hz=float(rate),
        settings=tuple((str(n), _values(str(n), v)) for n, v in settings.items()),
        leave_one_out=leave_one_out, group_by=_texts(data, "group_by"),
        group_metrics=_texts(data, "group_metrics", DEFAULT_GROUP_METRICS),
    )


def _texts(data: dict[str, Any], key: str, default: tuple[str, ...] = ()) -> tuple[str, ...]:
    """*data[key]*: a name or a list of names (ValueError for anything else)."""
    value = data.get(key, list(default))
    if not all(isinstance(v, str) for v in _as_list(value)):
        raise ValueError(f"{key!r} is a name or a list of names, not {value!r}")
    return tuple(_as_list(value))


def _whole(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _finite(value: float) -> bool:
    try:
        return math.isfinite(value)
    except OverflowError:  # an integer too large for a float
        return False


def _as_list(value: Any) -> list[Any]:
    return value if isinstance(value, list) else [value]


def _names(text: str | None) -> tuple[str, ...]:
    return tuple(n.strip() for n in text.split(",") if n.strip()) if text else ()


def build_spec(args: argparse.Namespace) -> SweepSpec:
    """The spec file (if any) with the command line's sources, seeds and settings added."""
    spec = load_spec_file(args.spec) if args.spec is not None else SweepSpec()
    settings = dict(spec.settings)
    for item in args.set:
        name, sep, values = item.partition("=")
        if not sep:
            raise ValueError(f"--set takes NAME=V1,V2,…; got {item!r}")
        settings[name.strip()] = _values(name.strip(), values)
    spec = replace(
        spec,
        recordings=spec.recordings + tuple(str(f) for f in args.files),
        scenarios=spec.scenarios + tuple(args.scenario),
        seeds=tuple(parse_seeds(args.seeds)) if args.seeds is not None else spec.seeds,
        rate_hz=args.rate if args.rate is not None else spec.rate_hz,
        settings=tuple(settings.items()),
        leave_one_out=args.leave_one_out or spec.leave_one_out,
        group_by=_names(args.group_by) or spec.group_by,
        group_metrics=_names(args.group_metrics) or spec.group_metrics,
    )
    spec.check()
    return spec


# ---------------------------------------------------------------------------------------------
# running and writing


def run_sweep(spec: SweepSpec, *, workers: int = 2, scheduler: str | None = None,
              quiet: bool = False, runner: Any = None) -> list[dict[str, Any]]:
    """The rows of every run of *spec*, sorted by run key (serial when *workers* is 0 and no
    *scheduler*); *runner* replaces :func:`~firmware_sim.app.runs.run_one` (tests)."""
    from . import cluster

    runs = spec.runs()
    kw = {"quiet": quiet} if runner is None else {"quiet": quiet, "runner": runner}
    if workers == 0 and scheduler is None:
        cluster.prepare_process(simulation=False)
        return cluster.execute(runs, **kw)
    with cluster.open_client(workers, scheduler) as client:
        return cluster.execute(runs, client, **kw)


def write_tables(rows: list[dict[str, Any]], setting_names: tuple[str, ...], out: Path) -> list[Path]:
    """``out/runs.parquet`` and ``out/runs.csv``: one row per run, in the order given."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    out.mkdir(parents=True, exist_ok=True)
    names = columns(setting_names)
    table = pa.Table.from_pydict({c: [r[c] for r in rows] for c in names})
    pq.write_table(table, out / "runs.parquet")
    return [out / "runs.parquet", write_csv(rows, out / "runs.csv", setting_names)]


# ---------------------------------------------------------------------------------------------
# command line (wired into `openshoe-emu` by firmware_sim.app.cli)


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("files", nargs="*", type=Path, metavar="FILE", help="recordings to sweep over")
    p.add_argument("--scenario", action="append", default=[], metavar="NAME",
                   help="a simulated scenario to sweep over (repeatable)")
    p.add_argument("--seeds", metavar="A:B", help="seeds A … B-1 (also N or N,M,…); default 0")
    p.add_argument("--set", action="append", default=[], metavar="NAME=V1,V2",
                   help="a setting and its values (repeatable): frontend.zupt_threshold, "
                        "frontend.zaru_threshold, sensors.<field>, link.profile, link.byte_loss, …")
    p.add_argument("--spec", type=Path, metavar="FILE", help="a sweep spec (TOML or JSON)")
    p.add_argument("--rate", type=rate_hz, help="sample rate of the scenarios [Hz] (default 1000)")
    p.add_argument("--out", type=Path, required=True, metavar="DIR",
                   help="write runs.parquet, runs.csv and closure.png here")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--workers", type=worker_count, default=2,
                       help="local Dask worker processes, 1 thread each (default 2; 0 = serial, here)")
    where.add_argument("--scheduler", metavar="tcp://HOST:PORT", help="run on this Dask cluster instead")
    p.add_argument("--leave-one-out", metavar="METRIC",
                   help="for each source, choose the settings with the least mean |METRIC| on the others "
                        "and score it there (e.g. closure_pct); OUT/leave_one_out.csv")
    p.add_argument("--group-by", metavar="COLUMN,…",
                   help="mean ± sd per group of runs with equal COLUMNs (e.g. source,sensors.model); "
                        "OUT/groups.csv")
    p.add_argument("--group-metrics", metavar="METRIC,…",
                   help=f"what --group-by averages (default {','.join(DEFAULT_GROUP_METRICS)})")
    p.add_argument("--no-plot", action="store_true", help="skip closure.png")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar, no table on stdout")


def main(args: argparse.Namespace) -> int:
    try:
        spec = build_spec(args)
        if args.out.exists() and not args.out.is_dir():
            raise ValueError(f"--out {args.out} is a file: it names the folder the tables go to")
        if args.scheduler is not None and not args.scheduler.rpartition(":")[2].isdigit():
            raise ValueError(f"--scheduler is a Dask scheduler's tcp://HOST:PORT, not {args.scheduler!r}")
    except (OSError, ValueError) as e:
        print(f"openshoe-emu sweep: {e}", file=sys.stderr)
        return 2
    try:
        rows = run_sweep(spec, workers=args.workers, scheduler=args.scheduler, quiet=args.quiet)
    except Exception as e:  # noqa: BLE001 - a run that failed on every try, or a lost cluster
        print(f"openshoe-emu sweep: {type(e).__name__}: {e}", file=sys.stderr)
        return 1
    written = write_tables(rows, spec.setting_names, args.out)
    if not args.no_plot:
        from .sweep_plot import plot_closure

        png = plot_closure(rows, spec.setting_names, args.out / "closure.png")
        if png is None:
            say("closure.png skipped: matplotlib is not installed (the `plot` extra)")
        else:
            written.append(png)
    lines = summary_lines(rows, spec.setting_names)
    written += _readings(spec, rows, args.out, lines)
    if not args.quiet:
        for line in lines:
            print(line)
    print("results: " + ", ".join(str(p) for p in written))
    return 0


def _readings(spec: SweepSpec, rows: list[dict[str, Any]], out: Path, lines: list[str]) -> list[Path]:
    """The spec's leave-one-out and grouped tables: written under *out*, their text added to *lines*."""
    from . import sweep_summary as reading

    written = []
    if spec.group_by:
        table = reading.group_table(rows, spec.group_by, spec.group_metrics)
        lines += ["", *reading.group_lines(table, spec.group_by, spec.group_metrics)]
        written.append(write_rows(table, out / "groups.csv"))
    if spec.leave_one_out:
        folds = reading.leave_one_out(rows, spec.setting_names, spec.leave_one_out)
        lines += ["", *reading.leave_one_out_lines(folds, spec.setting_names, spec.leave_one_out)]
        table = [{"held_out": f.held_out, **dict(zip(spec.setting_names, f.chosen, strict=True)),
                  f"{spec.leave_one_out}_held_out": f.score, f"{spec.leave_one_out}_others": f.others}
                 for f in folds]
        written.append(write_rows(table, out / "leave_one_out.csv"))
    return written
