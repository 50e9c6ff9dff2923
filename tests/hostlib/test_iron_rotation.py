"""The iron's rotation of the field from the attitude (hostlib.calibration.iron_rotation): recovered from the
field's constant inclination whatever the quaternion's yaw does at the resets, from the readings
held still only; refused, saying why, when the shoe was never tilted, never held still, or when
the attitude does not go with the field."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hostlib.aids.compass import StanceReading, compass_heading
from hostlib.calibration.iron_rotation import (
    MAX_INCLINATION_SCATTER_DEG,
    STILL_TILT_DEG,
    IronRotation,
    fit_iron_rotation,
    still_readings,
)
from hostlib.calibration.magcal import MagCalibration, MagCalibrationError
from hostlib.track.steps import rotation_z

from .wiggles import FIELD, rotation_deg

SETTINGS = settings(derandomize=True, deadline=None, max_examples=40)
#: The ellipsoid fit's calibration of the synthetic readings: they carry no hard or soft iron but
#: the rotation, which no ellipsoid fit sees.
ELLIPSOID = MagCalibration(np.zeros(3), np.eye(3))
SIGMA_DEG = 3.3


def _attitude(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Board → navigation, Z-Y-X Euler angles [rad]."""
    cr, sr, cp, sp = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch)
    return rotation_z(yaw) @ np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]]) @ \
        np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])


def _held_readings(seed: int, turn_deg, *, tilt_deg: float = 90.0, holds: int = 40, hold: int = 12,
                   noise_ut: float = 0.35, yaw_resets: bool = True) -> list[StanceReading]:
    """Readings of the field turned by the iron's *turn_deg*, the shoe held still in *holds*
    orientations (heading all round, tilted up to *tilt_deg*) for *hold* readings each. With
    *yaw_resets* each hold's attitude has its own yaw offset, as the module's quaternion after a
    reset of its INS: its heading is not the true one."""
    rng = np.random.default_rng(seed)
    turn = rotation_deg(turn_deg)
    readings = []
    for _ in range(holds):
        tilt = math.radians(tilt_deg) * rng.uniform(0.0, 1.0)
        towards = rng.uniform(0.0, 2 * math.pi)
        truth = _attitude(tilt * math.sin(towards), tilt * math.cos(towards), rng.uniform(-math.pi, math.pi))
        reported = rotation_z(rng.uniform(-math.pi, math.pi)) @ truth if yaw_resets else truth
        for _ in range(hold):
            field = turn @ (truth.T @ FIELD) + rng.normal(size=3) * noise_ut
            readings.append(StanceReading(field, reported, 3))
    return readings


def _angle_deg(r: np.ndarray) -> float:
    return math.degrees(math.acos(float(np.clip((np.trace(r) - 1.0) / 2.0, -1.0, 1.0))))


@SETTINGS
@given(turn=st.lists(st.floats(-5.0, 5.0), min_size=3, max_size=3), seed=st.integers(0, 2**16))
def test_the_rotation_is_recovered_from_the_attitude_whatever_the_quaternions_yaw(turn, seed):
    readings = _held_readings(seed, turn)
    fit = fit_iron_rotation(ELLIPSOID, readings, SIGMA_DEG)
    # the field as the iron turned it, turned back: R_m is the iron rotation's inverse, to within
    # the noise, as the fit's own covariance says
    error = _angle_deg(fit.rotation @ rotation_deg(turn))
    assert error < 0.15 and error < 4.0 * math.degrees(math.sqrt(np.trace(fit.covariance)))
    assert fit.inclination_deg == pytest.approx(72.5, abs=0.1)
    assert fit.readings == len(readings) - 2 * 40 + 2, "all but each hold's first and last"
    assert fit.scatter_deg < 0.6 and fit.heading_sigma_deg() < 0.3


