"""The published OpenShoe reference algorithm, as an oracle for the emulated firmware.

This is the OpenShoe MATLAB implementation (``zero_velocity_detector.m``, ``ZUPTaidedINS.m``)
written again in float64 at the recording's full rate, with nothing of the emulator in it:

* **GLRT detector** (Skog et al. 2010): for every window of ``W`` consecutive samples,
  T = (1/W) Σ ‖f_k − g f̄/‖f̄‖‖²/σ_a² + ‖ω_k‖²/σ_g²; a sample is stationary when *any*
  window holding it has T < γ.
* **EKF**: navigation equations (quaternion first, then p += v·Ts + a·Ts²/2, v += a·Ts),
  P ← F P Fᵀ + G Q Gᵀ with Q = diag(σ_acc² I, σ_gyro² I), a ZUPT (v = 0, σ_v) at every
  stationary sample, the attitude corrected by (I − [ε×]) R. No smoother, no step-wise reset.
* **Initial alignment**: roll and pitch from the mean specific force of the first 20 samples,
  heading 0, p = v = 0.

Units: the recording's specific force in g is turned into m/s² with ``g_unit`` (9.80665), and the
navigation equations add gravity ``g`` — the MATLAB's ``gravity(58°, 100 m)`` = 9.8173 m/s²,
the value the published closure figures were computed with (``reference.csv`` checks both).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

__all__ = ["ReferenceSettings", "ReferenceRun", "glrt_statistic", "glrt_stance", "run_reference",
           "matlab_gravity", "stance_phases"]


def matlab_gravity(latitude_deg: float, altitude_m: float) -> float:
    """The MATLAB reference's ``gravity.m``: normal gravity at a latitude and height [m/s²]."""
    lam = math.radians(latitude_deg)
    gamma = 9.780327 * (1 + 0.0053024 * math.sin(lam) ** 2 - 0.0000058 * math.sin(2 * lam) ** 2)
    return gamma - (3.0877e-6 - 0.004e-6 * math.sin(lam) ** 2) * altitude_m + 0.072e-12 * altitude_m ** 2


@dataclass(frozen=True)
class ReferenceSettings:
    """The reference's published settings (the MATLAB ``settings.m``)."""

    window: int = 3
    gamma: float = 0.3e5
    sigma_a: float = 0.01  # m/s²
    sigma_g: float = math.radians(0.1)  # rad/s
    sigma_acc: float = 0.5  # m/s²
    sigma_gyro: float = math.radians(0.5)  # rad/s
    sigma_vel: float = 0.01  # m/s
    sigma_p0: float = 1e-5
    sigma_v0: float = 1e-5
    sigma_att0: float = math.radians(0.1)
    g: float = matlab_gravity(58.0, 100.0)
    g_unit: float = 9.80665
    alignment_samples: int = 20


@dataclass
class ReferenceRun:
    """What the oracle computed on one recording (index k = sample k)."""

    stance: np.ndarray  #: (n,) bool, the detector's decision per sample
    statistic: np.ndarray  #: (n,) the GLRT statistic, centred on the window (edges: its max)
    position: np.ndarray  #: (n, 3) navigation frame, x north, y east, z down [m]
    velocity: np.ndarray  #: (n, 3) [m/s]
    heading: np.ndarray  #: (n,) yaw [rad]
    nis: np.ndarray  #: (n,) normalised innovation squared vᵀS⁻¹v of each ZUPT (NaN without one)


def glrt_statistic(acc: np.ndarray, gyro: np.ndarray, s: ReferenceSettings) -> np.ndarray:
    """T(k) of the window k … k+W−1, (n−W+1,); *acc* in m/s², *gyro* in rad/s, both (n, 3)."""
    w = s.window
    n = len(acc)
    windows = np.lib.stride_tricks.sliding_window_view(acc, (w, 3))[:, 0]  # (n-w+1, w, 3)
    mean = windows.mean(axis=1)
    unit = mean / np.linalg.norm(mean, axis=1, keepdims=True)
    dev = windows - s.g * unit[:, None, :]
    acc_term = (dev ** 2).sum(axis=(1, 2)) / s.sigma_a ** 2
    gyro_sq = (gyro ** 2).sum(axis=1)
    gyro_term = np.lib.stride_tricks.sliding_window_view(gyro_sq, w).sum(axis=1) / s.sigma_g ** 2
    assert len(acc_term) == n - w + 1
    return (acc_term + gyro_term) / w


