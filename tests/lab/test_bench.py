"""`python -m lab.bench`: the summary lines and the JSON file a reader of the benchmark relies on."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from firmware_sim.app.batch import run_replay
from firmware_sim.mcu.module import ModuleConfig
from firmware_sim.sensors.imu_array import make_source
from lab.bench import Result, machine_info, main
from lab.bench.driver import run_session
from lab.bench.targets import RepeatingWalk

LINE = re.compile(r"^(\w+): ([\d.]+) (.+?) \(target ([\d.]+), ratio (\d+\.\d\d)\)")


def test_result_line_format_and_ratio() -> None:
    r = Result("batch", 412000.0, "samples/s", 340000.0, passed=True)
    assert r.line() == "batch: 412000 samples/s (target 340000, ratio 1.21)"
    low = Result("latency", 1.234, "ms p99", 2.0, higher=False, passed=True)
    assert low.line() == "latency: 1.23 ms p99 (target 2, ratio 0.62)"
    short = Result("realtime", 10, "modules without overrun", 50.0, passed=False, short=True)
    assert short.line().startswith("realtime: 10 modules without overrun (target 50, ratio 0.20) NOT MET")
    assert "SHORT" in short.line()


def test_the_targets_do_not_import_the_package_that_runs_them() -> None:
    """``lab.bench`` runs ``lab.bench.targets``; both take Result from ``lab.bench.result``."""
    from lab.bench import result
    from tests.test_layering import project_imports

    assert "lab.bench" not in project_imports("lab.bench.targets")
    assert "lab.bench" not in project_imports("lab.bench.result")
    assert Result is result.Result


def test_session_driver_is_the_replay_session() -> None:
    """The benchmark's driver sends and acknowledges exactly like firmware_sim.app.batch.run_replay."""
    source = make_source("stand:2+walk:2", seed=5)
    reference = run_replay(source, config=ModuleConfig(rate_hz=source.rate_hz, compiled=False))
    assert run_session(source, compiled=False).wire == bytes(reference)


def test_machine_is_noted() -> None:
    m = machine_info()
    assert {"cpu", "cores", "python", "numpy", "numba", "compiled_path"} <= m.keys()
    assert m["cores"] >= 1


def test_unknown_target_refused(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["speed"])
    assert "unknown target" in capsys.readouterr().err


def test_repeating_walk_blocks_match_reads() -> None:
    """The memory target's long input: blocks and single reads agree, across the seam."""
    src = RepeatingWalk(5000, recipe="stand:1+walk:1")
    n = len(src.base.imu)
    block = src.imu_block(n - 3, 10)
    assert len(block) == 3  # stops at the seam; the next block starts over
    assert (src.imu_block(n, 2)[0] == src.read(0).imu).all()
    assert (block[1] == src.read(n - 2).imu).all()
    assert src.read(5000) is None and len(src.imu_block(4990, 100)) == 10


@pytest.mark.slow
def test_batch_target_prints_its_line_and_json(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "bench.json"
    main(["batch", "--walk-s", "1", "--json", str(out)])
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[0].startswith("machine: ")
    mo = LINE.match(lines[-1])
    assert mo and mo.group(1) == "batch" and mo.group(3) == "samples/s" and mo.group(4) == "340000"
    data = json.loads(out.read_text())
    (res,) = data["results"]
    assert res["name"] == "batch" and res["details"]["pure_samples_per_s"] > 0
    assert data["machine"]["cores"] >= 1
    if res["details"]["compiled"]:
        assert res["details"]["identical_bytes"] is True


def test_realtime_plan_spreads_the_modules_over_the_processes() -> None:
    from lab.bench.targets import _realtime_plan

    plan = _realtime_plan(50, 2, 10.0, None)
    assert plan.per == [25, 25] and plan.frame_len == 4.0 and not plan.short
    assert plan.scenario == "stand:3+walk:177", "long runs hold the last sample after 3 minutes"
    plan = _realtime_plan(5, 2, 0.5, 2.0)
    assert plan.per == [3, 2] and plan.frame_len == 2.0 and plan.short
    assert plan.scenario == "stand:3+walk:60"
    assert _realtime_plan(1, 1, 1.0, None).frame_len == 1.0, "one module per process: 1-ms frames"


def test_realtime_figures_from_the_status_lines() -> None:
    from lab.bench.targets import _realtime_details, _realtime_plan, _realtime_result, _ServeStatus

    status = _ServeStatus()
    for process, module, overruns in ((0, 0, 0), (0, 1, 2), (1, 0, 0)):
        status.add(process, {"module": module, "overruns": overruns, "late_bytes": 1, "late_max_ms": 0.5,
                             "lookahead_ms": 19.0, "overrun_limit_ms": 35.0, "lag_max_ms": 3.0 + module,
                             "loop_us_mean": 10.0, "lag_frames": {"<1ms": 10, "<2ms": 1}})
    steps = {"p0.m0.bt-pty": 4, "p0.m1.bt-pty": 3, "p1.m0.bt-pty": 0}
    plan = _realtime_plan(3, 2, 0.1, None)
    details = _realtime_details(plan, status, steps, per_tick=20.0)
    assert details["overruns"] == {"p0.m0": 0, "p0.m1": 2, "p1.m0": 0}
    assert details["frames_by_lateness"] == {"<1ms": 30, "<2ms": 3} and details["lag_max_ms"] == 4.0
    said: list[str] = []
    r = _realtime_result(plan, status, details, said.append)
    # the fewer of: modules without overrun (2), modules that sent steps (2)
    assert (r.figure, r.target, r.passed, r.short) == (2, 3.0, False, True)
    assert said[0].startswith("realtime: 2/3 modules without overrun, 2 sent steps (7 in all)")


def test_realtime_says_each_process_s_loop_priority_wait_and_collections() -> None:
    from lab.bench.targets import _realtime_details, _realtime_plan, _realtime_result, _ServeStatus

    status = _ServeStatus()
    status.add(0, {"module": 0, "overruns": 0, "late_bytes": 0, "late_max_ms": 0.0, "lookahead_ms": 19.0,
                   "overrun_limit_ms": 35.0, "lag_max_ms": 3.0, "loop_us_mean": 10.0,
                   "lag_frames": {"<1ms": 10}, "priority": "SCHED_FIFO 10", "run_queue_wait_s": 0.25,
                   "gc_runs": 7, "gc_longest_ms": 0.5})
    status.stalls[0]["cpu_us_per_module_tick"] = 9.5
    plan = _realtime_plan(1, 1, 0.1, None, rt_priority=10)
    said: list[str] = []
    _realtime_result(plan, status, _realtime_details(plan, status, {"p0.m0.bt-pty": 1}, per_tick=9.0),
                     said.append)
    assert ("realtime: p0: loop at SCHED_FIFO 10, waited 0.25 s for a CPU, GC ran 7 times (longest 0.5 ms), "
            "9.5 µs of CPU per module and tick") in said
