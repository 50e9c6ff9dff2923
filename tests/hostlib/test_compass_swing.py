"""A calibrated compass's swing B sin ψ + C cos ψ held as two states: learned from GPS and the walk's
turns, so that what a calibration leaves does not pass for the declination; unused without a
calibration."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hostlib.aids.compass import compass_heading, wrap_angle
from hostlib.calibration.magcal import MagCalibration
from hostlib.fusion.compass_swing import CALIBRATED_SWING, WARMING_SWING, swing_basis
from hostlib.fusion.deviation import OUTDOORS, WHITE_SIGMA_RAD
from hostlib.fusion.tracker import FusionSettings, FusionTracker
from hostlib.track.steps import rotation_z

from .test_hard_iron import FIELD_NED, _walk_a_square

CALIBRATION = MagCalibration(np.zeros(3), np.eye(3), field_ut=51.4, rms_residual_ut=0.3)
#: what the calibration left in the board's frame: 0.6 µT along the foot, −0.4 µT across (≈ 2.2°, −1.5°)
LEFT_UT = np.array([0.6, -0.4, 0.0])


def _settings(**changes) -> FusionSettings:
    return FusionSettings(**{"compass": True, "gps": True, "compass_sigma_rad": WHITE_SIGMA_RAD,
                             "compass_deviation": OUTDOORS, "compass_swing": CALIBRATED_SWING,
                             "mag_calibration": CALIBRATION, **changes})


def _true_swing() -> np.ndarray:
    """[B, C] of the readings' error at the four headings the square walks (a reading is the true
    heading less B sin ψ + C cos ψ)."""
    headings = np.radians([0.0, 90.0, 180.0, 270.0])
    errors = [-wrap_angle(compass_heading(rotation_z(psi).T @ FIELD_NED + LEFT_UT, np.eye(3)) - psi)
              for psi in headings]
    return np.linalg.lstsq(np.array([swing_basis(psi) for psi in headings]), errors, rcond=None)[0]


def test_turns_and_gps_teach_the_swing_and_the_declination_stays_where_a_clean_compass_puts_it():
    held = FusionTracker(_settings(), last_counter=0)
    _walk_a_square(held, LEFT_UT)
    truth = _true_swing()
    assert np.degrees(np.abs(truth)).min() > 1.0  # a swing of degrees, not a rounding
    assert held.compass_swing == pytest.approx(truth, abs=math.radians(0.3))
    assert np.all(held.compass_swing_sigma < math.radians(0.5))
    clean = FusionTracker(_settings(), last_counter=0)  # nothing left by the calibration
    _walk_a_square(clean, np.zeros(3))
    assert abs(math.degrees(held.declination - clean.declination)) < 0.2
    assert held.fusion.compass_rejected == 0


def test_without_the_swing_held_the_filter_is_the_one_before():
    plain = FusionTracker(_settings(compass_swing=None), last_counter=0)
    _walk_a_square(plain, LEFT_UT, laps=1)
    assert plain.compass_swing is None and "swing" not in plain.filter
    assert plain.compass_swing_sigma is None


def test_an_uncalibrated_compass_leaves_the_swing_at_its_prior():
    tracker = FusionTracker(_settings(mag_calibration=None), last_counter=0)
    _walk_a_square(tracker, LEFT_UT, laps=1)
    assert np.all(tracker.compass_swing == 0.0)
    assert tracker.compass_swing_sigma == pytest.approx([CALIBRATED_SWING.sigma_rad] * 2)


def test_the_swing_is_not_held_with_the_hard_iron_learned():
    from hostlib.fusion.hard_iron import CALIBRATED

    tracker = FusionTracker(_settings(hard_iron=CALIBRATED), last_counter=0)
    assert "swing" not in tracker.filter and "hard_iron" in tracker.filter


def test_the_warming_swing_is_weighed_and_not_learned_and_grows_from_the_first_calibrated_reading():
    """The default's swing (the level the module's warming moves after its calibration): GPS and
    the turns do not move its estimate, but its variance weighs the readings, from nothing at the
    first calibrated reading to its σ as the module warms."""
    swing = WARMING_SWING
    assert not swing.learned and swing.warming(0.0) == 0.0
    assert swing.warming(swing.warmup_tau_s) == pytest.approx(1.0 - math.exp(-1.0))
    assert CALIBRATED_SWING.warming(0.0) == 1.0  # the learned swing is whole from the start
    tracker = FusionTracker(_settings(compass_swing=swing), last_counter=0)
    _walk_a_square(tracker, LEFT_UT, laps=2)
    assert np.all(tracker.compass_swing == 0.0)
    assert tracker.compass_swing_sigma == pytest.approx([swing.sigma_rad] * 2)
    plain = FusionTracker(_settings(compass_swing=None), last_counter=0)
    _walk_a_square(plain, LEFT_UT, laps=2)
    assert not np.allclose(tracker.track.final_pose, plain.track.final_pose, rtol=0.0, atol=1e-9)


def test_a_consider_block_keeps_its_estimate_through_updates_and_its_variance_stays():
    from hostlib.fusion.core import StateFilter

    f = StateFilter()
    f.add_block("a", [0.0], np.array([[4.0]]))
    f.add_block("b", [0.0], np.array([[1.0]]), consider=True)
    f.update(np.array([1.0, 1.0]), 2.0, 1.0)  # measures a + b
    assert f.mean("b")[0] == 0.0 and f.covariance("b")[0, 0] == pytest.approx(1.0)
    assert f.mean("a")[0] == pytest.approx(2.0 * 4.0 / 6.0)  # the gain a gets with b's variance in S
    assert f.covariance("a")[0, 0] < 4.0 and f.P[0, 1] != 0.0  # a learned, and now correlated with b
