"""The ``startup`` target of `python -m lab.bench`: what a fresh process costs before and around its work.

Every figure is the median wall time of ``--repeats`` (7) fresh processes, the kinds taken in turn
(so a machine busy for a moment slows them alike), each also as a ratio to the interpreter alone
(``python -c pass``):

* ``openshoe-emu --help`` and ``openshoe-host --help`` — the command lines themselves;
* the imports of a batch replay (``import firmware_sim.app.replay_cli``), and numba's, which a
  replay needs only when its loop was not built ahead of time (:mod:`firmware_sim.nav.aot`);
* the compiled path's preparation in a fresh process (:func:`firmware_sim.nav.warmup.prepare_compiled_path`:
  the loop built ahead of time found, or the kernels loaded from numba's cache), timed inside it;
* one walk: ``openshoe-emu replay WALK --wire OUT -q`` of the first shared walk (a scenario when
  there is none), start-up included — the figure, against 0.3 s.

A first, unmeasured replay fills numba's cache if it is empty.
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from .files import WALK_GLOB, default_walks_dir
from .result import Result

__all__ = ["STARTUP_TARGET_S", "bench_startup"]

#: One walk in a fresh process, start-up included [s].
STARTUP_TARGET_S = 0.3
#: The preparation's result and seconds, and whether the loop was built ahead of time, from a fresh process.
_PREPARE = ("from firmware_sim.nav import fastpath, warmup; found = warmup.prepare_compiled_path(None); "
            "print(found.compiled, found.seconds, fastpath.ahead_of_time())")


def _commands(walk: list[str], out: Path) -> dict[str, list[str]]:
    py = [sys.executable]
    return {
        "python": [*py, "-c", "pass"],
        "emu_help": [*py, "-m", "firmware_sim.app.cli", "--help"],
        "host_help": [*py, "-m", "hostlib.cli", "--help"],
        "numba_import": [*py, "-c", "import numba"],
        "replay_import": [*py, "-c", "import firmware_sim.app.replay_cli"],
        "one_walk": [*py, "-m", "firmware_sim.app.cli", "replay", *walk, "--wire", str(out / "w.bin"), "-q"],
    }


def _wall(cmd: list[str]) -> tuple[float, str]:
    t0 = time.perf_counter()
    done = subprocess.run(cmd, check=True, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    return time.perf_counter() - t0, done.stdout


def bench_startup(repeats: int, say: Callable[[str], None], walks_dir: Path | None = None) -> Result:
    """Fresh processes of each kind, *repeats* times in turn: medians, and ratios to ``python -c pass``."""
    shared = sorted((walks_dir or default_walks_dir()).glob(WALK_GLOB))
    walk = [str(shared[0])] if shared else ["--scenario", "stand:3+walk:20"]
    with tempfile.TemporaryDirectory(prefix="openshoe-startup-") as tmp:
        commands = _commands(walk, Path(tmp))
        _wall(commands["one_walk"])  # fills numba's cache if it is empty; not measured
        say(f"startup: {len(commands) + 1} kinds of fresh process, {repeats} of each, in turn; one walk: "
            f"{' '.join(walk)}")
        walls: dict[str, list[float]] = {name: [] for name in commands}
        prepare: list[float] = []
        compiled = ahead = True
        for _ in range(repeats):
            for name, cmd in commands.items():
                walls[name].append(_wall(cmd)[0])
            printed = _wall([sys.executable, "-c", _PREPARE])[1].split()
            compiled = compiled and printed[0] == "True"
            ahead = ahead and printed[2] == "True"
            prepare.append(float(printed[1]))
    median = {name: statistics.median(w) for name, w in walls.items()}
    median["prepare_in_process"] = statistics.median(prepare)
    base = median["python"]
    # without written bytecode (PYTHONDONTWRITEBYTECODE) every process compiles the sources it imports
    details: dict[str, Any] = {"repeats": repeats, "walk": " ".join(walk), "compiled_path": compiled,
                               "ahead_of_time": ahead,
                               "bytecode_written": not sys.dont_write_bytecode}
    for name, seconds in median.items():
        details[f"{name}_s"] = round(seconds, 4)
        if name != "python":
            details[f"{name}_ratio_to_python"] = round(seconds / base, 1) if base else None
    details["one_walk_min_s"] = round(min(walls["one_walk"]), 4)
    say("startup: median wall of a fresh process — " + ", ".join(
        f"{name} {1e3 * s:.0f} ms" + ("" if name == "python" else f" ({s / base:.0f}×)")
        for name, s in median.items()))
    figure = median["one_walk"]
    ms = {name: f"{1e3 * s:.0f} ms" for name, s in median.items()}
    return Result("startup", figure, "s for one walk in a fresh process", STARTUP_TARGET_S, higher=False,
                  passed=figure <= STARTUP_TARGET_S, details=details,
                  note=f"--help {ms['emu_help']}, imports {ms['replay_import']}, kernels "
                       f"{ms['prepare_in_process']}, python {ms['python']}")
