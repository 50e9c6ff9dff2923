"""``python -m lab.accuracy navshoe-house``: NavShoe's house walk — a closed loop of about 120 m over two
storeys, indoors in a building's deviation — tracked with the compass per step, at every reset,
continuously, and without it."""

from __future__ import annotations

import csv
import io
import math

import numpy as np
import pytest

from firmware_sim.sensors.gps import GpsErrors, scenario_errors
from firmware_sim.sensors.imu_array import make_source
from firmware_sim.sensors.scenarios import SCENARIOS, environment, trajectory
from firmware_sim.sensors.truth import walked_distance
from hostlib.files.replay import replay_session
from hostlib.fusion.tracker import FusionSettings
from lab.accuracy import house, main
from lab.accuracy.runs import fusion_capture

STOREY_M = 16 * 0.17  # the flight: 16 stairs of 0.17 m


def test_the_house_walk_is_a_closed_loop_of_about_120_m_over_two_storeys_indoors():
    assert house.SCENARIO in SCENARIOS
    g = trajectory(house.SCENARIO).sample(100.0)
    assert 110.0 < walked_distance(g.pos)[-1] < 130.0
    rests = g.stance_positions
    assert np.abs(rests[-1] - rests[0]).max() < 0.01  # back at the front door, on the ground floor
    assert -rests[:, 2].min() == pytest.approx(STOREY_M, abs=1e-6)
    upstairs = np.flatnonzero(np.isclose(rests[:, 2], -STOREY_M))
    steps = np.diff(rests[upstairs, :2], axis=0)
    assert np.sum(np.hypot(*steps.T)) > 25.0  # a loop of the upper floor, not a landing
    # indoors: the building's deviation, and not one GPS fix
    env = environment(house.SCENARIO)
    assert not env.outdoors
    assert scenario_errors(GpsErrors(), house.SCENARIO, g.t, g.pos).outages[-1] == (0.0, math.inf)


def test_the_house_deviation_is_tens_of_degrees_changing_within_a_metre_and_between_floors():
    rng = np.random.default_rng(0)
    at_rests, pairs = [], {"0.25 m": [], "a stride": [], "a storey up": []}
    for seed in (1, 2, 3):
        source = make_source(house.SCENARIO, seed=seed)  # the world the tool's walks meet
        world = source.magnetic
        at_rests.append(world.heading_deviation(source.truth.stance_positions))
        p = np.c_[rng.uniform(-3, 14, 2000), rng.uniform(-1, 12, 2000), np.zeros(2000)]
        way = rng.uniform(0, 2 * np.pi, 2000)
        here = world.heading_deviation(p)
        for name, shift in (("0.25 m", 0.25), ("a stride", 1.5)):
            there = p + np.c_[shift * np.cos(way), shift * np.sin(way), np.zeros(2000)]
            pairs[name].append((here, world.heading_deviation(there)))
        pairs["a storey up"].append((here, world.heading_deviation(p + [0.0, 0.0, -STOREY_M])))
    rms = math.degrees(float(np.sqrt(np.mean(np.concatenate(at_rests) ** 2))))
    # the compass σ the tool trusts is this deviation's RMS
    assert rms == pytest.approx(house.INDOOR_COMPASS_SIGMA_DEG, rel=0.3)
    corr = {name: np.corrcoef(np.concatenate([a for a, _ in v]), np.concatenate([b for _, b in v]))[0, 1]
            for name, v in pairs.items()}
    assert corr["0.25 m"] > 0.8
    assert abs(corr["a stride"]) < 0.3
    assert corr["a storey up"] < 0.6


def test_a_continuous_compass_counts_each_stance_as_its_magnetometer_samples():
    source = make_source("stand:4+walk:6+stand:2", seed=1)
    settings = FusionSettings(compass=True, compass_mode="every-reset")
    tracker = house.ContinuousCompassTracker(settings, 100.0, last_counter=None)
    replay_session(fusion_capture(source), tracker=tracker)
    walking = [n for n, moved in zip(tracker.stance_samples, tracker.track.swing_times > 0, strict=True)
               if moved]
    standing = [n for n, moved in zip(tracker.stance_samples, tracker.track.swing_times > 0, strict=True)
                if not moved]
    assert len(walking) >= 4 and all(40 <= n <= 80 for n in walking)  # 0.55 s stances at 100 Hz
    assert standing and max(standing) >= 90  # a reset while standing comes about once a second
    # every reset but the aligning one is used, or rejected by the innovation gate
    assert tracker.fusion.compass_updates + tracker.fusion.compass_rejected == len(tracker) - 1


def test_one_house_walk_is_tracked_five_ways(tmp_path):
    out = io.StringIO()
    assert main(["navshoe-house", "--seeds", "2", "--workers", "0", "--out", str(tmp_path)], out) == 0
    text = out.getvalue()
    assert "navshoe-house, 1 seeds" in text and "per step (" in text and "wins over" in text
    with (tmp_path / "navshoe-house.csv").open() as f:
        rows = {r["run"]: r for r in csv.DictReader(f)}
    assert set(rows) == set(house.RUNS)
    step, every, continuous, plain = (rows[r] for r in house.RUNS[:4])
    wmm = rows["per step, WMM declination"]
    # per step: a reading per step that moved the foot; the resets while standing carry none
    assert int(step["compass_skipped"]) > 0 and int(every["compass_skipped"]) == 0
    def readings(row):  # used, or rejected by the innovation gate
        return int(row["compass_updates"]) + int(row["compass_rejected"])

    assert readings(step) + int(step["compass_skipped"]) == readings(every)
    assert readings(continuous) == readings(every)
    assert plain["compass_updates"] == "0" and plain["aligned_by"] == "truth"
    assert {rows[r]["aligned_by"] for r in house.RUNS if r != "plain"} == {"compass"}
    # the declination enters the heading one for one; the compass leaves the height alone
    shift = float(wmm["wmm_declination_deg"]) - float(wmm["true_declination_deg"])
    turned = float(wmm["heading_error_deg"]) - float(step["heading_error_deg"])
    assert turned == pytest.approx(shift, abs=1e-6)
    heights = [float(r["height_error_m"]) for r in rows.values()]
    assert max(heights) - min(heights) < 1e-3
    for r in rows.values():
        assert 110.0 < float(r["without_gps_m"]) < 130.0
        assert float(r["end_error_pct_without_gps"]) < 3.0
