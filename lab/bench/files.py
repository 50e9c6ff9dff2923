"""The ``files`` target of `python -m lab.bench`: a recording set through ``openshoe-emu replay``, end to end.

One command replays ``--walks`` (100) walk files — the six shared OpenShoe walks over and over —
into a folder, in a subprocess, start-up included (the interpreter, the imports, loading the
compiled kernels built ahead of time). The figure is walks per second of that command's wall
time; the command runs its walks in a worker process for each CPU (``--jobs``' default,
:mod:`firmware_sim.app.replay_pool`). The split comes from the per-run table it writes
(``--table``), summed over the workers (so it may exceed the wall time): parsing (reading the file
into the replicated board's registers), navigation (the module's run), writing (the wire file),
summing (the host's track for the table); start-up is the command's wall time before its runs
begin (the interpreter, the imports, loading the compiled kernels).
A first, unmeasured command with one walk builds the kernels if they are not built yet. Every copy of a
walk must give the same wire bytes.
"""

from __future__ import annotations

import csv
import math
import os
import re
import resource
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from . import Result

__all__ = ["FILES_TARGET", "bench_files", "default_walks_dir"]

#: Walks per second on the 2-core reference machine.
FILES_TARGET = 60.0
WALK_GLOB = "walk_*.txt"


def default_walks_dir() -> Path:
    """``OPENSHOE_WALKS``, else ``shared/data/openshoe-walks`` beside the clone."""
    here = Path(__file__).resolve().parents[2]
    return Path(os.environ.get("OPENSHOE_WALKS", here.parent / "shared" / "data" / "openshoe-walks"))


def _children_cpu_s() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _replay(paths: list[Path], out: Path) -> tuple[float, float, float]:
    """Run ``openshoe-emu replay PATHS --wire-dir out/wire --table out/runs.csv``: its wall time,
    the wall time of its runs (from its last line, ``… runs/s (S s) → DIR``) and its CPU time (all
    its processes and threads: on a loaded machine the steadier figure)."""
    cmd = [sys.executable, "-m", "firmware_sim.app.cli", "replay", *map(str, paths),
           "--wire-dir", str(out / "wire"), "--table", str(out / "runs.csv"), "--quiet"]
    out.mkdir(parents=True, exist_ok=True)  # replay refuses a table whose folder is missing
    cpu0, t0 = _children_cpu_s(), time.perf_counter()
    done = subprocess.run(cmd, check=True, stdout=subprocess.PIPE, text=True)
    wall, cpu = time.perf_counter() - t0, _children_cpu_s() - cpu0
    found = re.search(r"runs/s \(([\d.]+) s\)", done.stdout.strip().splitlines()[-1])
    return wall, float(found.group(1)) if found else math.nan, cpu


def _split(rows: list[dict[str, str]], wall: float, runs_wall: float) -> dict[str, float]:
    total = {k: sum(float(r[k]) for r in rows) for k in ("parse_s", "nav_s", "write_s", "time_s")}
    return {"startup_s": wall - runs_wall, "parse_s": total["parse_s"], "nav_s": total["nav_s"],
            "write_s": total["write_s"],
            "summing_s": total["time_s"] - total["parse_s"] - total["nav_s"] - total["write_s"]}


def bench_files(walks: int, walks_dir: Path, say: Callable[[str], None]) -> Result:
    """``walks`` files in one ``openshoe-emu replay`` command: walks/s and where the time goes."""
    shared = sorted(walks_dir.glob(WALK_GLOB))
    if not shared:
        say(f"files: no {WALK_GLOB} in {walks_dir} (set OPENSHOE_WALKS)")
        return Result("files", 0.0, "walks/s", FILES_TARGET, note=f"no walks in {walks_dir}")
    paths = [shared[i % len(shared)] for i in range(walks)]
    with tempfile.TemporaryDirectory(prefix="openshoe-files-") as tmp:
        out = Path(tmp)
        _replay(paths[:1], out / "warm")  # builds the kernels if they are not built; not measured
        say(f"files: {walks} walks ({len(shared)} shared walks repeated) in one command")
        wall, runs_wall, cpu = _replay(paths, out / "run")
        with (out / "run" / "runs.csv").open() as f:
            rows = list(csv.DictReader(f))
    split = _split(rows, wall, runs_wall)
    by_source: dict[str, set[str]] = {}
    for r in rows:
        by_source.setdefault(r["source"], set()).add(r["wire_sha256"])
    identical = len(rows) == walks and all(len(s) == 1 for s in by_source.values())
    rate = walks / wall
    per_walk = {k.replace("_s", "_ms_per_walk"): round(1e3 * v / walks, 2) for k, v in split.items()}
    details: dict[str, Any] = {"walks": walks, "wall_s": round(wall, 3), "cpu_s": round(cpu, 3),
                               "walks_per_cpu_s": round(walks / cpu, 1), "identical_copies": identical,
                               **{k: round(v, 3) for k, v in split.items()}, **per_walk}
    say(f"files: {rate:.1f} walks/s ({wall:.2f} s; {walks / cpu:.1f} walks per CPU second, {cpu:.2f} s CPU): "
        f"start-up {split['startup_s']:.2f} s, parsing {split['parse_s']:.2f} s, navigation "
        f"{split['nav_s']:.2f} s, writing {split['write_s']:.2f} s, "
        f"summing steps {split['summing_s']:.2f} s; per walk parsing {per_walk['parse_ms_per_walk']} ms vs "
        f"navigation {per_walk['nav_ms_per_walk']} ms; copies identical: {identical}")
    return Result("files", rate, "walks/s", FILES_TARGET, passed=rate >= FILES_TARGET and identical,
                  details=details, note=f"{walks / cpu:.1f} walks per CPU second; parse "
                                        f"{per_walk['parse_ms_per_walk']} ms/walk vs navigation "
                                        f"{per_walk['nav_ms_per_walk']} ms/walk")
