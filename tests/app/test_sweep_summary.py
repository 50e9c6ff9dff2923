"""A sweep's readings: settings chosen leave-one-out, and means per group of runs."""

from __future__ import annotations

import csv
import math

import pytest

from firmware_sim.app import cli, settings
from firmware_sim.app.sweep_summary import group_table, leave_one_out, leave_one_out_lines
from firmware_sim.sensors.config import IDEAL_CONFIG

RECIPES = ("stand:3+walk:3+stand:2", "stand:3+walk:2+stand:2")


def _row(source, th, closure, seed=0):
    return {"source": source, "seed": seed, "frontend.zupt_threshold": th, "closure_pct": closure}


def test_each_source_is_scored_at_the_setting_chosen_on_the_others():
    # a: far better at 1; b and c: a little better at 2 → leaving a out chooses 2, leaving b or c out 1
    rows = [_row("a", 1, 0.1), _row("a", 2, 0.9), _row("b", 1, 0.5), _row("b", 2, 0.2),
            _row("c", 1, 0.5), _row("c", 2, 0.3)]
    folds = leave_one_out(rows, ["frontend.zupt_threshold"], "closure_pct")
    assert [(f.held_out, f.chosen, f.score) for f in folds] == [("a", (2,), 0.9), ("b", (1,), 0.5),
                                                                ("c", (1,), 0.5)]
    assert folds[0].others == pytest.approx(0.25)  # b and c at 2
    assert "the same choice in 2 of 3 folds" in leave_one_out_lines(folds, ["frontend.zupt_threshold"],
                                                                     "closure_pct")[-1]


def test_a_source_is_scored_over_its_seeds_by_magnitude_and_nan_runs_are_left_out():
    rows = [_row("a", 1, -0.2, 0), _row("a", 1, 0.4, 1), _row("b", 1, math.nan), _row("b", 1, 0.1, 1)]
    folds = leave_one_out(rows, ["frontend.zupt_threshold"], "closure_pct")
    assert folds[0].score == pytest.approx(0.3) and folds[1].score == pytest.approx(0.1)


def test_a_leave_one_out_needs_two_sources_and_a_setting():
    with pytest.raises(ValueError, match="two recordings"):
        leave_one_out([_row("a", 1, 0.1), _row("a", 2, 0.2)], ["frontend.zupt_threshold"], "closure_pct")
    with pytest.raises(ValueError, match="at least one setting"):
        leave_one_out([_row("a", 1, 0.1)], [], "closure_pct")


def test_groups_keep_their_first_order_and_give_mean_and_population_sd():
    rows = [_row("b", 1, 0.1), _row("a", 1, 0.3), _row("b", 1, 0.3, 1), _row("b", 1, math.nan, 2)]
    table = group_table(rows, ["source"], ["closure_pct"])
    assert [(g["source"], g["runs"]) for g in table] == [("b", 3), ("a", 1)]
    assert table[0]["closure_pct_mean"] == pytest.approx(0.2)
    assert table[0]["closure_pct_sd"] == pytest.approx(0.1)
    with pytest.raises(ValueError, match="no column 'speed'"):
        group_table(rows, ["speed"], ["closure_pct"])


def test_an_ideal_sensor_model_is_the_base_of_the_other_sensor_settings_and_a_rate_reaches_the_run():
    applied = settings.apply((("sensors.noise", True), ("sensors.model", "ideal"),
                              ("scenario.rate_hz", 250.0)))
    assert applied.sensors.noise is True and applied.sensors.drift == IDEAL_CONFIG.drift is False
    assert applied.rate_hz == 250.0 and settings.apply(()).rate_hz is None


def test_one_sweep_command_gives_the_grouped_table_and_the_leave_one_out(tmp_path, capsys):
    argv = ["sweep", "--scenario", RECIPES[0], "--scenario", RECIPES[1],
            "--set", "sensors.model=ideal,default", "--set", "scenario.rate_hz=250,500",
            "--group-by", "source,scenario.rate_hz,sensors.model",
            "--leave-one-out", "end_along_m", "--out", str(tmp_path), "--workers", "0", "--no-plot"]
    assert cli.main(argv) == 0
    out = capsys.readouterr().out
    assert "leave-one-out over 2 sources" in out
    groups = list(csv.DictReader((tmp_path / "groups.csv").open()))
    assert len(groups) == 2 * 2 * 2 and {g["runs"] for g in groups} == {"1"}
    assert {float(g["scenario.rate_hz"]) for g in groups} == {250.0, 500.0}
    runs = list(csv.DictReader((tmp_path / "runs.csv").open()))
    samples = {(r["scenario.rate_hz"], r["source"]): int(r["samples"]) for r in runs}
    assert samples[("500.0", RECIPES[0])] == pytest.approx(2 * samples[("250.0", RECIPES[0])], rel=0.01)
    folds = list(csv.DictReader((tmp_path / "leave_one_out.csv").open()))
    assert sorted(f["held_out"] for f in folds) == sorted(RECIPES)
    assert set(folds[0]) == {"held_out", "sensors.model", "scenario.rate_hz", "end_along_m_held_out",
                             "end_along_m_others"}
