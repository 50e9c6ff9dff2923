"""Many batch replays over worker processes: ``openshoe-emu replay FILE... --wire-dir DIR --jobs N``.

One process navigates about 50 walks a second at most: some 13 ms of a walk's 25–30 ms of CPU hold
the GIL (the Python of each loop, the host's step sum), so threads cannot use a second core for
them. :func:`replay_in_processes` forks *jobs* worker processes once the command's imports are done
and its compiled kernels loaded (each worker starts with them, a fork costs milliseconds), and
deals the runs to them in groups (:func:`deal`): the first groups as large as the lockstep takes
(:data:`~firmware_sim.app.replay_group.LOCKSTEP_RUNS`), the later ones smaller, so that the workers
end together. Each worker reads its group's recordings (or simulates its scenarios), replays them in
lockstep and writes their files (:func:`firmware_sim.app.runs.run_group`: a run's bytes are its
replay's alone, whichever process runs it); the rows come back to the command, which prints and
writes them in the runs' order, as one process does.

A recording that cannot be read is the worker's refusal, one line naming the file (and its line,
:func:`refusal`), handed back as text; the command reports the first refusal in the runs' order, as
one process does, and no group after the refused one starts (groups that other workers are running
by then finish and keep their files). Without the ``fork`` start method (not on Linux) the runs go
in one process.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .batch import error_text, start_errors

if TYPE_CHECKING:
    from .runs import RunSpec

__all__ = ["MAX_JOBS", "Refused", "deal", "default_jobs", "job_count", "refusal", "replay_in_processes",
           "usable_cpus"]

#: The most worker processes ``--jobs`` takes (each holds the kernels and a group of walks).
MAX_JOBS = 64

#: In a worker: the index of the first group a worker refused (-1: none yet), shared by the workers.
_refused_group: Any = None


class Refused(Exception):
    """A run that could not start (a recording that cannot be read): the command's one line."""


def usable_cpus() -> int:
    """The CPUs this process may run on (its affinity), at least 1."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - no affinity on this platform
        return os.cpu_count() or 1


def job_count(text: str) -> int:
    """The argparse type of ``--jobs``: worker processes, a whole number from 1 to :data:`MAX_JOBS`."""
    try:
        value = int(text)
    except ValueError:
        value = 0
    if not 1 <= value <= MAX_JOBS:
        raise argparse.ArgumentTypeError(f"a whole number of processes from 1 (the runs in this process) "
                                         f"to {MAX_JOBS}, not {text!r}")
    return value


def default_jobs(jobs: int | None, runs: int) -> int:
    """The processes *runs* runs go in: *jobs* (None: :func:`usable_cpus`), at most one a run, and 1
    without the ``fork`` start method."""
    import multiprocessing

    if "fork" not in multiprocessing.get_all_start_methods():
        return 1  # pragma: no cover - Linux forks
    return max(1, min(usable_cpus() if jobs is None else jobs, runs))


def deal(runs: Sequence[RunSpec], jobs: int, most: int) -> list[list[RunSpec]]:
    """*runs* in groups, in order: each group about half of what is left per worker, at most *most*
    and at least one run, so that the last groups are small and the workers end together."""
    groups, start = [], 0
    while start < len(runs):
        size = max(1, min(most, math.ceil((len(runs) - start) / (2 * jobs))))
        groups.append(list(runs[start:start + size]))
        start += size
    return groups


def refusal(spec: RunSpec, exc: BaseException) -> str:
    """The one line saying why *spec* could not start, naming its source (a recording's own error
    names it already, with the line)."""
    text = error_text(exc)
    where = "" if text.startswith(spec.source) else f"{spec.source}: "
    return f"{where}{text}"


def replay_in_processes(runs: Sequence[RunSpec], wire_dir: Path, jobs: int,
                        done: Callable[[int], None]) -> list[dict[str, Any]]:
    """Replay *runs* into *wire_dir* on *jobs* forked worker processes (see the module doc); their
    rows, in order. *done(n)* hears of every group finished (its n runs). :class:`Refused` with the
    first refusal in the runs' order; a worker that dies is
    ``concurrent.futures.process.BrokenProcessPool``."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    from .replay_group import LOCKSTEP_RUNS

    _import_run_modules()
    context = multiprocessing.get_context("fork")
    refused = context.Value("i", -1)
    groups = deal(runs, jobs, LOCKSTEP_RUNS)
    for stream in (sys.stdout, sys.stderr):
        stream.flush()  # a worker flushes the streams it inherited when it ends
    rows: list[dict[str, Any]] = []
    with ProcessPoolExecutor(jobs, mp_context=context, initializer=_start_worker,
                             initargs=(refused,)) as pool:
        futures = [pool.submit(_replay_group, g, group, wire_dir) for g, group in enumerate(groups)]
        try:
            for future in futures:
                result = future.result()
                if isinstance(result, str):
                    raise Refused(result)
                rows.extend(result)
                done(len(result))
        except BaseException:
            pool.shutdown(cancel_futures=True)  # the groups not started: not run
            raise
    return rows


def _import_run_modules() -> None:
    """Import what a run uses, and find the compiled walk reader, before the workers fork: once here
    rather than in each worker."""
    import firmware_sim.sensors.replay  # noqa: F401
    import hostlib.files.replay  # noqa: F401
    import hostlib.inputs  # noqa: F401
    from firmware_sim.nav import lockstep  # noqa: F401
    from firmware_sim.sensors import openshoe_scan

    from . import replay_group, truth_files  # noqa: F401

    openshoe_scan.warm_up()


def _start_worker(refused: Any) -> None:
    """A worker's start: *refused* is the workers' first refused group; a worker has a core of its
    own, so its locksteps keep their calls in its one thread."""
    from firmware_sim.nav import aot

    global _refused_group
    _refused_group = refused
    aot.share_cores(False)


def _replay_group(index: int, group: list[RunSpec], wire_dir: Path) -> list[dict[str, Any]] | str:
    """In a worker: group *index*'s rows, or the refusal of its first run that cannot start. A group
    after one refused is not run (an empty list)."""

    from .runs import load, run_group

    refused = _refused_group
    if 0 <= refused.value < index:
        return []
    loaded = []
    for spec in group:
        try:
            loaded.append(load(spec))
        except start_errors() as e:
            with refused.get_lock():
                if refused.value < 0 or index < refused.value:
                    refused.value = index
            return refusal(spec, e)
    wire_dir.mkdir(parents=True, exist_ok=True)  # once a run has something to write
    return run_group(group, loaded, wire_dir)