def test_a_level_compass_is_right_once_the_calibration_is_turned():
    turn = (1.0, -1.5, 2.0)
    fit = fit_iron_rotation(ELLIPSOID, _held_readings(0, turn), SIGMA_DEG)
    turned = ELLIPSOID.turned(fit.rotation)
    assert turned.rotation_deg == pytest.approx(_angle_deg(rotation_deg(turn)), abs=0.05)
    declination = math.atan2(FIELD[1], FIELD[0])

    def worst_error_deg(calibration: MagCalibration) -> float:
        worst = 0.0
        for psi in np.radians(np.arange(0.0, 360.0, 30.0)):
            level = rotation_z(float(psi))
            field = rotation_deg(turn) @ (level.T @ FIELD)
            error = compass_heading(calibration.apply(field), level) - (psi - declination)
            worst = max(worst, abs(math.degrees(math.remainder(error, 2 * math.pi))))
        return worst

    # the iron's 2.7° cost the ellipsoid's level compass several degrees; turned, a tenth of one
    assert worst_error_deg(ELLIPSOID) > 5.0
    assert worst_error_deg(turned) < 0.15


def test_readings_taken_while_the_shoe_tilts_are_left_out_turning_about_the_vertical_is_not():
    before = _attitude(0.3, -0.2, 1.0)
    after = _attitude(0.3 + math.radians(15.0), -0.2, 1.0)

    def reading(attitude):
        return StanceReading(attitude.T @ FIELD, attitude, 3)

    tilting = [reading(_attitude(0.3 + math.radians(3.0 * k), -0.2, 1.0)) for k in range(1, 5)]
    turning = [reading(rotation_z(math.radians(20.0 * k)) @ after) for k in range(1, 5)]
    readings = [reading(before)] * 10 + tilting + [reading(after)] * 10 + turning
    kept = still_readings(readings)
    # the first hold but its last reading, which the tilt follows; the second but its first; and
    # the turn about the vertical, which keeps the field's angle with it
    assert kept == readings[:9] + readings[15:]
    assert STILL_TILT_DEG < 3.0


@pytest.mark.parametrize(("readings", "why"), [
    # a level shoe only turned round: the vertical never leaves the board's z axis
    (_held_readings(2, (1.0, 1.0, 1.0), tilt_deg=0.0), "rotation about the board's z axis undetermined"),
    # every reading in another attitude: none held still
    ([StanceReading(r.field_board, r.rotation, 3) for r in _held_readings(3, (0, 0, 0), holds=300, hold=1)],
     r"0 readings with the shoe held still \(at least 30\)"),
    # an attitude that does not go with the field: the level board's, however the shoe turned
    ([StanceReading(r.field_board, np.eye(3), 3) for r in _held_readings(4, (0, 0, 0))],
     "the attitude does not go with the magnetometers"),
])
def test_attitudes_that_do_not_determine_the_rotation_are_refused_saying_why(readings, why):
    with pytest.raises(MagCalibrationError, match=why):
        fit_iron_rotation(ELLIPSOID, readings, SIGMA_DEG)


def test_a_field_scattering_about_its_inclination_is_refused():
    noisy = _held_readings(5, (0.0, 0.0, 0.0), noise_ut=5.0)
    with pytest.raises(MagCalibrationError, match=r"inclination scatters [\d.]+° RMS"):
        fit_iron_rotation(ELLIPSOID, noisy, SIGMA_DEG)
    assert MAX_INCLINATION_SCATTER_DEG < 5.0 / 51.5 * 180 / math.pi


def test_the_heading_sigma_counts_a_tilt_about_the_field_tan_i_times():
    one_deg = math.radians(1.0) ** 2
    about_x = IronRotation(np.eye(3), 72.5, np.diag([one_deg, 0.0, 0.0]), 0.4, 100)
    about_z = IronRotation(np.eye(3), 72.5, np.diag([0.0, 0.0, one_deg]), 0.4, 100)
    assert about_x.heading_sigma_deg() == pytest.approx(math.tan(math.radians(72.5)), rel=1e-6)
    assert about_z.heading_sigma_deg() == pytest.approx(1.0, rel=1e-6)
    assert IronRotation(np.eye(3), 72.5, np.full((3, 3), math.inf), 0.4, 100).heading_sigma_deg() == math.inf
