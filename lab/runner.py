"""How the lab's experiments run: through the project's one Dask runner, as a sweep's runs do.

Every run of ``python -m lab.accuracy`` and ``python -m lab.spread`` goes to
:func:`firmware_sim.app.cluster.execute`, the runner of ``openshoe-emu sweep``: on a local Dask
cluster of ``--workers`` processes (one thread each; each worker loads the compiled kernels when
it joins), on an existing cluster (``--scheduler tcp://HOST:PORT``), or one after the other in this
process (``--workers 0``); with its progress bar on a terminal and its retries of a task that
raised, the results back in the order of the runs. They are the same whichever way: a run is a
pure function of what it is given.

* :func:`execute` — runs of :class:`~firmware_sim.app.runs.RunSpec` (a recording, or a scenario
  walked with a seed by a module: a sweep spec's runs, :func:`~firmware_sim.app.runs.scenario_runs`),
  each given to *runner* (:func:`~firmware_sim.app.runs.run_one`, or an experiment's own).
* :func:`map_runs` — ``[run(job) for job in jobs]``, for the experiments whose run is more than one
  replay summed by the plain host (the aided hosts, two feet, the leave-one-out calibrations): each
  job travels to the runner in a RunSpec of kind :data:`JOB` (the job its setting ``job``), which the
  runner schedules, names and retries like any other. :func:`seeded_rows` flattens per-seed rows.

On a cluster of other machines the workers must import what they run: :func:`execute` with
``run_one`` needs only the package (``openshoe-emu sweep``'s set-up, README), :func:`map_runs` also
the lab, which is not installed — start each worker with the clone on its path
(``PYTHONPATH=/path/to/clone dask worker tcp://HOST:8786 --nworkers 2 --nthreads 1``).
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from typing import Any

from firmware_sim.app import cluster
from firmware_sim.app.runs import RunSpec, run_one

__all__ = ["JOB", "execute", "map_runs", "seeded_rows"]

#: The kind of the RunSpec in which a job of :func:`map_runs` travels.
JOB = "job"


def execute(runs: Sequence[RunSpec], *, workers: int = 2, scheduler: str | None = None,
            runner: Callable[[RunSpec], Any] = run_one, quiet: bool = False) -> list:
    """*runner*'s result of every run, in the order of *runs*: on *scheduler*'s cluster, else on a
    local cluster of *workers* processes, else (*workers* 0, or a single run) here in turn."""
    runs = list(runs)
    if scheduler is None and (workers == 0 or len(runs) <= 1):
        cluster.prepare_process(simulation=False)
        return cluster.execute(runs, runner=runner, quiet=quiet)
    with cluster.open_client(workers, scheduler) as client:
        return cluster.execute(runs, client, runner=runner, quiet=quiet)


def map_runs(run: Callable[[Any], Any], jobs: Sequence[Any], workers: int = 2, scheduler: str | None = None,
             quiet: bool = False) -> list:
    """``[run(job) for job in jobs]`` through :func:`execute` (module docstring), in the jobs' order."""
    what = getattr(run, "__qualname__", None) or getattr(getattr(run, "func", None), "__qualname__", "run")
    specs = [RunSpec(JOB, what, i, settings=(("job", job),), name=f"{what}-{i}")
             for i, job in enumerate(jobs)]
    return execute(specs, workers=workers, scheduler=scheduler, runner=functools.partial(_run_job, run),
                   quiet=quiet)


def _run_job(run: Callable[[Any], Any], spec: RunSpec) -> Any:
    """*run* of the job *spec* carries (:func:`map_runs`)."""
    return run(dict(spec.settings)["job"])


def seeded_rows(run: Callable[[int], list], seeds: Sequence[int], workers: int = 2,
                scheduler: str | None = None) -> list:
    """The rows of every seed's *run* (a list of rows each), seeds in order (:func:`map_runs`)."""
    return [row for rows in map_runs(run, list(seeds), workers, scheduler) for row in rows]
