"""`python -m lab.accuracy`: what height compensation and drift correction gain, per walk and on slopes."""

from __future__ import annotations

import io
import math

import pytest

from lab.accuracy import main
from lab.accuracy.slopes import slope_rows, summary_lines
from lab.accuracy.speeds import (
    RATES_HZ,
    SPEEDS_KMH,
    speed_recipe,
    speed_run,
    speed_spec,
    table_row,
    table_runs,
)
from lab.accuracy.walks import VARIANTS, height_lines, table_lines, walk_results
from tests.conftest import WALK_IDS, requires_walks, walk_path


def run(argv: list[str]) -> tuple[int, str]:
    out = io.StringIO()
    return main(argv, out), out.getvalue()


def _error_free_run(speed: float, rate: float):
    """The speed table's run of the error-free module at *speed* [km/h] and *rate* [Hz]."""
    (run,) = [r for r in table_runs(speed_spec([1])) if r.source == speed_recipe(speed)
              and dict(r.settings) == {"scenario.rate_hz": rate, "sensors.model": "ideal",
                                       "scenario.stance_sway": False, "sensors.temperature.powered_s": 600.0}]
    return run


def test_a_short_ramp_is_walked_with_and_without_compensation_and_summarised():
    rows = slope_rows([1], workers=0, scenarios=("stand:3+walk:8:6+stand:2",))
    assert [r["height_compensation"] for r in rows] == [False, True]
    top = rows[0]["true_top_m"]
    assert top == pytest.approx(8 * math.sin(math.radians(6)), rel=1e-6)
    for r in rows:  # the track climbs the ramp to within a few centimetres either way
        assert abs(r["top_error_m"]) < 0.1 and abs(r["end_error_m"]) < 0.1
    lines = summary_lines(rows)
    assert "height error at the top" in lines[0] and "stand:3+walk:8:6+stand:2" in lines[2]


def test_leave_one_out_needs_two_walks():
    with pytest.raises(ValueError, match="at least two"):
        walk_results(["only_one.txt"], workers=0)


def test_an_error_free_module_walks_100_m_at_5_km_h_to_within_a_decimetre():
    """At its own 1 kHz, the length is right to 0.05 % and the height to 0.1 % (the mechanization's
    half-sample skew: docs/accuracy.md)."""
    ideal = _error_free_run(5.0, 1000.0)
    row = table_row(ideal, speed_run(ideal))
    assert row["seed"] == "ideal" and row["steps"] >= 60
    assert abs(row["along"]) < 0.05 and abs(row["across"]) < 0.05 and abs(row["height"]) < 0.1


def test_the_speed_table_has_a_row_per_speed_and_rate(tmp_path):
    code, text = run(["speeds", "--seeds", "1:2", "--workers", "0", "--out", str(tmp_path)])
    assert code == 0
    lines = text.splitlines()
    assert "error-free" in lines[0] and len(lines) == 2 + 2 * len(SPEEDS_KMH)
    assert lines[1].split()[:3] == ["3", "km/h", "1000"] and lines[-2].split()[:2] == ["run", "250"]
    assert (tmp_path / "speeds.csv").is_file()


@pytest.mark.parametrize("argv", [["walks", "no_such_walk.txt", "other.txt"], ["slopes", "--seeds", "5:1"],
                                  ["slopes", "--ramps", "ramp_6,ramp_60"], ["speeds", "--seeds", "x"],
                                  ["slopes", "--workers", "-1"], ["slopes", "--workers", "100000"]])
def test_bad_arguments_exit_2(argv, capsys):
    try:
        code, _ = run(argv)
    except SystemExit as exc:  # argparse's refusal (--workers: 0 to 64 processes)
        code = exc.code
    assert code == 2 and "python -m lab.accuracy" in capsys.readouterr().err


