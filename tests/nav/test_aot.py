"""The loop and the walk reader built ahead of time (no numba when they run) give exactly what
numba's give: the wire bytes and every state, and every number of a walk file."""

from __future__ import annotations

import shutil
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

from firmware_sim import prebuilt
from firmware_sim.app.batch import run_replay
from firmware_sim.mcu.module import ModuleConfig
from firmware_sim.nav import aot, fastpath, jit
from firmware_sim.nav.firmware import build_module
from firmware_sim.sensors import openshoe_scan
from firmware_sim.sensors.imu_array import make_source

pytestmark = pytest.mark.skipif(not jit.COMPILING or not aot.wanted(),
                                reason="building ahead of time needs numba (and OPENSHOE_AOT not 0)")

WALK = Path(__file__).resolve().parents[3] / "shared" / "data" / "openshoe-walks" / "walk_100521_2.txt"


def replay_with(monkeypatch, loop, **options):
    """A short walk replayed with *loop* as the compiled loop (None: numba's): its bytes and states."""
    monkeypatch.setattr(aot, "_loaded", [loop])
    data = run_replay(make_source("stand:3+walk:10+turn:90+walk:5+stand:2", seed=4), announce=None,
                      **options)
    assert data.module.compiled
    return bytes(data), data.module.memory.arena.tobytes()


@pytest.mark.parametrize("height_compensation", [False, True])
def test_the_loop_built_ahead_of_time_sends_and_holds_what_numbas_does(monkeypatch, height_compensation):
    assert aot.build(), "built for the present sources (or there already)"
    built = prebuilt.load(aot.module_path(), "run_loops")
    assert built is not None
    ahead = replay_with(monkeypatch, built, height_compensation=height_compensation)
    numbas = replay_with(monkeypatch, None, height_compensation=height_compensation)
    assert ahead[0] == numbas[0], "the wire bytes"
    assert ahead[1] == numbas[1], "every state"


def test_the_process_that_compiled_runs_the_loop_it_then_built(monkeypatch, tmp_path):
    """A first run looks for the built loop, finds none, compiles numba's and then builds the loop:
    the modules it starts after that run the built one, and a lockstep of them does not split its
    calls with a helper thread (it would with numba's)."""
    assert aot.build(), "built for the present sources (or there already)"
    built = aot.module_path()
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))  # an empty cache: nothing built for it yet
    monkeypatch.setattr(aot, "_compile", lambda folder: shutil.copy(built, folder / built.name))
    monkeypatch.setattr(openshoe_scan, "build", lambda: None)  # the walk reader's build: not this test's
    monkeypatch.setattr(aot, "_loaded", [None])  # looked for before the build
    monkeypatch.setattr(aot, "_loaded_group", [])
    monkeypatch.setattr(aot, "_sharing", [])
    assert fastpath.group_loop() is not aot.run_group() and fastpath.group_releases_gil(), "numba's"
    assert aot.build() and aot.module_path().parent == tmp_path
    assert aot.run_loops() is not None and fastpath.ahead_of_time()
    module = build_module(ModuleConfig(compiled=True))
    assert fastpath.FastNav(module)._run is aot.run_loops()
    assert fastpath.group_loop() is aot.run_group() is not None
    assert not fastpath.group_releases_gil()


def test_the_reader_built_ahead_of_time_reads_what_numbas_reads():
    assert openshoe_scan.build(), "built for this reader (or there already)"
    built, numbas = openshoe_scan._built(), openshoe_scan._numba_scan()
    assert built is not None and numbas is not None
    data = WALK.read_bytes() if WALK.is_file() else openshoe_scan._SAMPLE_ROW * 500
    start = data.index(b"\n", data.index(b"Header:")) + 1 if WALK.is_file() else 0
    end = data.rindex(b"\n") + 1
    buf = np.frombuffer(data, dtype=np.uint8)
    rows = (end - start) // openshoe_scan.MIN_ROW_BYTES + 1
    outs = [np.empty((rows, openshoe_scan.N_KEPT)) for _ in range(2)]
    got = [scan(buf, start, end, openshoe_scan.COLUMNS, openshoe_scan.KEPT, out)
           for scan, out in zip((built, numbas), outs, strict=True)]
    assert got[0] == got[1] and got[0][0] > 0
    assert outs[0][:got[0][0]].tobytes() == outs[1][:got[1][0]].tobytes()


def test_the_reader_built_ahead_of_time_lets_other_threads_run_while_it_reads():
    """A batch's reader thread reads the next walks while the runs go on: the built reader lets go
    of the GIL for its scan. The GIL is never taken from a thread here (a switch interval of 100 s),
    so this thread can run during the scan only if the scan lets it go."""
    assert openshoe_scan.build(), "built for this reader (or there already)"
    built = openshoe_scan._built()
    assert built is not None
    rows = 300_000  # a tenth of a second's scan and more: long enough for this thread to wake meanwhile
    data = openshoe_scan._SAMPLE_ROW * rows
    buf = np.frombuffer(data, dtype=np.uint8)
    out = np.empty((rows, openshoe_scan.N_KEPT))
    started, finished, seen = threading.Event(), threading.Event(), []

    def read() -> None:
        started.set()
        seen.append(built(buf, 0, len(data), openshoe_scan.COLUMNS, openshoe_scan.KEPT, out))
        finished.set()

    interval = sys.getswitchinterval()
    sys.setswitchinterval(100.0)
    try:
        reader = threading.Thread(target=read)
        reader.start()
        started.wait()
        ran_during_the_scan = not finished.is_set()
        reader.join()
    finally:
        sys.setswitchinterval(interval)
    assert seen == [(rows, openshoe_scan.OK)]
    assert ran_during_the_scan
