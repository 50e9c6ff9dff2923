"""How real feet rotate in the swing: the shared walks' figures the stair gait is built on.

The swings are the reference detector's (:mod:`.reference_ins`, the oracle's stance flags): the
gaps of at least 0.2 s between two stances, as :mod:`.threshold` takes them. Per swing:

* the smallest |ω| in its middle 80 % (the edges are lift-off and landing, where a foot is
  nearly still by definition) — how close a real foot comes to not rotating while it moves;
* its attitude in the foot's own frame (x forward, y right, z down), integrated from the stance
  before it: the walk's pitch axis is the principal axis of the swings' rates (the foot pitches
  far more than it rolls or turns), down is the first stance's gravity. The pitch's extremes are
  the toe-off and heel-strike; on the *straight* swings (heading changed by less than 5°), the
  largest roll away from the stance's (the sole turned) and the largest yaw away from it (the toe
  turned) are what the foot does besides pitching.

``python -m tests.oracle.swing_rotation`` prints the figures (docs/accuracy.md; the stair gait of
``firmware_sim.sensors.gait`` takes its roll and yaw from them).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .reference_ins import reference_of_recording, stance_phases

__all__ = ["MIN_SWING_S", "STRAIGHT_DEG", "SwingRotation", "foot_frame", "swing_rotations", "summary"]

#: Shortest gap between two oracle stances counted as a swing [s] (as :mod:`.threshold`).
MIN_SWING_S = 0.2
#: A swing whose heading changes by less than this [deg] is straight.
STRAIGHT_DEG = 5.0


@dataclass(frozen=True)
class SwingRotation:
    """One real swing."""

    min_rate_dps: float  #: smallest |ω| in the middle 80 % [°/s]
    median_rate_dps: float  #: median |ω| there [°/s]
    toe_off_deg: float  #: lowest pitch, from the stance's (toe down < 0)
    heel_strike_deg: float  #: highest pitch, from the stance's (toe up > 0)
    roll_deg: float  #: largest |roll| away from the stance's
    yaw_deg: float  #: largest |yaw| away from the stance's
    turn_deg: float  #: heading change over the swing


def _rotation(v: np.ndarray) -> np.ndarray:
    """The rotation matrix of the rotation vector *v* (Rodrigues)."""
    angle = float(np.linalg.norm(v))
    if angle == 0.0:
        return np.eye(3)
    k = v / angle
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + math.sin(angle) * kx + (1.0 - math.cos(angle)) * kx @ kx


def _euler(r: np.ndarray) -> tuple[float, float, float]:
    """ZYX Euler angles (roll, pitch, yaw) [rad] of a body → navigation matrix."""
    pitch = math.asin(-max(-1.0, min(1.0, r[2, 0])))
    return math.atan2(r[2, 1], r[2, 2]), pitch, math.atan2(r[1, 0], r[0, 0])


def _swing_pairs(phases: list[tuple[int, int]], rate: float) -> list[tuple[tuple[int, int], tuple[int, int]]]:
    """The (stance before, stance after) of every swing: the gaps of at least MIN_SWING_S."""
    return [(a, b) for a, b in zip(phases[:-1], phases[1:], strict=True)
            if b[0] - a[1] - 1 >= MIN_SWING_S * rate]


def foot_frame(acc: np.ndarray, gyro: np.ndarray, phases: list[tuple[int, int]], rate: float) -> np.ndarray:
    """The rotation (3, 3) from a recording's board frame to the foot's (x forward, y right, z down):
    its pitch axis is the swings' principal rate axis, down the first stance's gravity, and toe-off
    pitches the toe down first (a negative pitch rate); *phases* the stances (:func:`stance_phases`)
    of the recording at *rate* [Hz]."""
    pairs = _swing_pairs(phases, rate)
    swinging = np.concatenate([gyro[a[1] + 1:b[0]] for a, b in pairs])
    axis = np.linalg.eigh(swinging.T @ swinging)[1][:, -1]
    down = -acc[phases[0][0]:phases[0][1] + 1].mean(axis=0)
    down /= np.linalg.norm(down)
    right = axis - (axis @ down) * down
    right /= np.linalg.norm(right)
    if np.median([gyro[a[1] + 1:a[1] + 20] @ right for a, _ in pairs]) > 0:
        right = -right  # toe-off pitches the toe down first: a negative pitch rate
    return np.array([np.cross(right, down), right, down])


def swing_rotations(path: str | Path) -> list[SwingRotation]:
    """Every swing of the recording *path* (module docstring)."""
    from firmware_sim.sensors.replay import load_recording

    rec = load_recording(path)
    acc, gyro, rate = rec.board_acc_g(), rec.board_gyro(), rec.rate_hz
    phases = stance_phases(reference_of_recording(path).stance[:len(gyro)])
    pairs = _swing_pairs(phases, rate)
    to_foot = foot_frame(acc, gyro, phases, rate)
    gyro, acc = gyro @ to_foot.T, acc @ to_foot.T
    out = []
    for (s0, e0), (s1, _) in pairs:
        gap = s1 - e0 - 1
        rate_dps = np.degrees(np.linalg.norm(gyro[e0 + 1 + gap // 10:s1 - gap // 10], axis=1))
        f = acc[s0:e0 + 1].mean(axis=0)
        roll0, pitch0 = math.atan2(-f[1], -f[2]), math.atan2(f[0], math.hypot(f[1], f[2]))
        cr, sr, cp, sp = math.cos(roll0), math.sin(roll0), math.cos(pitch0), math.sin(pitch0)
        r = np.array([[cp, sp * sr, sp * cr], [0.0, cr, -sr], [-sp, cp * sr, cp * cr]])
        angles = []
        for k in range(e0, s1 + 1):
            r = r @ _rotation(gyro[k] / rate)
            angles.append(_euler(r))
        roll, pitch, yaw = np.degrees(np.array(angles)).T
        yaw = np.degrees(np.unwrap(np.radians(yaw)))
        out.append(SwingRotation(float(rate_dps.min()), float(np.median(rate_dps)),
                                 float(pitch.min() - math.degrees(pitch0)),
                                 float(pitch.max() - math.degrees(pitch0)),
                                 float(np.abs(roll - roll[0]).max()), float(np.abs(yaw - yaw[0]).max()),
                                 float(yaw[-1] - yaw[0])))
    return out


def summary(swings: list[SwingRotation]) -> dict[str, float]:
    """The figures over *swings*: the smallest mid-swing |ω| (its minimum, 5th percentile and
    median over the swings), and the straight swings' median roll and yaw away from the stance."""
    rates = np.array([s.min_rate_dps for s in swings])
    straight = [s for s in swings if abs(s.turn_deg) < STRAIGHT_DEG]
    return {"swings": len(swings), "min_rate_floor_dps": float(rates.min()),
            "min_rate_p5_dps": float(np.percentile(rates, 5)), "min_rate_median_dps": float(np.median(rates)),
            "straight_swings": len(straight),
            "roll_median_deg": float(np.median([s.roll_deg for s in straight])),
            "yaw_median_deg": float(np.median([s.yaw_deg for s in straight])),
            "toe_off_median_deg": float(np.median([s.toe_off_deg for s in swings])),
            "heel_strike_median_deg": float(np.median([s.heel_strike_deg for s in swings]))}


if __name__ == "__main__":
    from tests.conftest import WALK_IDS, walk_path

    every = [s for w in WALK_IDS for s in swing_rotations(walk_path(w))]
    for key, value in summary(every).items():
        print(f"{key:24s} {value:.1f}" if isinstance(value, float) else f"{key:24s} {value}")