def glrt_stance(acc: np.ndarray, gyro: np.ndarray, s: ReferenceSettings) -> tuple[np.ndarray, np.ndarray]:
    """(stance per sample, statistic centred on its window) as ``zero_velocity_detector.m``."""
    t = glrt_statistic(acc, gyro, s)
    n, w = len(acc), s.window
    stance = np.zeros(n, dtype=bool)
    for k in np.flatnonzero(t < s.gamma):
        stance[k:k + w] = True
    half = w // 2
    centred = np.concatenate([np.full(half, t.max()), t, np.full(n - len(t) - half, t.max())])
    return stance, centred


def stance_phases(stance: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) sample of each run of stationary samples."""
    edges = np.diff(np.concatenate([[0], stance.astype(np.int8), [0]]))
    starts = np.flatnonzero(edges == 1)
    ends = np.flatnonzero(edges == -1) - 1
    return list(zip(starts.tolist(), ends.tolist(), strict=True))


def _skew(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _q2dcm(q: np.ndarray) -> np.ndarray:
    """The MATLAB ``q2dcm`` (scalar last; scales by 2/‖q‖² as it does)."""
    x, y, z, w = q
    k = 2.0 / (x * x + y * y + z * z + w * w)
    return np.array([[1 - k * (y * y + z * z), k * (x * y - z * w), k * (x * z + y * w)],
                     [k * (x * y + z * w), 1 - k * (x * x + z * z), k * (y * z - x * w)],
                     [k * (x * z - y * w), k * (y * z + x * w), 1 - k * (x * x + y * y)]])


def _dcm2q(r: np.ndarray) -> np.ndarray:
    """The MATLAB ``dcm2q`` (scalar last), all four branches."""
    t = 1 + r[0, 0] + r[1, 1] + r[2, 2]
    if t > 1e-8:
        s = 0.5 / math.sqrt(t)
        return np.array([(r[2, 1] - r[1, 2]) * s, (r[0, 2] - r[2, 0]) * s, (r[1, 0] - r[0, 1]) * s, 0.25 / s])
    if r[0, 0] > r[1, 1] and r[0, 0] > r[2, 2]:
        s = math.sqrt(1 + r[0, 0] - r[1, 1] - r[2, 2]) * 2
        return np.array([0.25 * s, (r[0, 1] + r[1, 0]) / s, (r[0, 2] + r[2, 0]) / s, (r[2, 1] - r[1, 2]) / s])
    if r[1, 1] > r[2, 2]:
        s = math.sqrt(1 + r[1, 1] - r[0, 0] - r[2, 2]) * 2
        return np.array([(r[0, 1] + r[1, 0]) / s, 0.25 * s, (r[1, 2] + r[2, 1]) / s, (r[0, 2] - r[2, 0]) / s])
    s = math.sqrt(1 + r[2, 2] - r[0, 0] - r[1, 1]) * 2
    return np.array([(r[0, 2] + r[2, 0]) / s, (r[1, 2] + r[2, 1]) / s, 0.25 * s, (r[1, 0] - r[0, 1]) / s])


def _euler_to_q(roll: float, pitch: float, yaw: float) -> np.ndarray:
    cr, sr, cp, sp, cy, sy = (math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch),
                              math.cos(yaw), math.sin(yaw))
    r = np.array([[cy * cp, -sy * cr + cy * sp * sr, sy * sr + cy * cr * sp],
                  [sy * cp, cy * cr + sy * sp * sr, -cy * sr + sy * sp * cr],
                  [-sp, cp * sr, cp * cr]])
    return _dcm2q(r)


def run_reference(acc_g: np.ndarray, gyro: np.ndarray, rate_hz: float,
                  settings: ReferenceSettings | None = None,
                  stance: np.ndarray | None = None) -> ReferenceRun:
    """Run the reference on a recording: *acc_g* specific force [g], *gyro* [rad/s], (n, 3) each,
    in the recording's own body frame (any frame: the alignment finds it). *stance* replaces the
    detector's decisions (another detector's flags, to tell the detector's part from the filter's)."""
    s = settings or ReferenceSettings()
    acc = np.asarray(acc_g, dtype=np.float64) * s.g_unit
    gyro = np.asarray(gyro, dtype=np.float64)
    n = len(acc)
    ts = 1.0 / rate_hz
    detected, statistic = glrt_stance(acc, gyro, s)
    stance = detected if stance is None else np.asarray(stance, dtype=bool)

    f0 = acc[:s.alignment_samples].mean(axis=0)
    roll = math.atan2(-f0[1], -f0[2])
    pitch = math.atan2(f0[0], math.hypot(f0[1], f0[2]))
    q = _euler_to_q(roll, pitch, 0.0)
    p = np.zeros(3)
    v = np.zeros(3)
    cov = np.diag([s.sigma_p0 ** 2] * 3 + [s.sigma_v0 ** 2] * 3 + [s.sigma_att0 ** 2] * 3)
    qn = np.diag([s.sigma_acc ** 2] * 3 + [s.sigma_gyro ** 2] * 3)
    r_zupt = np.eye(3) * s.sigma_vel ** 2
    g_n = np.array([0.0, 0.0, s.g])
    eye9 = np.eye(9)

    pos = np.zeros((n, 3))
    vel = np.zeros((n, 3))
    heading = np.zeros(n)
    nis = np.full(n, np.nan)
    rot = _q2dcm(q)
    heading[0] = math.atan2(rot[1, 0], rot[0, 0])
    for k in range(1, n):
        w = gyro[k] * ts
        angle = float(np.linalg.norm(w))
        if angle != 0.0:
            om = 0.5 * np.array([[0.0, w[2], -w[1], w[0]], [-w[2], 0.0, w[0], w[1]],
                                 [w[1], -w[0], 0.0, w[2]], [-w[0], -w[1], -w[2], 0.0]])
            q = (math.cos(angle / 2) * np.eye(4) + 2 / angle * math.sin(angle / 2) * om) @ q
            q = q / np.linalg.norm(q)
        rot = _q2dcm(q)
        f_n = rot @ acc[k]
        a_n = f_n + g_n
        p = p + v * ts + a_n * ts * ts / 2
        v = v + a_n * ts

        f = eye9.copy()
        f[0:3, 3:6] = np.eye(3) * ts
        f[3:6, 6:9] = _skew(f_n) * ts
        gm = np.zeros((9, 6))
        gm[3:6, 0:3] = rot * ts
        gm[6:9, 3:6] = -rot * ts
        cov = f @ cov @ f.T + gm @ qn @ gm.T
        cov = (cov + cov.T) / 2

        if stance[k]:
            ph = cov[:, 3:6]
            s_inv = np.linalg.inv(cov[3:6, 3:6] + r_zupt)
            nis[k] = float(v @ s_inv @ v)
            gain = ph @ s_inv
            dx = gain @ (-v)
            p = p + dx[0:3]
            v = v + dx[3:6]
            rot = (np.eye(3) - _skew(dx[6:9])) @ rot
            q = _dcm2q(rot)
            cov = (eye9 - gain @ np.hstack([np.zeros((3, 3)), np.eye(3), np.zeros((3, 3))])) @ cov
            cov = (cov + cov.T) / 2
        pos[k], vel[k] = p, v
        heading[k] = math.atan2(rot[1, 0], rot[0, 0])
    return ReferenceRun(stance, statistic, pos, vel, heading, nis)


def reference_of_recording(path: str | Path) -> ReferenceRun:
    """:func:`run_reference` with the default settings on the recording *path* (its own rate), once
    per process: the oracle's comparisons ask for the same shared walks again. Its arrays are
    read-only (shared by every caller)."""
    return _reference_of(str(Path(path).resolve()))


@functools.cache
def _reference_of(path: str) -> ReferenceRun:
    from firmware_sim.sensors.replay import load_recording

    rec = load_recording(path)
    run = run_reference(rec.acc_g, rec.gyro, rec.rate_hz)
    for f in fields(run):
        getattr(run, f.name).flags.writeable = False
    return run
