"""A simulated wiggle as the magnetometer stream delivers it: each packet's attitude and three
chips' registers (hostlib.calibration.wiggle's readings), with a shoe iron an ellipsoid fit recovers whole, or
one turned by a rotation only the attitude shows."""

from __future__ import annotations

import math

import numpy as np

from firmware_sim.sensors.config import DEFAULT_CONFIG
from firmware_sim.sensors.gait_builder import GaitBuilder
from firmware_sim.sensors.magnetic import earth_field_ned
from firmware_sim.sensors.truth import euler_to_quat
from hostlib.calibration.iron_rotation import rotation_of_vector
from protocol.board import MAG_UT_PER_LSB, mag_to_board_matrix
from protocol.ids import StateId

#: The Earth's field of the emulator's walks (Stockholm), NED [µT].
FIELD = earth_field_ned(DEFAULT_CONFIG)


def packet_states(rotation: np.ndarray, field_board: np.ndarray) -> dict:
    """A stream packet's states: the attitude *rotation*, and three chips' registers of the board
    field *field_board* [µT]."""
    roll = math.atan2(rotation[2, 1], rotation[2, 2])
    pitch = math.asin(-rotation[2, 0])
    yaw = math.atan2(rotation[1, 0], rotation[0, 0])
    w, x, y, z = euler_to_quat(np.array(roll), np.array(pitch), np.array(yaw))
    states = {StateId.QUATERNION: np.array([x, y, z, w])}
    for i in range(3):
        states[0x90 + i] = np.rint(mag_to_board_matrix(i).T @ field_board / MAG_UT_PER_LSB)
    return states


def rotation_deg(vector) -> np.ndarray:
    """The rotation of the rotation vector *vector* [deg] (Rodrigues)."""
    return rotation_of_vector(np.radians(np.asarray(vector, dtype=np.float64)))


#: The stream's packet interval at 1 kHz: every 16th cycle.
_CYCLES_PER_PACKET = 16


def wiggle_packets(tilt_deg: float = 90.0, noise_ut: float = 0.35, seconds: float = 30.0, seed: int = 0,
                   turn_deg=(0.0, 0.0, 0.0), attitude_lag_cycles: int = 0):
    """Stream packets (62.5 Hz) of a simulated wiggle with a shoe iron, and that iron: (states
    list, soft iron, hard iron). The iron is symmetric (which an ellipsoid fit recovers whole) times
    the rotation of *turn_deg* (board frame; what only the attitude shows). Each packet's attitude
    is the one *attitude_lag_cycles* 1 kHz cycles before its magnetometers' (the module's pipeline:
    up to 16)."""
    truth = GaitBuilder().stand(1.0).wiggle(seconds, tilt_deg).stand(1.0).build().sample(1000.0)
    at = np.arange(attitude_lag_cycles, len(truth.R), _CYCLES_PER_PACKET)
    rng = np.random.default_rng(seed)
    soft = np.eye(3) + rng.uniform(-0.05, 0.05, (3, 3))
    soft = 0.5 * (soft + soft.T) @ rotation_deg(turn_deg)
    hard = rng.uniform(-4.0, 4.0, 3)
    noise = rng.normal(size=(len(at), 3)) * noise_ut
    packets = [packet_states(truth.R[k - attitude_lag_cycles], soft @ (truth.R[k].T @ FIELD) + hard + e)
               for k, e in zip(at, noise, strict=True)]
    return packets, soft, hard
