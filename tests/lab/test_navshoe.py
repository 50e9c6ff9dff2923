"""``python -m lab.accuracy navshoe-outage``: one seed of NavShoe's outage loop through the module and the
receiver's NMEA, tracked by every host; GPS trains the declination, the compass aligns the heading,
and the oracle hosts put the truth into the compass readings."""

from __future__ import annotations

import csv
import io
import math

import numpy as np
import pytest

from lab.accuracy import main, navshoe


def test_one_seed_of_the_outage_loop_is_tracked_by_every_host(tmp_path):
    out = io.StringIO()
    assert main(["navshoe-outage", "--seeds", "3", "--workers", "0", "--out", str(tmp_path)], out) == 0
    text = out.getvalue()
    # the sway's millimetres in each of the ~690 stances add to the path: 631 m (630 m still)
    assert "(631 m walked without GPS)" in text and (tmp_path / "navshoe-outage.csv").is_file()
    with (tmp_path / "navshoe-outage.csv").open() as f:
        rows = {r["host"]: r for r in csv.DictReader(f)}
    assert set(rows) == set(navshoe.HOSTS)
    both = rows["compass+gps"]
    assert both["aligned_by"] == "compass" and rows["gps"]["aligned_by"] == "gps"
    assert int(both["gps_updates"]) > 20 and int(both["compass_updates"]) > 500
    assert float(both["declination_sigma_deg"]) < 5.0  # 15° before: GPS made it observable
    assert rows["plain"]["gps_updates"] == rows["plain"]["compass_updates"] == "0"
    uncalibrated = rows["compass+gps uncalibrated"]
    assert float(both["end_error_pct_without_gps"]) < float(uncalibrated["end_error_pct_without_gps"])
    # where the receiver fell silent: a GPS run's error is the receiver's, a few metres
    assert 0.0 < float(rows["gps"]["last_fix_error_m"]) < 10.0
    assert rows["plain"]["last_fix_error_m"] == "nan"
    assert "error where the receiver fell silent" in text


def test_the_perfect_compass_oracle_reads_the_true_heading_from_magnetic_north():
    from firmware_sim.sensors.imu_array import make_source
    from hostlib.aids.compass import StanceReading, wrap_angle
    from hostlib.fusion.tracker import FusionSettings

    source = make_source("walk", seed=0)
    truth = source.truth
    oracle = navshoe.OracleCompassTracker(FusionSettings(compass=True), source, "all", last_counter=None)
    k = len(truth.t) // 2
    oracle._time = float(truth.t[k])
    r = truth.R[k]
    expected = math.atan2(r[1, 0], r[0, 0]) - math.radians(source.config.mag.declination_deg)
    psi = oracle.compass_heading(StanceReading(np.array([15.0, 5.0, 49.0]), np.eye(3), 3))  # any reading
    assert abs(wrap_angle(psi - expected)) < 1e-9
    assert oracle.compass_heading(None) is None


def test_on_a_swaying_walk_compass_and_gps_teach_the_warmup_the_simulated_dies_hold():
    """With a real foot's stance sway ZARU no longer re-learns the gyros' bias every stride, and the
    dies' warm-up turns the heading: a host holding the warm-up learns the simulated one (its sign
    and its size, within a quarter) from the compass and GPS, and ends the outage nearer than the
    same host without it."""
    rows = {r["host"]: r for r in navshoe.outage_run(1, stance_sway=True)}
    best = rows["compass+gps every error state and warm-up"]
    assert best["stance_sway"] and abs(best["true_warmup_deg_s"]) > 0.01
    assert best["warmup_deg_s"] == pytest.approx(best["true_warmup_deg_s"], rel=0.25)
    assert math.isnan(rows["compass+gps"]["warmup_deg_s"])
    assert best["end_error_m"] < 0.5 * rows["compass+gps every error state"]["end_error_m"]


def test_the_simulated_warmup_is_what_is_left_of_it_at_the_first_step():
    """A module switched on before the run has less of its warm-up still to come: the simulated w
    shrinks by e^(−t/τ) for t on before the run, as the dies' temperature does."""
    from firmware_sim.sensors.config import DEFAULT_CONFIG
    from firmware_sim.sensors.imu_array import make_source

    cold = make_source("stand:2+walk:3+stand:1", seed=4)
    warm = make_source("stand:2+walk:3+stand:1", seed=4, config=DEFAULT_CONFIG.warm())
    tau, on = DEFAULT_CONFIG.temperature.warmup_tau_s, DEFAULT_CONFIG.temperature.settled_s
    w = navshoe.simulated_warmup(cold, 2.0)
    assert abs(w) > 0.0
    assert navshoe.simulated_warmup(warm, 2.0) == pytest.approx(w * math.exp(-on / tau), rel=1e-12)

