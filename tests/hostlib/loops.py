"""Closed loops walked by hand: steps with swing times whose positions drift at a constant velocity.

The true path is a rectangle (back at its start); each step's measured position is off by
``v_err · (time spent swinging so far)``, the error a drift calibration recovers
(shared/spec/aids.md §4). :func:`fusion_capture` turns the steps into the module's bytes
with the fusion set-up, as ``openshoe-host log --raw`` would have captured them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hostlib.track.steps import StepTracker, Track, rotation_z
from protocol.codec import STEP_IDS, encode_states
from protocol.extensions import FUSION_SETUP, fusion_step_ids
from protocol.frames import build_command, build_command_ack, build_state_packet
from protocol.ids import Command, StateId

#: Side lengths [m] of the rectangle and the step length along it.
SIDES = (6.0, 3.0, 6.0, 3.0)
STEP_M = 0.75
DP = np.diag([1e-4, 1e-4, 1e-4, 1e-5])


@dataclass
class Loop:
    dx: np.ndarray  #: (n, 4) steps as the module reports them
    swing: np.ndarray  #: (n,) swing times [s]

    def track(self, heading0: float = 0.0, with_swing: bool = True) -> Track:
        tracker = StepTracker(heading=heading0)
        for k, (dx, t) in enumerate(zip(self.dx, self.swing, strict=True)):
            tracker.add_step(dx, DP, k + 1, t if with_swing else math.nan)
        return tracker.track


def rectangle(v_err: tuple[float, float, float], seed: int = 0, heading0: float = 0.0) -> Loop:
    """A rectangle walked from heading *heading0* whose positions drift by *v_err* [m/s] (in the
    walk's start frame) per second of swing; swing times 0.3–0.6 s drawn with *seed*."""
    rng = np.random.default_rng(seed)
    true, chi = [np.zeros(3)], [0.0]
    for side in SIDES:
        n = int(round(side / STEP_M))
        for i in range(n):
            turn = math.pi / 2 if i == 0 and len(true) > 1 else 0.0
            chi.append(chi[-1] + turn)
            true.append(true[-1] + rotation_z(chi[-1]) @ np.array([side / n, 0.0, 0.0]))
    true_p, chis = np.array(true), np.array(chi)
    swing = rng.uniform(0.3, 0.6, len(true_p) - 1)
    elapsed = np.concatenate(([0.0], np.cumsum(swing)))
    rot0 = rotation_z(heading0)
    measured = (rot0 @ (true_p + elapsed[:, None] * np.asarray(v_err)[None, :]).T).T
    heads = chis + heading0
    dx = np.empty((len(swing), 4))
    for k in range(len(swing)):
        dx[k, :3] = rotation_z(heads[k]).T @ (measured[k + 1] - measured[k])
        dx[k, 3] = heads[k + 1] - heads[k]
    return Loop(dx.astype(np.float32).astype(np.float64), swing.astype(np.float32).astype(np.float64))


#: The fusion step packet's other states at a level foot facing magnetic north: the loop time, the
#: attitude and three magnetometers (chips 0 and 1 upright, chip 2 upside down; AK8975 axes).
STANCE_STATES = {StateId.GP_DT: 5000, StateId.T_INT_K: 0, StateId.QUATERNION: np.array([0.0, 0.0, 0.0, 1.0]),
                 0x90: [0, 50, -160], 0x91: [0, 50, -160], 0x92: [0, 50, 160]}


def fusion_capture(loop: Loop, serial: bytes | None, with_setup: bool = True) -> bytes:
    """The module → host bytes of *loop* walked with the fusion set-up: the acks of 0x34,
    STATE_IF_SETUP and MCU_ID, the serial number packet, then one step packet per step carrying
    :func:`~protocol.extensions.fusion_step_ids`. *with_setup* False: plain 0x34 step packets."""
    out = bytearray(build_command_ack(Command.STEPWISE_DEAD_RECKONING))
    number = 0
    ids: tuple[int, ...] = STEP_IDS
    if with_setup:
        for meaning, fields in FUSION_SETUP:
            out += build_command_ack(build_command(meaning, **fields)[0])
        if serial is not None:
            number += 1
            out += build_state_packet(number, encode_states([StateId.MCU_ID], {StateId.MCU_ID: serial}))
        ids = fusion_step_ids()
    for k, (dx, t) in enumerate(zip(loop.dx, loop.swing, strict=True)):
        number += 1
        values = {**STANCE_STATES, StateId.T_INT_K: 64000 * number, StateId.DX: dx,
                  StateId.DP: DP[np.triu_indices(4)], StateId.STEP_COUNTER: k + 1, StateId.SWING_TIME: t}
        out += build_state_packet(number, encode_states(ids, values))
    return bytes(out)
