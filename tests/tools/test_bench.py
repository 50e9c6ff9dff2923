"""`openshoe-bench`: the summary lines and the JSON file a reader of the benchmark relies on."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from tools.bench import Result, machine_info, main
from tools.bench.targets import RepeatingWalk

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
    """``tools.bench`` runs ``tools.bench.targets``; both take Result from ``tools.bench.result``."""
    from tests.test_layering import project_imports
    from tools.bench import result

    assert "tools.bench" not in project_imports("tools.bench.targets")
    assert "tools.bench" not in project_imports("tools.bench.result")
    assert Result is result.Result


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
