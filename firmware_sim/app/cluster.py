"""Running many :class:`~firmware_sim.app.runs.RunSpec` on Dask distributed, or in this process.

* :func:`open_client` — a :class:`distributed.LocalCluster` of *workers* processes with one
  thread each, or a client of an existing cluster (``tcp://HOST:PORT``).
* :func:`execute` — every run, in order of the specs: with the default runner in groups replayed in
  lockstep (:func:`~firmware_sim.app.runs.run_many`: :data:`TASK_RUNS` runs a task on a cluster,
  :data:`~firmware_sim.app.replay_group.LOCKSTEP_RUNS` at a time here), with another runner one
  task a run. Dask retries a task that raised (``retries``) and reschedules the tasks of a worker
  that died (the scheduler's ``allowed-failures``, 3 by default): each run's row comes back
  exactly once. With no client, the runs go one after the other in this process. The rows do not
  depend on where a run went, nor on its group: a run is a pure function of its spec.
* :class:`~firmware_sim.app.cluster_plugin.PrepareWorker` — a worker plugin: every worker, a
  restarted one too, loads the compiled tracking kernels and the walk reader from numba's
  on-disk cache (:func:`firmware_sim.nav.warmup.prepare_compiled_path`) before its first task,
  instead of compiling them again. :func:`open_client` prepares this process first, so that a local
  cluster's workers find the cache filled (``NUMBA_CACHE_DIR`` if set, else ``__pycache__``
  beside the sources; the workers inherit the environment).

``distributed`` is imported only where a cluster is used: runs in this process start without it.
"""

from __future__ import annotations

import contextlib
import logging
from collections.abc import Callable, Iterator, Sequence
from typing import Any

from .prepare import prepare_process
from .progress import progress_bar
from .runs import RunSpec, run_many, run_one

__all__ = ["execute", "open_client", "prepare_process"]

Runner = Callable[[RunSpec], dict[str, Any]]
#: Retries of a task that raised (a worker that died is the scheduler's business).
RETRIES = 2
#: Runs in one task of a cluster, replayed in lockstep (few: the tasks still spread over the workers).
TASK_RUNS = 4


@contextlib.contextmanager
def open_client(workers: int = 2, scheduler: str | None = None) -> Iterator[Any]:
    """A Dask client: of the cluster at *scheduler*, or of a new local cluster of *workers*
    processes (1 thread each, no dashboard), closed on exit. Workers get
    :class:`~firmware_sim.app.cluster_plugin.PrepareWorker`."""
    from distributed import Client, LocalCluster

    from .cluster_plugin import PrepareWorker

    with local_worker_environment():
        if scheduler is not None:
            client, cluster = Client(scheduler), None
        else:
            prepare_process()
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                   dashboard_address=None, silence_logs=logging.ERROR)
            client = Client(cluster)
        try:
            client.register_plugin(PrepareWorker())
            yield client
        finally:
            client.close()
            if cluster is not None:
                cluster.close()


@contextlib.contextmanager
def local_worker_environment() -> Iterator[None]:
    """The environment Dask's nannies give the worker processes they start, without
    ``MALLOC_TRIM_THRESHOLD_``: set, it turns off glibc's adaptive mmap threshold, so every
    large numpy array of a run is mapped and unmapped afresh — a run then spends about as much
    time in the kernel as in Python (measured: 0.6 s instead of 0.35 s per ``rectangle`` run)."""
    import dask

    key = "distributed.nanny.pre-spawn-environ"
    environ = {k: v for k, v in dask.config.get(key, {}).items() if k != "MALLOC_TRIM_THRESHOLD_"}
    with dask.config.set({key: environ}):
        yield


def execute(runs: Sequence[RunSpec], client: Any | None = None, *, runner: Runner = run_one,
            retries: int = RETRIES, quiet: bool = False) -> list[dict[str, Any]]:
    """The row of every run, in the order of *runs*: on *client*'s cluster, or here in turn."""
    from .replay_group import LOCKSTEP_RUNS

    grouped = runner is run_one
    size = 1 if not grouped else LOCKSTEP_RUNS if client is None else TASK_RUNS
    groups = [list(runs[i:i + size]) for i in range(0, len(runs), size)]
    task: Callable[[list[RunSpec]], list[dict[str, Any]]] = run_many if grouped else (
        lambda group: [runner(spec) for spec in group])
    with progress_bar(len(runs), "sweep", "runs", quiet=quiet) as bar:
        if client is None:
            rows = []
            for group in groups:
                rows.extend(task(group))
                bar.update(len(group))
            return rows
        from distributed import as_completed

        keys = [f"openshoe-runs-{i}-{_token(group)}" for i, group in enumerate(groups)]
        futures = client.map(task, groups, key=keys, retries=retries, pure=False)
        sizes = {key: len(group) for key, group in zip(keys, groups, strict=True)}
        for future in as_completed(futures):
            bar.update(sizes[future.key])
        return [row for rows in client.gather(futures) for row in rows]


def _token(group: list[RunSpec]) -> str:
    from dask.base import tokenize

    return tokenize([(s.kind, s.source, s.seed, s.module, s.rate_hz, s.settings) for s in group])
