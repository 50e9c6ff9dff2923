"""The per-step compass: a step packet's magnetometers and attitude give the board's heading from
magnetic north, whatever the tilt, the field's inclination or the quaternion's (reset) yaw."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from firmware_sim.sensors.truth import euler_to_matrix, euler_to_quat
from hostlib.aids.compass import compass_heading, quaternion_rotation, stance_reading, wrap_angle
from protocol.board import AK8975_AXES, CHIP_MOUNTING, MAG_UT_PER_LSB, mag_to_board
from protocol.ids import StateId


def _field_ned(intensity=51.5, inclination_deg=72.5, declination_deg=0.0) -> np.ndarray:
    inc, dec = math.radians(inclination_deg), math.radians(declination_deg)
    return intensity * np.array([math.cos(inc) * math.cos(dec), math.cos(inc) * math.sin(dec), math.sin(inc)])


def _module_quaternion(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """The QUATERNION state (scalar last) of an attitude."""
    w, x, y, z = euler_to_quat(np.array(roll), np.array(pitch), np.array(yaw))
    return np.array([x, y, z, w])


def test_the_chip_magnetometer_axes_turn_back_into_the_board_frame():
    board = np.array([12.0, -3.0, 45.0])
    for imu, mounting in enumerate(CHIP_MOUNTING):
        registers = np.asarray(AK8975_AXES) @ np.asarray(mounting) @ board / MAG_UT_PER_LSB
        np.testing.assert_allclose(mag_to_board(imu, registers), board, atol=1e-12)


def test_a_level_board_facing_east_reads_ninety_degrees():
    r = euler_to_matrix(np.array(0.0), np.array(0.0), np.array(math.pi / 2))
    m_b = r.T @ _field_ned()
    assert compass_heading(m_b, r) == pytest.approx(math.pi / 2, abs=1e-12)


angles = st.floats(-math.pi, math.pi)
tilts = st.floats(-1.2, 1.2)


@settings(max_examples=300, deadline=None)
@given(roll=tilts, pitch=tilts, yaw=angles, reset_yaw=angles, inclination=st.floats(-80, 80),
       declination=st.floats(-30, 30))
def test_the_heading_is_the_yaw_from_magnetic_north_whatever_the_tilt(roll, pitch, yaw, reset_yaw,
                                                                       inclination, declination):
    """The module zeroes the quaternion's yaw at each reset: the heading must not depend on it."""
    true = euler_to_matrix(np.array(roll), np.array(pitch), np.array(yaw))
    m_b = true.T @ _field_ned(inclination_deg=inclination, declination_deg=declination)
    heading = compass_heading(m_b, quaternion_rotation(_module_quaternion(roll, pitch, reset_yaw)))
    assert abs(wrap_angle(heading - (yaw - math.radians(declination)))) < 1e-9


def test_a_step_packet_gives_its_reading_and_a_plain_one_none():
    r = euler_to_matrix(np.array(0.1), np.array(-0.2), np.array(0.0))
    m_b = r.T @ _field_ned()
    regs = {imu_id: np.rint(np.asarray(AK8975_AXES) @ np.asarray(CHIP_MOUNTING[i]) @ m_b / MAG_UT_PER_LSB)
            for i, imu_id in enumerate((0x90, 0x91, 0x92))}
    reading = stance_reading({StateId.QUATERNION: _module_quaternion(0.1, -0.2, 0.0), **regs})
    assert reading is not None and reading.chips == 3
    np.testing.assert_allclose(reading.field_board, m_b, atol=0.3)
    assert reading.roll_pitch == pytest.approx((0.1, -0.2), abs=1e-9)
    assert stance_reading({StateId.DX: np.zeros(4)}) is None
    assert stance_reading({StateId.QUATERNION: np.zeros(4), 0x90: [1, 2, 3]}) is None
