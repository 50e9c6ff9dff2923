"""Where a scenario is walked: NavShoe's outage loop is outdoors, starts facing north-east, closes,
and its receiver loses the sky after 400 m; a recipe can set the walker's first heading."""

from __future__ import annotations

import math

import numpy as np
import pytest

from firmware_sim.sensors.config import MagConfig
from firmware_sim.sensors.gps import GpsErrors, outage_after_distance, scenario_errors
from firmware_sim.sensors.scenarios import environment, trajectory


def test_the_outage_loop_is_a_closed_kilometre_outdoors_started_facing_north_east():
    g = trajectory("navshoe-outage").sample(10.0)
    walked = np.sum(np.hypot(*np.diff(g.pos[:, :2], axis=0).T))
    assert 1000.0 < walked < 1060.0
    assert np.hypot(*g.pos[-1, :2]) < 0.01 and abs(g.pos[-1, 2]) < 0.01
    assert math.degrees(g.euler[0, 2]) == pytest.approx(50.0)
    assert -g.pos[:, 2].min() > 7.0  # the 3° hill
    env = environment("navshoe-outage")
    assert env.outdoors and env.gps_outage_after_m == 400.0
    assert environment("default") == environment("walk:10")  # indoors, GPS throughout


def test_face_sets_the_start_and_only_the_start():
    g = trajectory("face:-90+walk:5").sample(10.0)
    assert g.pos[-1, 1] == pytest.approx(-5.0, abs=0.01) and abs(g.pos[-1, 0]) < 0.01
    with pytest.raises(ValueError, match="first piece"):
        trajectory("walk:5+face:90")


def test_outdoors_the_deviation_is_a_few_degrees_over_tens_of_metres():
    indoor, outdoor = MagConfig(), MagConfig().outdoors()
    horizontal = indoor.intensity_ut * math.cos(math.radians(indoor.inclination_deg))
    degrees = [math.degrees(c.indoor_rms_ut / horizontal) for c in (outdoor, indoor)]
    assert degrees[0] < 5.0 < degrees[1]
    assert outdoor.indoor_length_m >= 10 * indoor.indoor_length_m


def test_the_scripted_outage_starts_where_the_walker_has_gone_400_m():
    t = np.arange(0.0, 1000.0)
    pos = np.column_stack([t * 1.5, np.zeros_like(t), np.zeros_like(t)])
    assert outage_after_distance(t, pos, 400.0)[0] == pytest.approx(400.0 / 1.5, abs=1.0)
    errors = scenario_errors(GpsErrors(), "navshoe-outage", t, pos)
    assert errors.in_outage(300.0) and not errors.in_outage(200.0)
    assert scenario_errors(GpsErrors(), "walk", t, pos) == GpsErrors()


def test_the_wiggle_then_the_outage_loop_is_the_loop_after_a_calibration_in_one_place():
    """One capture calibrates the magnetometers in situ and walks NavShoe's loop: the wiggle moves
    the shoe by centimetres where the loop starts, then the loop is walked as without it."""
    loop = trajectory("navshoe-outage").sample(10.0)
    wiggled = trajectory("navshoe-wiggle-outage").sample(10.0)
    assert wiggled.t[-1] == pytest.approx(loop.t[-1] + 33.0, abs=0.5)  # the 30 s wiggle and 3 s stand
    assert np.hypot(*wiggled.pos[-1, :2]) < 0.01
    early = wiggled.t < 38.0  # the stand and the wiggle before the first stride
    assert np.hypot(*wiggled.pos[early, :2].T).max() < 0.3
    assert environment("navshoe-wiggle-outage") == environment("navshoe-outage")
