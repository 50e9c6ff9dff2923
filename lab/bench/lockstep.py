"""The ``lockstep`` target of `python -m lab.bench`: the six shared walks navigated K at a time.

``--walks`` (64) replays — the six shared OpenShoe walks over and over, read once beforehand —
run in groups of K (:func:`firmware_sim.app.replay_group.run_replays`: the modules' quiet
stretches in one compiled call per round, :mod:`firmware_sim.nav.lockstep`) for K = 1, 4, 16, 64,
each K ``--repeats`` (3) times, on the compiled path. The figure is samples per second of wall
time at K = :data:`~firmware_sim.app.replay_group.LOCKSTEP_RUNS` (what ``replay --wire-dir`` runs),
best of the repeats; beside it, per K, the same per second of the process's CPU time and how
much of it the compiled loop took (the rest: the Python around a step's end, the host's acks, the modules'
set-up and drain). Every walk's bytes must be the same at every K.
"""

from __future__ import annotations

import hashlib
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from .files import WALK_GLOB, default_walks_dir
from .result import Result

__all__ = ["LOCKSTEP_TARGET", "bench_lockstep"]

#: Samples per second navigated on the six shared walks (batch replay, compiled path).
LOCKSTEP_TARGET = 1_500_000.0
#: The K of each measurement: replays navigated together.
GROUP_SIZES = (1, 4, 16, 64)


class _Timed:
    """The compiled loop of K modules, its calls timed (the CPU time of the thread that runs each:
    the caller's, or the helper's beside it)."""

    def __init__(self, loop: Callable[..., int]):
        self.loop = loop
        self.seconds = 0.0
        self._lock = threading.Lock()

    def __call__(self, *args: Any) -> int:
        t = time.thread_time()
        try:
            return self.loop(*args)
        finally:
            spent = time.thread_time() - t
            with self._lock:
                self.seconds += spent


def _run(sources: list[Any], k: int, timed: _Timed) -> tuple[float, float, int, list[str]]:
    """Every source replayed, K at a time: wall and CPU seconds (the process's: the helper thread's
    too), samples, each wire's SHA-256."""
    from firmware_sim.app.batch import start_replay
    from firmware_sim.app.replay_group import run_replays
    from firmware_sim.mcu.module import ModuleConfig
    from firmware_sim.nav import fastpath

    releases = fastpath.group_releases_gil()  # of the loop itself, not of the timing wrapper
    wall, cpu = time.perf_counter(), time.process_time()
    samples, digests = 0, []
    for i in range(0, len(sources), k):
        hosts = [start_replay(s, config=ModuleConfig(rate_hz=s.rate_hz, compiled=True), announce=None)
                 for s in sources[i:i + k]]
        original = fastpath.group_loop, fastpath.group_releases_gil
        # the Lockstep of run_replays calls the timed loop
        fastpath.group_loop, fastpath.group_releases_gil = (lambda: timed), (lambda: releases)
        try:
            results = run_replays(hosts)
        finally:
            fastpath.group_loop, fastpath.group_releases_gil = original
        samples += sum(r.samples for r in results)
        digests += [hashlib.sha256(r).hexdigest() for r in results]
    return time.perf_counter() - wall, time.process_time() - cpu, samples, digests


def bench_lockstep(walks: int, repeats: int, say: Callable[[str], None],
                   walks_dir: Path | None = None) -> Result:
    """*walks* replays of the shared walks, K at a time for each K of :data:`GROUP_SIZES`."""
    from firmware_sim.app.replay_group import LOCKSTEP_RUNS
    from firmware_sim.nav import aot, fastpath
    from firmware_sim.nav.warmup import prepare_compiled_path
    from firmware_sim.sensors.replay import ReplaySource

    shared = sorted((walks_dir or default_walks_dir()).glob(WALK_GLOB))
    if not shared:
        say(f"lockstep: no {WALK_GLOB} in the walks folder (set OPENSHOE_WALKS)")
        return Result("lockstep", 0.0, "samples/s", LOCKSTEP_TARGET, note="no walks")
    if not prepare_compiled_path(None).compiled or fastpath.group_loop() is None:
        say(f"lockstep: compiled path unavailable: {fastpath.reason_unavailable()}")
        return Result("lockstep", 0.0, "samples/s", LOCKSTEP_TARGET, note="no compiled path")
    aot.share_cores()  # a helper thread runs half of each group, as in replay --wire-dir
    read = [ReplaySource.from_file(p) for p in shared]
    sources = [read[i % len(read)] for i in range(walks)]
    sizes = ", ".join(map(str, GROUP_SIZES))
    say(f"lockstep: {walks} replays ({len(read)} shared walks repeated), K = {sizes}, {repeats} times each; "
        f"ahead of time: {fastpath.ahead_of_time()}")
    _run(sources[:len(read)], len(read), _Timed(fastpath.group_loop()))  # warm: first calls, caches
    details: dict[str, Any] = {"walks": walks, "repeats": repeats, "ahead_of_time": fastpath.ahead_of_time()}
    digests: dict[int, list[str]] = {}
    rates: dict[int, float] = {}
    for k in GROUP_SIZES:
        best: dict[str, float] = {}
        for _ in range(repeats):
            timed = _Timed(fastpath.group_loop())
            wall, cpu, samples, digests[k] = _run(sources, k, timed)
            if samples / wall > best.get("wall", 0.0):
                best = {"wall": samples / wall, "cpu": samples / cpu, "compiled_share": timed.seconds / cpu}
        rates[k] = best["wall"]
        details[f"k{k}_samples_per_s"] = round(best["wall"])
        details[f"k{k}_cpu_samples_per_s"] = round(best["cpu"])
        details[f"k{k}_compiled_share"] = round(best["compiled_share"], 3)
        say(f"lockstep: K = {k}: {best['wall']:,.0f} samples/s ({best['cpu']:,.0f} per CPU second), "
            f"compiled loop {100 * best['compiled_share']:.0f} % of the CPU time")
    identical = all(d == digests[1] for d in digests.values())
    details["identical_bytes"] = identical
    figure = rates.get(LOCKSTEP_RUNS, max(rates.values()))
    note = ", ".join(f"K={k} {rates[k] / 1e6:.2f} M" for k in GROUP_SIZES) + f"; bytes identical: {identical}"
    return Result("lockstep", figure, f"samples/s at K={LOCKSTEP_RUNS}", LOCKSTEP_TARGET,
                  passed=figure >= LOCKSTEP_TARGET and identical, details=details, note=note)
