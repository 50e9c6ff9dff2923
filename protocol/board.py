"""What the MIMU22BT's per-IMU states mean physically: chip axes and magnetometer scale.

The states 0x40+i (raw inertial) and 0x90+i (magnetometer) are chip *i*'s registers
as read, in that chip's own axes (protocol.md §4). A host that turns them into
board-frame quantities — the per-step compass of the host-side aids does, from the
magnetometer states a step packet carries — needs how each chip sits on the board;
the emulator's sensor model needs the same to produce the registers. It is declared
here, once, for both.

Board frame: x forward, y right, z down. Chips 0 and 1 are on the top side, 2 and 3 on
the bottom side, mounted upside down (a 180° rotation about the board's x axis;
sensors.md). Inside each MPU9150 the AK8975 die is turned: x_mag = y_acc,
y_mag = x_acc, z_mag = −z_acc (datasheet). One magnetometer LSB is 0.3 µT.

A walker may wear a module on each foot: :data:`FOOT_SIDES` names the feet for the
emulator and the host alike.
"""

from __future__ import annotations

import numpy as np

from .ids import NR_IMUS

__all__ = ["AK8975_AXES", "CHIP_MOUNTING", "FOOT_SIDES", "MAG_UT_PER_LSB", "mag_to_board",
           "mag_to_board_matrix"]

_UPRIGHT = ((1, 0, 0), (0, 1, 0), (0, 0, 1))
_UPSIDE_DOWN = ((1, 0, 0), (0, -1, 0), (0, 0, -1))  # 180° about x

#: ``CHIP_MOUNTING[i]`` maps board-frame vectors to chip *i*'s accelerometer/gyro axes:
#: ``v_chip = CHIP_MOUNTING[i] @ v_board`` (±1 rotation matrices).
CHIP_MOUNTING: tuple[tuple[tuple[int, int, int], ...], ...] = (_UPRIGHT, _UPRIGHT, _UPSIDE_DOWN, _UPSIDE_DOWN)

#: The AK8975's axes from its MPU9150's accelerometer/gyro axes: ``v_mag = AK8975_AXES @ v_acc``.
AK8975_AXES: tuple[tuple[int, int, int], ...] = ((0, 1, 0), (1, 0, 0), (0, 0, -1))

#: Magnetometer scale [µT per LSB] (AK8975 datasheet).
MAG_UT_PER_LSB = 0.3

#: The feet a walker wears a module on, in the order two-foot devices, files and results list them
#: (the emulator's ``serve --feet 2`` names its ports ``<path>-left`` and ``<path>-right``).
FOOT_SIDES: tuple[str, str] = ("left", "right")

assert len(CHIP_MOUNTING) == NR_IMUS


def mag_to_board_matrix(imu: int) -> np.ndarray:
    """The 3×3 matrix taking IMU *imu*'s magnetometer axes to the board frame (the inverse,
    i.e. transpose, of ``AK8975_AXES @ CHIP_MOUNTING[imu]``)."""
    if not 0 <= imu < NR_IMUS:
        raise ValueError(f"IMU index {imu} out of range 0..{NR_IMUS - 1}")
    forward = np.asarray(AK8975_AXES, dtype=np.float64) @ np.asarray(CHIP_MOUNTING[imu], dtype=np.float64)
    return forward.T


def mag_to_board(imu: int, registers) -> np.ndarray:
    """IMU *imu*'s magnetometer registers (3 × int16, state 0x90+imu) as a board-frame field [µT]."""
    raw = np.asarray(registers, dtype=np.float64).reshape(3)
    return mag_to_board_matrix(imu) @ (raw * MAG_UT_PER_LSB)
