"""`python -m lab.bench`: the emulator's performance targets, measured as ratios in one run.

Targets (``python -m lab.bench [TARGET …]``, all of them by default):

* ``batch`` — the full firmware pipeline of step-wise dead reckoning (4 IMUs at 1 kHz:
  read, front end, detector, INS, step-wise reset, packet assembly, the host's acks)
  on a simulated walk, compiled and pure Python on the same input, side by side;
  target 340 000 samples/s on one core. Under a minute.
* ``realtime`` — ``--modules`` (50) modules at 1 kHz in two ``openshoe-emu serve``
  processes (one per core, each pinned to it; their loops at real-time priority ``--rt-priority``,
  10), each on its own pty with a host that starts step-wise dead reckoning and acknowledges every
  step, for ``--minutes`` (10); target: no overrun. Per process: its loop's priority, the seconds it waited
  for a CPU, the garbage collector's runs, its CPU per module and tick; the machine's load.
* ``latency`` — one module served in real time on a pty: time from a command written on
  the pty to its ack read back (p99), ``--pings`` (2000); target ≤ 1 ms.
* ``files`` — ``--walks`` (100) walk files through one ``openshoe-emu replay`` command, start-up
  included: walks/s (target 60) and the time split (:mod:`lab.bench.files`).
* ``lockstep`` — ``--walks`` (64 here) replays of the six shared walks navigated K at a time
  (K = 1, 4, 16, 64), compiled: samples/s (target 1.5 M at K = 16, the batch replay's), per CPU
  second and the compiled loop's share, every walk's bytes the same at every K
  (:mod:`lab.bench.lockstep`).
* ``sweep`` — a sweep of ``--runs`` (64) runs on 1, then 2 local Dask workers: the speed-up
  (target 1.7) and identical tables (:mod:`lab.bench.sweep`).
* ``startup`` — fresh processes, ``--repeats`` (7) of each kind in turn: one walk replayed
  (target ≤ 0.3 s), the two commands' ``--help``, a replay's imports, the kernels' loading from
  numba's cache, each also as a ratio to ``python -c pass`` (:mod:`lab.bench.startup`).
* ``memory`` — a batch run of ``--cycles`` loop cycles (86.4 M = 24 h at 1 kHz) of a
  repeated walk, compiled; RSS sampled along the way: peak and growth (flat = < 5 %).
* ``hostile`` — ``--modules`` (10) served modules, each with a hostile client (random
  well-formed commands of every kind, random bytes, leaving and coming back) for
  ``--minutes`` (10), beside the same run with a well-behaved host on each module
  (``--baseline``): overruns beyond the baseline's, the worst loop, late bytes, the serve
  process's RSS over time, non-finite states; at the end every module must answer a clean
  PING and track (:mod:`lab.bench.hostile`). A table per module and process.

Last, one line per target: ``<name>: <figure> <unit> (target <t>, ratio <figure/t>)``; the same
figures go to ``--json`` (default ``out/bench.json``) with the machine (cpu, cores, python,
numpy, numba). Shorter runs of the long targets (``--minutes``, ``--modules``, ``--cycles``)
are marked "SHORT" in the output and the JSON.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from dataclasses import asdict
from pathlib import Path
from typing import Any

from .result import Result

__all__ = ["Result", "main", "machine_info"]

TARGETS = ("batch", "realtime", "latency", "memory", "files", "lockstep", "sweep", "startup", "hostile")
#: --modules when not given, by target.
DEFAULT_MODULES = {"realtime": 50, "hostile": 10}
#: 24 h at 1 kHz.
FULL_CYCLES = 86_400_000


def machine_info() -> dict[str, Any]:
    """CPU model, cores, python, numpy and numba versions."""
    import numpy as np

    cpu = platform.processor() or ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    try:
        import numba

        numba_v: str | None = numba.__version__
    except ImportError:
        numba_v = None
    from firmware_sim.nav import fastpath

    return {
        "cpu": cpu,
        "cores": os.cpu_count(),
        "python": platform.python_version(),
        "implementation": platform.python_implementation(),
        "numpy": np.__version__,
        "numba": numba_v,
        "compiled_path": fastpath.available(),
        "compiled_unavailable_reason": fastpath.reason_unavailable(),
        "platform": platform.platform(),
    }


def _say(msg: str) -> None:
    from firmware_sim.app.progress import say

    say(msg)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m lab.bench", description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("targets", nargs="*", metavar="TARGET",
                   help=f"targets to run: {', '.join(TARGETS)} (default: all)")
    p.add_argument("--json", type=Path, default=Path("out/bench.json"), help="write the figures here")
    p.add_argument("--walk-s", type=float, default=20.0,
                   help="batch: seconds of simulated walking after 3 s standing (default 20)")
    p.add_argument("--modules", type=int,
                   help="realtime: modules in total (default 50); hostile: modules in each run (default 10)")
    p.add_argument("--processes", type=int, default=2, help="realtime: serve processes (default 2)")
    p.add_argument("--minutes", type=float, default=10.0,
                   help="realtime, hostile: wall minutes of load (default 10)")
    p.add_argument("--frame-ms", type=float,
                   help="realtime: serve's --frame-ms (default: serve's own default for several modules)")
    p.add_argument("--rt-priority", type=int, default=10, metavar="LEVEL",
                   help="realtime: the serve processes' loops at this real-time priority (serve's "
                        "--rt-priority; default 10; 0: the ordinary priority)")
    p.add_argument("--pings", type=int, default=2000, help="latency: commands sent (default 2000)")
    p.add_argument("--cycles", type=float, default=FULL_CYCLES,
                   help="memory: loop cycles (default 86.4e6 = 24 h at 1 kHz)")
    p.add_argument("--walks", type=int,
                   help="files: walk files replayed (default 100); lockstep: replays (default 64)")
    p.add_argument("--runs", type=int, default=64, help="sweep: runs in the sweep (default 64)")
    p.add_argument("--repeats", type=int, default=None,
                   help="startup: fresh processes of each kind (default 7); the medians are reported; "
                        "lockstep: runs of each K (default 3), the best reported")
    p.add_argument("--baseline", choices=("side-by-side", "before"), default="side-by-side",
                   help="hostile: the run without hostile clients runs beside the hostile one (default) "
                        "or before it")
    p.add_argument("--hostile-rate", type=float, default=10.0,
                   help="hostile: actions per second of each hostile client (default 10)")
    p.add_argument("--hostile-commands", metavar="NAME,…", default="",
                   help="hostile: send only these commands (names of protocol/'s table, e.g. "
                        "SET_IMU_BANDWIDTH,PING), to find which ones cost what (default: every command)")
    p.add_argument("--seed", type=int, default=0,
                   help="hostile: seed of the modules and the clients (default 0)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bars")
    args = p.parse_args(argv)
    targets = args.targets or list(TARGETS)
    bad = [t for t in targets if t not in TARGETS]
    if bad:
        p.error(f"unknown target(s) {', '.join(bad)}; choose from {', '.join(TARGETS)}")
    from . import targets as t

    hostile = None
    if "hostile" in targets:  # refused values before any target runs
        from .hostile_plan import hostile_plan

        try:
            modules = DEFAULT_MODULES["hostile"] if args.modules is None else args.modules
            hostile = hostile_plan(modules, args.minutes, args.baseline,
                                   args.seed, args.hostile_rate,
                                   commands=tuple(c for c in args.hostile_commands.split(",") if c))
        except ValueError as exc:
            p.error(str(exc))

    machine = machine_info()
    _say(f"machine: {machine['cpu']}, {machine['cores']} cores, python {machine['python']}, "
         f"numpy {machine['numpy']}, numba {machine['numba']} (compiled path "
         f"{'on' if machine['compiled_path'] else 'OFF: ' + machine['compiled_unavailable_reason']})")
    results: list[Result] = []
    for name in targets:
        _say(f"--- {name}")
        t0 = time.monotonic()
        modules = args.modules if args.modules is not None else DEFAULT_MODULES.get(name, 0)
        if name == "batch":
            r = t.bench_batch(args.walk_s, _say)
        elif name == "realtime":
            r = t.bench_realtime(modules, args.processes, args.minutes, _say, frame_ms=args.frame_ms,
                                 quiet=args.quiet, rt_priority=args.rt_priority or None)
        elif name == "hostile":
            from .hostile import bench_hostile

            r = bench_hostile(hostile, _say, quiet=args.quiet)
        elif name == "latency":
            r = t.bench_latency(args.pings, _say, quiet=args.quiet)
        elif name == "files":
            from .files import bench_files, default_walks_dir

            r = bench_files(100 if args.walks is None else args.walks, default_walks_dir(), _say)
        elif name == "lockstep":
            from .lockstep import bench_lockstep

            r = bench_lockstep(64 if args.walks is None else args.walks, args.repeats or 3, _say)
        elif name == "sweep":
            from .sweep import bench_sweep

            r = bench_sweep(args.runs, _say)
        elif name == "startup":
            from .startup import bench_startup

            r = bench_startup(7 if args.repeats is None else args.repeats, _say)
        else:
            r = t.bench_memory(int(args.cycles), _say, quiet=args.quiet)
        r.details["wall_s"] = round(time.monotonic() - t0, 1)
        results.append(r)
    report = {"machine": machine, "time": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
              "results": [{**{k: v for k, v in asdict(r).items() if k != "table"}, "ratio": r.ratio,
                           "line": r.line()} for r in results]}
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps(report, indent=2, default=str) + "\n")
    _say(f"figures written to {args.json}")
    print(f"machine: {machine['cpu']}, {machine['cores']} cores, python {machine['python']}, "
          f"numpy {machine['numpy']}, numba {machine['numba']}")
    for r in results:
        if r.table:
            print(r.table)
    for r in results:
        print(r.line())
    return 0 if all(r.passed for r in results) else 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
