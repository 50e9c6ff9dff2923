"""openshoe-accuracy's two-feet experiments: a walker's two modules through the emulated module and
the host's two-foot fusion; a lost link on one foot is reported and the fused track goes on."""

from __future__ import annotations

import csv
import io

import numpy as np
import pytest

from tools.accuracy import main, two_feet

SHORT = "stand:3+walk:30+stand:3"


def test_one_straight_walk_gives_each_foot_the_average_and_the_fusion(tmp_path):
    out = io.StringIO()
    assert main(["two-feet-straight", "--seeds", "2", "--workers", "0", "--out", str(tmp_path)], out) == 0
    assert "1 straight 100 m walks" in out.getvalue()
    assert (tmp_path / "two-feet-straight.png").stat().st_size > 0
    with (tmp_path / "two-feet-straight.csv").open() as f:
        rows = {r["estimate"]: r for r in csv.DictReader(f)}
    assert set(rows) == set(two_feet.ESTIMATES)
    for name in two_feet.ESTIMATES:
        assert abs(float(rows[name]["length_error_m"])) < 1.0  # 1 % of 100 m
    mean = np.mean([float(rows[s]["across_error_m"]) for s in ("left", "right")])
    assert float(rows["average"]["across_error_m"]) == pytest.approx(mean, abs=1e-9)
    assert float(rows["average"]["sigma_across_m"]) < float(rows["left"]["sigma_across_m"])


def test_a_link_down_on_one_foot_is_a_gap_and_the_fusion_goes_on():
    walk = two_feet.feet_walk(SHORT, seed=1, drop_s=(10.0, 18.0))
    assert walk.dropped >= 7
    right, left = walk.tracker.right, walk.tracker.left
    assert len(right.gaps) == 1 and right.gaps[0].missing == walk.dropped
    assert left.gaps == []
    assert [side for side, _ in walk.tracker.restarts] == ["right"]
    body_true = 0.5 * (walk.truth["left"].stance_positions[-1] + walk.truth["right"].stance_positions[-1])
    fused_end = walk.tracker.body.final_pose[:2]
    assert np.hypot(*(fused_end - body_true[:2])) < 1.0  # the body's track went on to the end
    average_end = walk.tracker.average.final_pose[:2]
    assert np.hypot(*(average_end - body_true[:2])) > 3.0  # the right foot's own track lost ~8 m


def test_heading_run_reports_both_trackers_and_the_gap(monkeypatch):
    monkeypatch.setattr(two_feet, "HEADING_SCENARIO", SHORT)
    result = two_feet.heading_run(seed=1, drop_s=(10.0, 18.0))
    assert len(result["time_s"]) == len(result["fused"]["separation_m"])
    assert np.all(np.diff(result["time_s"]) >= 0)
    lines = two_feet.heading_summary(result)
    assert any("right foot's link down 10–18 s" in line for line in lines)
    assert result["gaps"]["right"] and not result["gaps"]["left"]
