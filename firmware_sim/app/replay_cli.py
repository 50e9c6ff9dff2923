"""Replay a recording or a scenario in batch mode — one, or many in one command.

``openshoe-emu replay FILE --wire OUT`` (or ``--scenario NAME --wire OUT``) is one replay
(:mod:`firmware_sim.app.batch`). ``openshoe-emu replay FILE... --wire-dir DIR`` replays every
file, and ``--scenario NAME --seeds A:B --wire-dir DIR`` the scenario with
every seed A … B−1 (with ``--module N``, one module walked with every seed: ``<name>_moduleN_seedS``):
each run writes ``DIR/<name>.bin`` (a scenario also ``<name>.bin.truth.csv``),
byte for byte what a replay of it alone writes, and a table of the runs goes to stdout: steps,
distance, closure (for closed loops) and time (:mod:`firmware_sim.app.runs`). The compiled
tracking path is prepared once, before the first run. With ``--jobs N`` (default: one a usable
CPU) the runs then go in N worker processes forked from this one (:mod:`firmware_sim.app.replay_pool`),
each file, row and line what one process gives; in one process (``--jobs 1``, or a single run) they
go 16 at a time in lockstep (:mod:`firmware_sim.app.replay_group`), a reader thread reading the next
group's files while the current group runs. ``--host fusion``, ``--height-compensation`` and
``--calibrate-mag`` apply to every run, and ``--stance-sway`` to every run of a scenario.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from . import batch
from .progress import progress_bar, say

if TYPE_CHECKING:
    from .runs import RunSpec

__all__ = ["add_arguments", "main", "replay_many"]


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The replay's options (:func:`firmware_sim.app.batch.add_arguments`) and ``--jobs``."""
    from .replay_pool import job_count

    batch.add_arguments(p)
    p.add_argument("--jobs", type=job_count, metavar="N", default=None,
                   help="with --wire-dir: the runs go in N worker processes, forked once the kernels are "
                        "loaded (default: one a usable CPU, and this process alone for one run); every "
                        "file, row and line is what --jobs 1 gives")


def main(args: argparse.Namespace) -> int:
    problem = batch.check_arguments(args)
    if problem is not None:
        print(f"openshoe-emu replay: {problem}", file=sys.stderr)
        return 2
    if args.wire_dir is None:
        if args.jobs is not None:
            print("openshoe-emu replay: --jobs goes with --wire-dir (one replay is one process)",
                  file=sys.stderr)
            return 2
        return batch.main(args)
    from .runs import file_runs, parse_seeds, scenario_runs  # many runs only

    try:
        seeds = parse_seeds(args.seeds) if args.seeds is not None else [args.seed]
    except ValueError as e:
        print(f"openshoe-emu replay: {e}", file=sys.stderr)
        return 2
    if args.scenario is not None:
        runs = scenario_runs([args.scenario], seeds, rate_hz=args.rate, module=args.module)
    else:
        runs = file_runs(args.files)
    runs = [dataclasses.replace(spec, host=args.host, height_compensation=args.height_compensation,
                                calibrate_mag=args.calibrate_mag, stance_sway=args.stance_sway)
            for spec in runs]
    return replay_many(runs, args.wire_dir, table=args.table, quiet=args.quiet, jobs=args.jobs)


