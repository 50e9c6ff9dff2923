"""The MIMU22BT board: where its four MPU9150s sit and how they are turned.

One place for the geometry that both the sensor model (which must produce each
chip's raw axes) and the firmware's default calibration (which must rotate them
back into the board frame) rely on. Board frame: x forward, y right, z down
(the navigation convention of firmware.md §4: at rest and level the
accelerometer reads f = (0, 0, −g)).

Chips 0 and 1 are on the top side, 2 and 3 on the bottom side; the bottom pair
is mounted upside down, a 180° rotation about the board's x axis (sensors.md).
The turns are declared in :mod:`protocol.board` (a host needs them to read the
magnetometer states); the positions are our documented choice (the board is 22.5 × 20 mm); both are
configurable through :class:`BoardGeometry`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from protocol.board import CHIP_MOUNTING
from protocol.ids import NR_IMUS

#: Q14 fixed point: 16384 = 1.0 (calibration matrices of firmware.md §3).
Q14_ONE = 1 << 14


def _default_mounting() -> np.ndarray:
    return np.array(CHIP_MOUNTING, dtype=np.int64)  # declared once, for the host too


def _default_lever_arms() -> np.ndarray:
    # metres, board frame; top side is −z (z points down)
    return np.array(
        [
            [+0.0060, -0.0050, -0.0008],
            [-0.0060, +0.0050, -0.0008],
            [+0.0060, +0.0050, +0.0008],
            [-0.0060, -0.0050, +0.0008],
        ]
    )


@dataclass(frozen=True)
class BoardGeometry:
    """Chip placement on the board.

    ``mounting[i]`` maps board-frame vectors to chip *i*'s raw axes:
    ``v_chip = mounting[i] @ v_board`` (an integer ±1 rotation matrix).
    ``lever_arms[i]`` is chip *i*'s position relative to the board centre [m].
    """

    mounting: np.ndarray = field(default_factory=_default_mounting)
    lever_arms: np.ndarray = field(default_factory=_default_lever_arms)

    def __post_init__(self) -> None:
        if self.mounting.shape != (NR_IMUS, 3, 3) or self.lever_arms.shape != (NR_IMUS, 3):
            raise ValueError("board geometry needs one 3×3 mounting and one lever arm per IMU")

    def default_calibration_q14(self) -> np.ndarray:
        """Ideal Q14 calibration matrices (NR_IMUS, 3, 3), int32: chip axes → board axes."""
        return (np.transpose(self.mounting, (0, 2, 1)) * Q14_ONE).astype(np.int32)


MIMU22BT = BoardGeometry()
