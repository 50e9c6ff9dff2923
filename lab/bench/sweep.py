"""The ``sweep`` target of `python -m lab.bench`: the speed-up of a sweep from one Dask worker to two.

The sweep: the ``rectangle`` scenario (a closed loop, 65 s at 1 kHz) × seeds × four detector
thresholds, ``--runs`` (64) runs in all, run on a local cluster of one worker process and then
of two (one thread each). Each time is the sweep's own, from the first task submitted to the
last row back: the cluster is up and its workers prepared (compiled kernels loaded) before the
clock starts. The two tables (timings aside) must be identical.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

from . import Result

__all__ = ["SWEEP_TARGET", "bench_sweep", "sweep_spec"]

#: Speed-up from 1 to 2 workers on the 2-core reference machine.
SWEEP_TARGET = 1.7
SCENARIO = "rectangle"
#: The ZUPT thresholds the benchmark sweep runs over.
THRESHOLDS = (12000, 16000, 20000, 24000)


def sweep_spec(runs: int):
    """At least *runs* runs: the scenario × ⌈runs/4⌉ seeds × :data:`THRESHOLDS`."""
    from firmware_sim.app.sweep import SweepSpec

    seeds = tuple(range(math.ceil(runs / len(THRESHOLDS))))
    spec = SweepSpec(scenarios=(SCENARIO,), seeds=seeds, settings=(("frontend.zupt_threshold", THRESHOLDS),))
    spec.check()
    return spec


def _timed(spec: Any, workers: int, say: Callable[[str], None]) -> tuple[float, list[dict[str, Any]]]:
    from firmware_sim.app import cluster

    runs = spec.runs()
    with cluster.open_client(workers) as client:
        client.wait_for_workers(workers)
        t0 = time.perf_counter()
        rows = cluster.execute(runs, client, quiet=True)
        elapsed = time.perf_counter() - t0
    say(f"sweep: {len(runs)} runs on {workers} worker(s): {elapsed:.1f} s ({len(runs) / elapsed:.2f} runs/s)")
    return elapsed, rows


def _without_timings(rows: list[dict[str, Any]]) -> str:
    from firmware_sim.app.runs import TIMINGS

    return repr([{k: v for k, v in r.items() if k not in TIMINGS} for r in rows])


def bench_sweep(runs: int, say: Callable[[str], None]) -> Result:
    """One sweep on 1 worker, then on 2: the speed-up, and whether the tables agree."""
    spec = sweep_spec(runs)
    say(f"sweep: {SCENARIO} × {len(spec.seeds)} seeds × {len(THRESHOLDS)} thresholds "
        f"= {len(spec.runs())} runs")
    t1, rows1 = _timed(spec, 1, say)
    t2, rows2 = _timed(spec, 2, say)
    identical = _without_timings(rows1) == _without_timings(rows2)
    speedup = t1 / t2
    details = {"runs": len(rows1), "one_worker_s": round(t1, 2), "two_workers_s": round(t2, 2),
               "identical_tables": identical, "run_cpu_s": round(sum(r["time_s"] for r in rows2), 2)}
    say(f"sweep: speed-up 1 → 2 workers {speedup:.2f}; tables identical: {identical}")
    return Result("sweep", speedup, "speed-up (1 → 2 workers)", SWEEP_TARGET,
                  passed=speedup >= SWEEP_TARGET and identical, details=details)
