"""A simulated wiggle as the magnetometer stream delivers it: each packet's attitude and three
chips' registers (hostlib.wiggle's readings), with a shoe iron an ellipsoid fit recovers whole."""

from __future__ import annotations

import math

import numpy as np

from firmware_sim.sensors.config import DEFAULT_CONFIG
from firmware_sim.sensors.gait import GaitBuilder
from firmware_sim.sensors.magnetic import earth_field_ned
from firmware_sim.sensors.truth import euler_to_quat
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


def wiggle_packets(tilt_deg: float = 90.0, noise_ut: float = 0.35, seconds: float = 30.0, seed: int = 0):
    """Stream packets (62.5 Hz) of a simulated wiggle with a symmetric shoe iron (which an ellipsoid
    fit recovers whole), and that iron: (states list, soft iron, hard iron)."""
    truth = GaitBuilder().stand(1.0).wiggle(seconds, tilt_deg).stand(1.0).build().sample(62.5)
    rng = np.random.default_rng(seed)
    soft = np.eye(3) + rng.uniform(-0.05, 0.05, (3, 3))
    soft = 0.5 * (soft + soft.T)
    hard = rng.uniform(-4.0, 4.0, 3)
    noise = rng.normal(size=(len(truth.R), 3)) * noise_ut
    packets = [packet_states(r, soft @ (r.T @ FIELD) + hard + e)
               for r, e in zip(truth.R, noise, strict=True)]
    return packets, soft, hard