@requires_walks
def test_each_walk_is_corrected_by_the_others_and_never_by_itself(tmp_path):
    paths = [walk_path(w) for w in WALK_IDS[:3]]
    results = walk_results(paths, workers=0)
    assert [r.name for r in results] == [p.stem for p in paths]
    for r in results:
        assert set(r.horizontal_pct) == {v[0] for v in VARIANTS}
        # drift correction moves positions only: the distance walked is the plain track's
        assert r.tracks["drift"].distance == pytest.approx(r.tracks["plain"].distance)
        assert r.horizontal_pct["plain"] != r.horizontal_pct["drift"]
    # with a calibration from itself a loop would close exactly; leave-one-out does not
    assert all(r.closure_3d_pct["drift"] > 0.01 for r in results)
    table = table_lines(results)
    assert table[-2].startswith("mean") and len(table) == len(results) + 3
    # closed loops on level ground: with height compensation the height ends nearer 0 and stays nearer
    heights = height_lines(results)
    assert heights[-1].startswith("mean") and len(heights) == len(results) + 2
    for r in results:
        assert abs(r.end_height_m["height"]) < abs(r.end_height_m["plain"])
        assert r.rms_height_m["height"] < r.rms_height_m["plain"]


@requires_walks
def test_the_walks_table_and_picture_are_written(tmp_path):
    code, text = run(["walks", *map(str, (walk_path(w) for w in WALK_IDS[:2])), "--workers", "0",
                      "--out", str(tmp_path)])
    assert code == 0 and "mean" in text
    assert (tmp_path / "walks.csv").read_text().count("\n") == 3
    assert (tmp_path / "height-walk.png").stat().st_size > 10_000


def test_the_speed_table_is_its_sweep_spec_and_reads_the_runs_it_needs():
    """``python -m lab.accuracy speeds`` runs the runs of ``lab/accuracy/speeds.toml`` (the spec
    ``openshoe-emu sweep --spec`` runs whole) that its table reads: the error-free module on still
    stances, once, and every seed's module with errors on the simulation's own (swaying) stances."""
    spec = speed_spec([1, 2, 3])
    assert spec.scenarios == tuple(speed_recipe(v) for v in SPEEDS_KMH) and spec.seeds == (1, 2, 3)
    settings = dict(spec.settings)
    assert settings["scenario.rate_hz"] == RATES_HZ and set(settings["sensors.model"]) == {"ideal", "default"}
    assert settings["scenario.stance_sway"] == (False, True)
    assert settings["sensors.temperature.powered_s"] == (600.0,)  # warm, as the spread's modules
    assert spec.group_by == ("source", "scenario.rate_hz", "sensors.model", "scenario.stance_sway")
    read = table_runs(spec)
    assert len(read) == len(SPEEDS_KMH) * len(RATES_HZ) * (1 + 3) and set(read) <= set(spec.runs())
    for run in read:
        s = dict(run.settings)
        assert (s["sensors.model"], s["scenario.stance_sway"]) in (("ideal", False), ("default", True))
        assert s["sensors.model"] == "default" or run.seed == 1


def test_on_still_stances_the_error_free_module_walks_the_same_whatever_the_seed():
    """Why the table's error-free module walks the first seed only."""
    from dataclasses import replace

    from firmware_sim.app import runs

    ideal = _error_free_run(8.0, 250.0)
    assert runs.run_one(ideal)["wire_sha256"] == runs.run_one(replace(ideal, seed=4))["wire_sha256"]


def test_every_experiment_explains_itself(capsys):
    """`python -m lab.accuracy --help` and each experiment's --help print (argparse formats help with %,
    so a stray percent sign would crash it)."""
    from lab.accuracy.cli import build_parser

    parser = build_parser()
    parser.format_help()
    commands = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction").choices
    assert {"error-free", "consistency", "navshoe-house", "walks-compass", "magcal"} <= set(commands)
    for name, sub in commands.items():
        assert name.split("-")[0] in sub.format_help()
