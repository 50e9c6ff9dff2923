"""The two-feet experiments of ``python -m lab.accuracy``: a walker's two modules through the
emulated module and the host's two-foot fusion; a lost link on one foot is reported and the fused
track goes on; the heading aids on both feet (NavShoe's outage loop) and each module's drift
correction (leave-one-out over one walker's loops)."""

from __future__ import annotations

import csv
import io

import numpy as np
import pytest

from lab.accuracy import main, two_feet

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


@pytest.fixture(scope="module")
def aided_rows(tmp_path_factory):
    """Walker 1's walk of NavShoe's outage loop through ``python -m lab.accuracy two-feet-aids``, on
    still stances: there the gyros' bias is re-learnt every stride and no host need hold the
    modules' warm-up (the swaying walk's test below holds it)."""
    path = tmp_path_factory.mktemp("two-feet-aids")
    out = io.StringIO()
    assert main(["two-feet-aids", "--seeds", "1", "--no-stance-sway", "--workers", "0", "--out", str(path)],
                out) == 0
    assert "630 m walked without GPS" in out.getvalue()
    with (path / "two-feet-aids.csv").open() as f:
        return {r["estimate"]: r for r in csv.DictReader(f)}


def test_the_outage_loop_with_two_feet_reports_every_estimate_and_the_declinations(aided_rows):
    assert set(aided_rows) == set(two_feet.AIDED_ESTIMATES)
    for row in aided_rows.values():
        assert float(row["without_gps_m"]) == pytest.approx(630.4)
        assert float(row["end_error_pct_without_gps"]) == pytest.approx(  # the distance is rounded
            100.0 * float(row["end_error_m"]) / float(row["without_gps_m"]), rel=1e-3)
    assert float(aided_rows["fused plain"]["declination_deg"]) == 0.0  # no aids: D stays at its prior
    # GPS taught the joint filter's declination: nearer the simulated 6° than the WMM's 7.70°
    free = aided_rows["unconstrained compass+gps"]
    truth, prior = float(free["true_declination_deg"]), float(free["wmm_declination_deg"])
    assert abs(float(free["declination_deg"]) - truth) < abs(prior - truth)


def test_compass_and_gps_on_both_feet_with_still_stances_keep_the_outage_under_one_percent(aided_rows):
    # NavShoe's figure: with the compass, the end error ≤ 1 % of the distance walked without GPS
    for name in ("fused compass+gps", "average compass+gps", "unconstrained compass+gps"):
        assert float(aided_rows[name]["end_error_pct_without_gps"]) < 1.0


def test_on_swaying_feet_each_modules_warmup_held_keeps_the_fused_outage_under_one_percent(tmp_path):
    """With a real foot's stance sway the dies' warm-up turns each module's heading, which a
    filter that does not hold it takes for truth; holding each foot's module's errors and
    warm-up (EMULATED_MODULE_SWAYING) ends walker 1's outage within 1 % and nearer than the fused
    compass and GPS without them."""
    out = io.StringIO()
    assert main(["two-feet-aids", "--seeds", "1", "--workers", "0", "--out", str(tmp_path)], out) == 0
    assert "walkers, stance sway:" in out.getvalue()
    with (tmp_path / "two-feet-aids.csv").open() as f:
        rows = {r["estimate"]: r for r in csv.DictReader(f)}
    held = float(rows["fused compass+gps module errors and warm-up"]["end_error_pct_without_gps"])
    assert held < 1.0
    assert held < 0.5 * float(rows["fused compass+gps"]["end_error_pct_without_gps"])


def test_with_still_stances_the_constraint_does_not_turn_the_aided_feet_away(aided_rows):
    # the projection moves the estimate only: it never turns both headings and D for centimetres
    fused, free = (float(aided_rows[name]["end_error_m"]) for name in ("fused compass+gps",
                                                                       "unconstrained compass+gps"))
    assert fused <= 1.1 * free
    truth = float(aided_rows["fused compass+gps"]["true_declination_deg"])
    assert abs(float(aided_rows["fused compass+gps"]["declination_deg"]) - truth) < 1.5


def test_drift_correction_from_the_other_loop_closes_each_foot_and_the_body(tmp_path):
    out = io.StringIO()
    assert main(["two-feet-drift", "--seeds", "1:3", "--workers", "0", "--out", str(tmp_path)], out) == 0
    assert "round a 400 m loop 2 times" in out.getvalue()
    with (tmp_path / "two-feet-drift.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 2 * 2 * len(two_feet.ESTIMATES)
    closure = {(int(r["seed"]), r["estimate"], r["drift_correction"] == "True"): float(r["closure_pct"])
               for r in rows}
    for seed in (1, 2):
        for name in two_feet.ESTIMATES:
            assert closure[(seed, name, True)] < closure[(seed, name, False)]


def test_drift_correction_needs_another_loop_to_calibrate_on(tmp_path, capsys):
    assert main(["two-feet-drift", "--seeds", "1", "--workers", "0", "--out", str(tmp_path)]) == 2
    assert "at least two seeds" in capsys.readouterr().err
    with pytest.raises(ValueError, match="at least two loops"):
        two_feet.drift_rows([1], workers=0)
