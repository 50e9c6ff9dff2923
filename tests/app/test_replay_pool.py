"""`openshoe-emu replay FILE... --wire-dir DIR --jobs N`: the runs in N worker processes give the
files, the table and the lines that one process gives, in the same order; a recording that cannot
be read is still refused with its line."""

from __future__ import annotations

import csv
import os

import pytest

from firmware_sim.app import cli, replay_pool
from firmware_sim.app.replay_pool import deal, default_jobs, usable_cpus
from firmware_sim.app.runs import TIMINGS, file_runs
from tests.conftest import walk_path

RECIPE = "stand:3+walk:3+stand:2"


def _replay(argv: list[str], out, jobs: str, capsys) -> tuple[dict[str, bytes], list[dict], list[str]]:
    """The wire files, the table's rows without their timings, and the printed lines without the
    times, of ``replay ARGV --wire-dir OUT/wire --table OUT/runs.csv --jobs JOBS``."""
    args = ["replay", *argv, "--wire-dir", str(out / "wire"), "--table", str(out / "runs.csv"), "--quiet",
            "--jobs", jobs]
    out.mkdir()
    assert cli.main(args) == 0
    lines = capsys.readouterr().out.splitlines()
    files = {p.name: p.read_bytes() for p in sorted((out / "wire").iterdir())}
    with (out / "runs.csv").open() as f:
        rows = [{k: v for k, v in r.items() if k not in TIMINGS} for r in csv.DictReader(f)]
    untimed = [line.rsplit(None, 1)[0] for line in lines[:-2]]  # each run's line but its time
    return files, rows, [*untimed, lines[-2].split(",")[0]]


def test_worker_processes_write_the_files_rows_and_lines_of_one_process(walks_dir, tmp_path, capsys):
    walks = [str(walk_path(w)) for w in ("2", "33", "3", "2", "30")]
    one = _replay(walks, tmp_path / "one", "1", capsys)
    two = _replay(walks, tmp_path / "two", "2", capsys)
    assert one == two
    assert [r["name"] for r in two[1]] == ["walk_100521_2", "walk_100521_33", "walk_100521_3",
                                           "walk_100521_2-2", "walk_100521_30"]
    assert len(two[0]) == 5 and two[2][-1] == "5 runs"


def test_worker_processes_write_a_scenarios_seeds_and_truth_as_one_process(tmp_path, capsys):
    argv = ["--scenario", RECIPE, "--rate", "250", "--seeds", "0:3"]
    one = _replay(argv, tmp_path / "one", "1", capsys)
    three = _replay(argv, tmp_path / "three", "3", capsys)
    assert one == three
    assert sorted(three[0]) == sorted(f"stand_3_walk_3_stand_2_seed{s}.bin{end}" for s in range(3)
                                      for end in ("", ".iron.json", ".truth.csv"))


def test_a_malformed_file_among_many_is_refused_with_its_line_by_the_workers(walks_dir, tmp_path, capsys):
    bad = tmp_path / "bad.csv"
    bad.write_text("# rate_hz=100\nt,ax,ay,az,gx,gy,gz\n0.1,0,0,-1,0,0,x\n")
    args = ["replay", str(walk_path("2")), str(bad), str(walk_path("3")), "--wire-dir", str(tmp_path / "w"),
            "--table", str(tmp_path / "runs.csv"), "--quiet", "--jobs", "2"]
    assert cli.main(args) == 2
    captured = capsys.readouterr()
    (line,) = captured.err.strip().splitlines()
    assert line.startswith(f"openshoe-emu replay: {bad}, line 3: ")
    assert captured.out == "" and not (tmp_path / "runs.csv").exists()


def test_runs_are_dealt_in_order_in_groups_that_shrink_towards_the_end():
    runs = file_runs([f"w{i}.txt" for i in range(100)])
    groups = deal(runs, 2, 16)
    assert [spec for group in groups for spec in group] == runs
    sizes = [len(g) for g in groups]
    assert max(sizes) == 16 and sizes == sorted(sizes, reverse=True) and sizes[-1] == 1
    assert deal(runs[:1], 2, 16) == [runs[:1]]


def test_one_run_stays_in_this_process_and_many_use_every_usable_cpu():
    assert default_jobs(None, 1) == 1
    assert default_jobs(None, 100) == usable_cpus()
    assert default_jobs(8, 3) == 3 and default_jobs(1, 100) == 1


@pytest.mark.parametrize("argv, message", [
    (["a.txt", "--wire", "o.bin", "--jobs", "2"], "--jobs goes with --wire-dir"),
    (["a.txt", "--wire-dir", "d", "--jobs", "0"], "argument --jobs: a whole number of processes from 1"),
    (["a.txt", "--wire-dir", "d", "--jobs", "many"], "argument --jobs: a whole number of processes from 1"),
])
def test_jobs_out_of_place_or_range_are_refused(argv, message, capsys):
    try:
        code = cli.main(["replay", *argv, "--quiet"])
    except SystemExit as exc:  # argparse's refusal of an option's value
        code = exc.code
    assert code == 2 and message in capsys.readouterr().err


def _die(*_args):
    os._exit(3)


def test_a_worker_process_that_dies_is_said_in_one_line(walks_dir, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(replay_pool, "_replay_group", _die)  # the workers fork with it
    args = ["replay", str(walk_path("2")), str(walk_path("3")), "--wire-dir", str(tmp_path / "w"),
            "--table", str(tmp_path / "runs.csv"), "--quiet", "--jobs", "2"]
    assert cli.main(args) == 1
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith("openshoe-emu replay: a worker process ended abruptly")
    assert not (tmp_path / "runs.csv").exists()