def replay_many(runs: list[RunSpec], wire_dir: Path, *, table: Path | None = None,
                quiet: bool = False, jobs: int | None = None) -> int:
    """Run every spec in order into *wire_dir*; print the summary; 2 when a run fails to start (a
    recording that cannot be read, an unknown scenario: before it, nothing is written, not even
    *wire_dir*), 1 when a worker process died.

    *jobs* worker processes run the runs (:mod:`firmware_sim.app.replay_pool`; None: one a usable
    CPU, and this process alone for one run); the files, rows and lines are those of one process.
    In one process the runs go in groups of :data:`~firmware_sim.app.replay_group.LOCKSTEP_RUNS`,
    each group's replays in lockstep (:func:`firmware_sim.app.runs.run_group`; every file's bytes
    those of its replay alone), a helper thread running half of each group's modules
    (:func:`firmware_sim.nav.aot.share_cores`). A reader thread loads the next group's recordings
    while the current group runs (the compiled reader and navigation kernels release the GIL),
    and the first group's while the compiled tracking path is prepared. A recording that cannot be
    read stops the batch before its group runs.
    """
    from concurrent.futures.process import BrokenProcessPool

    from .replay_pool import Refused, default_jobs
    from .runs import summary_lines, write_csv

    jobs = default_jobs(jobs, len(runs))
    with progress_bar(len(runs), "replay", "runs", quiet=quiet) as bar:
        try:
            if jobs > 1:
                rows, wall = _in_processes(runs, wire_dir, jobs, bar.update, quiet)
            else:
                rows, wall = _in_this_process(runs, wire_dir, bar.update, quiet)
        except Refused as e:
            print(f"openshoe-emu replay: {e}", file=sys.stderr)
            return 2
        except BrokenProcessPool as e:
            print(f"openshoe-emu replay: a worker process ended abruptly ({e}): the runs of its group "
                  f"and the table were not written", file=sys.stderr)
            return 1
    for line in summary_lines(rows):
        print(line)
    print(f"{len(rows) / wall:.1f} runs/s ({wall:.2f} s) → {wire_dir}")
    if table is not None:
        write_csv(rows, table)
    return 0


def _in_processes(runs: list[RunSpec], wire_dir: Path, jobs: int, done: Callable[[int], None],
                  quiet: bool) -> tuple[list[dict[str, Any]], float]:
    """:func:`replay_many`'s runs in *jobs* worker processes: the rows, and the runs' wall time (from
    the kernels loaded)."""
    from firmware_sim.nav.warmup import prepare_compiled_path

    from .replay_pool import replay_in_processes

    prepare_compiled_path(None if quiet else say)  # before the fork: every worker starts with it
    t0 = time.perf_counter()  # the runs' wall time, from here: start-up is the rest
    rows = replay_in_processes(runs, wire_dir, jobs, done)
    return rows, time.perf_counter() - t0


def _in_this_process(runs: list[RunSpec], wire_dir: Path, done: Callable[[int], None],
                     quiet: bool) -> tuple[list[dict[str, Any]], float]:
    """:func:`replay_many`'s runs in this process: the rows, and the runs' wall time (from the kernels
    loaded); :class:`~firmware_sim.app.replay_pool.Refused` for the first run that cannot start."""
    from concurrent.futures import ThreadPoolExecutor

    from firmware_sim.nav import aot
    from firmware_sim.nav.warmup import prepare_compiled_path

    from .replay_group import LOCKSTEP_RUNS
    from .replay_pool import Refused, refusal
    from .runs import load, run_group

    if len(runs) > 1:
        aot.share_cores()
    groups = [runs[i:i + LOCKSTEP_RUNS] for i in range(0, len(runs), LOCKSTEP_RUNS)]
    rows: list[dict[str, Any]] = []
    with ThreadPoolExecutor(1, thread_name_prefix="openshoe-reader") as reader:
        pending = [reader.submit(load, spec) for spec in groups[0]]
        prepare_compiled_path(None if quiet else say)
        t0 = time.perf_counter()  # the runs' wall time, from here: start-up is the rest
        for g, group in enumerate(groups):
            loaded = []
            for spec, future in zip(group, pending, strict=True):
                try:
                    loaded.append(future.result())
                except batch.start_errors() as e:
                    for later in pending:
                        later.cancel()
                    raise Refused(refusal(spec, e)) from None
            wire_dir.mkdir(parents=True, exist_ok=True)  # once a run has something to write
            if g + 1 < len(groups):
                pending = [reader.submit(load, spec) for spec in groups[g + 1]]
            rows.extend(run_group(group, loaded, wire_dir))
            done(len(group))
    return rows, time.perf_counter() - t0
