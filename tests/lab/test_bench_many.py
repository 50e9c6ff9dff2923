"""The `files` and `sweep` targets of `python -m lab.bench`: their inputs, and the line `files` prints."""

from __future__ import annotations

import json
import re

import pytest

from lab.bench import main
from lab.bench.files import _split
from lab.bench.sweep import sweep_spec

LINE = re.compile(r"^(\w+): ([\d.]+) (.+?) \(target ([\d.]+), ratio (\d+\.\d\d)\)")


def test_the_sweep_target_has_at_least_the_runs_asked_for():
    runs = sweep_spec(64).runs()
    assert len(runs) == 64 and len({r.key for r in runs}) == 64
    assert len(sweep_spec(65).runs()) >= 65


def test_the_files_split_gives_start_up_the_time_outside_the_runs():
    rows = [{"parse_s": "0.01", "nav_s": "0.02", "write_s": "0.001", "time_s": "0.035"}] * 4
    split = _split(rows, wall=1.0, runs_wall=0.2)
    assert split["startup_s"] == pytest.approx(0.8)
    assert split["parse_s"] == pytest.approx(0.04) and split["nav_s"] == pytest.approx(0.08)
    assert split["summing_s"] == pytest.approx(4 * 0.004)


@pytest.mark.slow
def test_the_files_target_prints_walks_per_second(walks_dir, tmp_path, capsys):
    out = tmp_path / "bench.json"
    main(["files", "--walks", "3", "--json", str(out)])
    mo = LINE.match(capsys.readouterr().out.strip().splitlines()[-1])
    assert mo and mo.group(1) == "files" and mo.group(3) == "walks/s" and float(mo.group(2)) > 0
    (res,) = json.loads(out.read_text())["results"]
    assert res["details"]["walks"] == 3 and res["details"]["identical_copies"] is True
    assert {"startup_s", "parse_s", "nav_s", "write_s"} <= res["details"].keys()
