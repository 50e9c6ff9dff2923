"""The levelled field's inclination (dip) as a measurement of a calibrated compass's swing: a level
error fixed in the board's frame turns the dip as the model says, and the dip teaches the swing
where the headings cannot (no GPS: the heading readings alone cannot tell a swing from the heading)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hostlib.aids.compass import StanceReading, compass_heading, wrap_angle
from hostlib.aids.declination import MagneticField
from hostlib.aids.field_check import level_field
from hostlib.fusion.compass_dip import dip_swing_row
from hostlib.fusion.compass_swing import CALIBRATED_SWING, swing_basis
from hostlib.fusion.deviation import OUTDOORS, WHITE_SIGMA_RAD
from hostlib.fusion.tracker import FusionSettings, FusionTracker
from hostlib.track.steps import rotation_z

from .test_compass_swing import CALIBRATION
from .test_hard_iron import DP, FIELD_NED

INCLINATION = math.atan2(FIELD_NED[2], FIELD_NED[0])
WMM = MagneticField(0.0, math.degrees(INCLINATION), 1000.0 * float(np.linalg.norm(FIELD_NED)),
                    1000.0 * float(FIELD_NED[0]))
#: the attitude's level error at the end of the stance, fixed in the board's frame: 0.3° about the
#: board's x axis (roll), −0.4° about its y axis (pitch)
TILT = np.radians([0.3, -0.4])


def _tilted(tilt: np.ndarray) -> np.ndarray:
    """The small rotation of a level error *tilt* [roll, pitch] (rad) in the board's frame."""
    roll, pitch = tilt
    rx = np.array([[1, 0, 0], [0, math.cos(roll), -math.sin(roll)], [0, math.sin(roll), math.cos(roll)]])
    ry = np.array([[math.cos(pitch), 0, math.sin(pitch)], [0, 1, 0], [-math.sin(pitch), 0, math.cos(pitch)]])
    return ry @ rx


def _reading(heading: float, tilt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A level board at magnetic *heading* [rad]: its field, and the attitude the module reports,
    off by *tilt*."""
    truth = rotation_z(heading)
    return truth.T @ FIELD_NED, truth @ _tilted(tilt)


def test_a_level_error_turns_the_dip_by_cot_i_times_the_headings_swing_a_quarter_turn_on():
    headings = np.radians(np.arange(0.0, 360.0, 15.0))
    errors, dips = [], []
    for psi in headings:
        field, rotation = _reading(psi, TILT)
        errors.append(-wrap_angle(compass_heading(field, rotation) - psi))  # ψ_c = ψ − swing
        dips.append(level_field(field, rotation)[1] - INCLINATION)
    swing = np.linalg.lstsq(np.array([swing_basis(p) for p in headings]), errors, rcond=None)[0]
    assert np.degrees(np.abs(swing)).min() > 0.5  # a level error of tenths swings by degrees
    predicted = [float(dip_swing_row(p, INCLINATION) @ swing) for p in headings]
    assert np.degrees(np.abs(dips)).max() > 0.3
    assert np.degrees(np.array(dips) - predicted) == pytest.approx(np.zeros(len(dips)), abs=0.01)


def _settings(**changes) -> FusionSettings:
    return FusionSettings(**{"compass": True, "compass_sigma_rad": WHITE_SIGMA_RAD,
                             "compass_deviation": OUTDOORS, "compass_swing": CALIBRATED_SWING,
                             "mag_calibration": CALIBRATION, "magnetic_field": WMM, **changes})


def _walk_a_square(tracker: FusionTracker, tilt: np.ndarray, laps: int = 6) -> None:
    """Laps of a 14 m square without GPS, the module's steps exact; each reading levelled with an
    attitude off by *tilt*."""
    k, chi = 0, 0.0
    for _ in range(laps * 4):
        for leg_step in range(20):
            turn = math.pi / 2 if leg_step == 0 and k > 0 else 0.0
            chi += turn
            k += 1
            field, rotation = _reading(chi, tilt)
            tracker.add_step([0.7, 0.0, 0.0, turn], DP, k, time_s=float(k),
                             reading=StanceReading(field, rotation, 3))


def test_without_gps_the_dip_teaches_the_swing_a_level_error_makes():
    tracker = FusionTracker(_settings(), last_counter=0)
    _walk_a_square(tracker, TILT)
    headings = np.radians([0.0, 90.0, 180.0, 270.0])
    errors = [-wrap_angle(compass_heading(*_reading(p, TILT)) - p) for p in headings]
    truth = np.linalg.lstsq(np.array([swing_basis(p) for p in headings]), errors, rcond=None)[0]
    assert tracker.fusion.dip_updates > 400 and tracker.fusion.dip_rejected == 0
    assert tracker.compass_swing == pytest.approx(truth, abs=math.radians(0.3))
    assert "dip" in tracker.filter


def test_the_dip_is_not_held_without_a_place_or_a_swing_learned_from_it():
    for changes in ({"magnetic_field": None}, {"compass_swing": None}, {"compass_deviation": None}):
        tracker = FusionTracker(_settings(**changes), last_counter=0)
        assert "dip" not in tracker.filter
