"""`openshoe-emu replay FILE... --wire-dir DIR`: many replays in one process, each file's bytes
those of a replay of it alone, and a summary table of the runs."""

from __future__ import annotations

import csv
import hashlib
import math

import pytest

from firmware_sim.app import cli
from firmware_sim.app.batch import run_replay
from firmware_sim.app.runs import TIMINGS, file_runs, parse_seeds, run_many, run_one, scenario_runs
from firmware_sim.sensors.imu_array import make_source
from tests.conftest import walk_path
from tests.e2e.test_wire_golden import WALK_SHA256

RECIPE = "stand:3+walk:3+stand:2"


def test_seeds_are_a_half_open_range_a_number_or_a_list():
    assert parse_seeds("0:4") == [0, 1, 2, 3]
    assert parse_seeds("7") == [7] and parse_seeds("1,5") == [1, 5]
    for bad in ("4:4", "a:b", "1:2:3", ""):
        with pytest.raises(ValueError, match="seeds"):
            parse_seeds(bad)


def test_every_walk_replayed_together_keeps_its_pinned_bytes(walks_dir, tmp_path, capsys):
    walks = ["2", "33", "2"]
    args = ["replay", *(str(walk_path(w)) for w in walks), "--wire-dir", str(tmp_path / "wire"),
            "--table", str(tmp_path / "runs.csv"), "--quiet"]
    assert cli.main(args) == 0
    for name, walk in (("walk_100521_2", "2"), ("walk_100521_33", "33"), ("walk_100521_2-2", "2")):
        data = (tmp_path / "wire" / f"{name}.bin").read_bytes()
        assert hashlib.sha256(data).hexdigest() == WALK_SHA256[walk]
    out = capsys.readouterr().out.splitlines()
    assert out[0].split()[:4] == ["name", "samples", "steps", "distance"]
    assert [line.split()[0] for line in out[1:4]] == ["walk_100521_2", "walk_100521_33", "walk_100521_2-2"]
    assert out[4].startswith("3 runs, ") and "mean closure" in out[4]
    with (tmp_path / "runs.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert [r["wire_sha256"] for r in rows] == [WALK_SHA256[w] for w in walks]
    assert 0 < float(rows[0]["closure_pct"]) < 2 and int(rows[0]["steps"]) > 30


def test_a_scenario_with_many_seeds_writes_what_each_single_replay_writes(tmp_path, capsys):
    args = ["replay", "--scenario", RECIPE, "--rate", "250", "--seeds", "3:5", "--wire-dir", str(tmp_path),
            "--quiet"]
    assert cli.main(args) == 0
    for seed in (3, 4):
        stem = f"stand_3_walk_3_stand_2_seed{seed}"
        expect = run_replay(make_source(RECIPE, seed=seed, rate_hz=250.0), announce=None)
        assert (tmp_path / f"{stem}.bin").read_bytes() == bytes(expect)
        assert (tmp_path / f"{stem}.bin.truth.csv").is_file()
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 5 and lines[1].split()[4] == "–", "an open path has no closure"
    assert lines[-1].endswith(str(tmp_path)) and "runs/s" in lines[-1]


def test_a_run_row_has_identity_metrics_and_timings():
    (spec,) = scenario_runs(["stand:3+rectangle:4:2:0.5+stand:2"], [1], rate_hz=250.0)
    row = run_one(spec)
    assert row["name"] == "stand_3_rectangle_4_2_0.5_stand_2_seed1" and row["seed"] == 1
    assert row["steps"] > 5 and row["distance_m"] > 8
    assert 0 <= row["closure_pct"] < 10 and not math.isnan(row["closure_m"]), "a rectangle is a closed loop"
    assert row["time_s"] >= row["parse_s"] + row["nav_s"]
    assert len(row["wire_sha256"]) == 64


def test_runs_replayed_in_lockstep_give_the_rows_each_gives_alone():
    specs = scenario_runs([RECIPE], [0, 1, 2], rate_hz=250.0)
    untimed = [{k: v for k, v in row.items() if k not in TIMINGS} for row in run_many(specs)]
    assert untimed == [{k: v for k, v in run_one(s).items() if k not in TIMINGS} for s in specs]


def test_file_runs_name_repeated_stems_apart():
    names = [r.name for r in file_runs(["a/w.txt", "b/w.txt", "w.csv", "x.txt"])]
    assert names == ["w", "w-2", "w-3", "x"]


@pytest.mark.parametrize("argv, message", [
    (["a.txt", "b.txt", "--wire", "o.bin"], "use --wire-dir"),
    (["a.txt", "--seeds", "0:2", "--wire-dir", "d"], "--seeds goes with --scenario"),
    (["--scenario", "stand:2", "--seeds", "0:2", "--wire", "o.bin"], "go with --wire-dir"),
    (["--wire-dir", "d"], "give recording FILE(s) or --scenario"),
    (["--scenario", "stand:2", "--seeds", "2:1", "--wire-dir", "d"], "seeds must be"),
])
def test_wrong_combinations_are_refused(argv, message, capsys):
    assert cli.main(["replay", *argv, "--quiet"]) == 2
    assert message in capsys.readouterr().err


def test_a_malformed_file_stops_the_batch_with_its_line(tmp_path, capsys):
    bad = tmp_path / "bad.csv"
    bad.write_text("# rate_hz=100\nt,ax,ay,az,gx,gy,gz\n0.1,0,0,-1,0,0,x\n")
    assert cli.main(["replay", str(bad), "--wire-dir", str(tmp_path / "w"), "--quiet"]) == 2
    assert "bad.csv, line 3" in capsys.readouterr().err


def test_the_summary_counts_the_samples_the_recorders_skipped(tmp_path, capsys):
    from tests.sensors.test_replay import openshoe_row, write_openshoe

    gappy = write_openshoe(tmp_path / "gappy.txt", [openshoe_row(k) for k in (0, 1, 2, 6, 7, 9)])
    whole = write_openshoe(tmp_path / "whole.txt", [openshoe_row(k) for k in range(6)])
    args = ["replay", str(gappy), str(whole), "--wire-dir", str(tmp_path / "wire"),
            "--table", str(tmp_path / "runs.csv"), "--quiet"]
    assert cli.main(args) == 0
    out = capsys.readouterr().out.splitlines()
    assert "; 4 samples the recorders skipped put back (interpolated) in 1 file" in out[3]
    with (tmp_path / "runs.csv").open() as f:
        rows = {r["name"]: r for r in csv.DictReader(f)}
    assert (rows["gappy"]["filled_samples"], rows["gappy"]["samples"]) == ("4", "10")
    assert rows["whole"]["filled_samples"] == "0"
