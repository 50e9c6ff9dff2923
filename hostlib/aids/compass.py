"""The per-step compass: a heading from the magnetometers and attitude at the end of a stance.

NavShoe (Foxlin 2005; shared/spec/aids.md §1) takes exactly one compass reading per step, at the
end of the stance, where roll and pitch are at their best after a run of ZUPTs and successive
readings lie a step apart, so that their deviations are nearly uncorrelated. The module resets
its INS at the end of the stance, and with the fusion set-up
(:data:`protocol.extensions.FUSION_SETUP`) the step packet carries, from that very cycle, the
attitude quaternion (state 0x22) and three IMUs' magnetometer registers (0x90+i).

:func:`stance_reading` turns a step packet's states into a :class:`StanceReading`: the board-frame
field [µT] (the chips' registers turned into board axes with :mod:`protocol.board` and averaged)
and the board-to-navigation rotation. :func:`compass_heading` levels the field with the attitude
and takes the heading of the board's x axis from magnetic north, east positive::

    n = R(q) m_b,   ψ_compass = ψ(q) − atan2(n_y, n_x)

which does not depend on the field's inclination or magnitude, and not on the quaternion's yaw
(the module zeroes it at each reset). A :class:`hostlib.calibration.magcal.MagCalibration` first removes the
shoe's hard and soft iron from the field. The result measures the true heading minus the
declination (plus the local deviation): that is how :mod:`hostlib.fusion.tracker` uses it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from protocol.board import mag_to_board
from protocol.ids import NR_IMUS, StateId, imu_mag_id

__all__ = ["StanceReading", "compass_heading", "quaternion_rotation", "stance_reading"]


def quaternion_rotation(q) -> np.ndarray:
    """R(q), board → navigation frame, of the QUATERNION state (scalar last, ``[x, y, z, w]``),
    in float64; the quaternion is normalised first."""
    x, y, z, w = (float(v) for v in np.asarray(q, dtype=np.float64).reshape(4))
    norm = math.sqrt(x * x + y * y + z * z + w * w)
    if not norm > 0.0 or not math.isfinite(norm):
        raise ValueError(f"not an attitude quaternion: {[x, y, z, w]}")
    x, y, z, w = x / norm, y / norm, z / norm, w / norm
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


@dataclass(frozen=True)
class StanceReading:
    """The magnetometers and the attitude at one step's end of stance."""

    field_board: np.ndarray  #: (3,) µT, board frame (x forward, y right, z down), uncalibrated
    rotation: np.ndarray  #: (3, 3) board → navigation frame, from the QUATERNION state
    chips: int  #: how many magnetometers were averaged

    @property
    def roll_pitch(self) -> tuple[float, float]:
        """Roll and pitch [rad] of the board (Z-Y-X Euler angles)."""
        r = self.rotation
        return math.atan2(r[2, 1], r[2, 2]), math.asin(max(-1.0, min(1.0, -r[2, 0])))


def stance_reading(states: Mapping[int, np.ndarray]) -> StanceReading | None:
    """The reading in a step packet's decoded *states*, or None when it lacks the attitude or
    every magnetometer (a plain 0x34 step packet), or carries an all-zero quaternion."""
    quaternion = states.get(StateId.QUATERNION)
    fields = [mag_to_board(i, states[imu_mag_id(i)]) for i in range(NR_IMUS) if imu_mag_id(i) in states]
    if quaternion is None or not fields:
        return None
    try:
        rotation = quaternion_rotation(quaternion)
    except ValueError:
        return None
    return StanceReading(np.mean(fields, axis=0), rotation, len(fields))


def compass_heading(field_board: np.ndarray, rotation: np.ndarray) -> float:
    """The board's heading [rad] from magnetic north (east positive, in −π..π) given the
    calibrated board-frame field and the board → navigation rotation (module docstring)."""
    n = np.asarray(rotation, dtype=np.float64) @ np.asarray(field_board, dtype=np.float64).reshape(3)
    yaw = math.atan2(rotation[1][0], rotation[0][0])
    return wrap_angle(yaw - math.atan2(n[1], n[0]))


def wrap_angle(a: float) -> float:
    """*a* [rad] wrapped into −π..π."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi
