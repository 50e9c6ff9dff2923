"""The shoe's hard iron from end-of-stance readings: the level circle, and when the ellipsoid is used."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hostlib.aids.compass import StanceReading, compass_heading, wrap_angle
from hostlib.calibration.level_iron import (
    MIN_TILT_SPAN_DEG,
    fit_level_hard_iron,
    iron_calibration,
    tilt_span_deg,
)
from hostlib.track.steps import rotation_z

#: A field of 50 µT dipping 70° (north, east, down) [µT].
FIELD = 50.0 * np.array([math.cos(math.radians(70.0)), 0.0, math.sin(math.radians(70.0))])
HARD_IRON = np.array([-4.0, 2.5, 0.0])  # µT, board frame


def _rotation(yaw: float, pitch: float, roll: float) -> np.ndarray:
    cp, sp, cr, sr = math.cos(pitch), math.sin(pitch), math.cos(roll), math.sin(roll)
    return rotation_z(yaw) @ np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]]) @ np.array(
        [[1, 0, 0], [0, cr, -sr], [0, sr, cr]])


def _readings(tilt_deg: float, n: int = 120, seed: int = 3) -> tuple[list[StanceReading], np.ndarray]:
    """Readings of the field plus the hard iron at headings all round, tilted up to *tilt_deg*."""
    rng = np.random.default_rng(seed)
    yaws = rng.uniform(-math.pi, math.pi, n)
    tilts = np.radians(rng.uniform(-tilt_deg, tilt_deg, (n, 2)))
    out = []
    for yaw, (pitch, roll) in zip(yaws, tilts, strict=True):
        r = _rotation(yaw, pitch, roll)
        out.append(StanceReading(r.T @ FIELD + HARD_IRON + rng.normal(0.0, 0.3, 3), r, 3))
    return out, yaws


def _heading_errors_deg(readings, yaws, calibration=None) -> np.ndarray:
    return np.degrees([wrap_angle(compass_heading(r.field_board if calibration is None else
                                                  calibration.apply(r.field_board), r.rotation) - yaw)
                       for r, yaw in zip(readings, yaws, strict=True)])


def test_level_readings_give_the_horizontal_hard_iron_and_the_compass_its_heading_back():
    readings, yaws = _readings(tilt_deg=3.0)
    cal, horizontal = fit_level_hard_iron(readings)
    assert cal.hard_iron[:2] == pytest.approx(HARD_IRON[:2], abs=0.2)
    assert abs(cal.hard_iron[2]) < 0.2  # the vertical part is not observable: left at 0
    assert np.array_equal(cal.soft_iron, np.eye(3))
    assert horizontal == pytest.approx(math.hypot(FIELD[0], FIELD[1]), abs=0.3)
    assert np.sqrt(np.mean(_heading_errors_deg(readings, yaws) ** 2)) > 10.0
    assert np.sqrt(np.mean(_heading_errors_deg(readings, yaws, cal) ** 2)) < 1.5


def test_level_readings_take_the_circle_and_a_wiggle_the_ellipsoid():
    level, _ = _readings(tilt_deg=3.0)
    fit = iron_calibration(level)
    assert tilt_span_deg(level) < MIN_TILT_SPAN_DEG and fit.model == "level circle"
    assert math.isfinite(fit.horizontal_ut) and fit.ellipsoid  # what the ellipsoid fit said is kept
    wiggle, _ = _readings(tilt_deg=60.0)
    fit = iron_calibration(wiggle)
    assert tilt_span_deg(wiggle) >= MIN_TILT_SPAN_DEG and fit.model == "ellipsoid"
    assert fit.calibration.hard_iron == pytest.approx(HARD_IRON, abs=0.5)
