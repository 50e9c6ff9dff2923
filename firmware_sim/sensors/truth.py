"""Ground truth of a simulated walk, and a reference strapdown integrator to check it.

:class:`Kinematics` is the exact motion of the board at a set of times:
position, velocity, acceleration (navigation frame NED), attitude (ZYX Euler
angles, rotation matrix body → navigation, quaternion), angular rate and
angular acceleration (body frame) and the specific force f_b = Rᵀ(a − g_n) an
ideal accelerometer at the board centre reads (g_n = (0, 0, +g), so at rest
f_b = (0, 0, −g)). :class:`GroundTruth` adds the sample rate and the stances
(where and when the foot rested) and writes both as CSV.

:func:`strapdown_rk4` integrates specific force and angular rate back into a
trajectory in float64 with a fourth-order Runge–Kutta step over two sample
intervals (the middle sample is the midpoint stage). It is the yardstick that
shows the simulated signals are consistent with the trajectory; it is *not*
the firmware's float32 INS.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = [
    "Kinematics", "GroundTruth", "body_rate", "euler_to_matrix", "mul_transposed", "rotate", "rotation",
    "add_at_rows", "cross", "cross_rows", "euler_to_quat", "quat_to_matrix", "strapdown_rk4",
    "walked_distance",
]


def euler_to_matrix(roll: np.ndarray, pitch: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """R = Rz(yaw) Ry(pitch) Rx(roll), body → navigation, shape (n, 3, 3)."""
    return _matrix_of(np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch), np.cos(yaw), np.sin(yaw))


def _matrix_of(cr: np.ndarray, sr: np.ndarray, cp: np.ndarray, sp: np.ndarray, cy: np.ndarray, sy: np.ndarray
               ) -> np.ndarray:
    """:func:`euler_to_matrix` of the angles' cosines and sines."""
    R = np.empty(np.shape(cr) + (3, 3))
    cy_sp, sy_sp = cy * sp, sy * sp  # each product once, where two entries share it
    R[..., 0, 0] = cy * cp
    R[..., 0, 1] = cy_sp * sr - sy * cr
    R[..., 0, 2] = cy_sp * cr + sy * sr
    R[..., 1, 0] = sy * cp
    R[..., 1, 1] = sy_sp * sr + cy * cr
    R[..., 1, 2] = sy_sp * cr - cy * sr
    R[..., 2, 0] = -sp
    R[..., 2, 1] = cp * sr
    R[..., 2, 2] = cp * cr
    return R


def body_rate(ang: np.ndarray, dang: np.ndarray) -> np.ndarray:
    """The body's angular rate ω_b (n, 3) of ZYX Euler angles *ang* (roll, pitch, yaw; n, 3) and
    their rates *dang*."""
    phi, th = ang[:, 0], ang[:, 1]
    return _body_rate(dang, np.sin(phi), np.cos(phi), np.sin(th), np.cos(th))


def _body_rate(dang: np.ndarray, sf: np.ndarray, cf: np.ndarray, st: np.ndarray, ct: np.ndarray
               ) -> np.ndarray:
    """:func:`body_rate` of the roll's and the pitch's sines and cosines."""
    dphi, dth, dpsi = dang.T
    dpsi_ct = dpsi * ct
    return np.stack([
        dphi - dpsi * st,
        dth * cf + dpsi_ct * sf,
        -dth * sf + dpsi_ct * cf,
    ], axis=1)


def walked_distance(pos: np.ndarray) -> np.ndarray:
    """(n,) horizontal distance [m] walked up to each of the NED positions *pos* (n, ≥ 2)."""
    steps = np.diff(np.asarray(pos, dtype=np.float64)[:, :2], axis=0)
    return np.concatenate([[0.0], np.cumsum(np.hypot(steps[:, 0], steps[:, 1]))])


def mul_transposed(R: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rᵀ v for stacks (n, 3, 3) and (n, 3) (navigation → body); *v* may be one vector (3,).

    Each component R₀ᵢv₀ + R₁ᵢv₁ + R₂ᵢv₂ is summed in that order, a component at a time (many times
    faster than the rows of three)."""
    out = np.empty(R.shape[:-1], dtype=np.result_type(R, v))
    for i in range(3):
        column = np.multiply(R[:, 0, i], v[..., 0], out=out[:, i])
        column += R[:, 1, i] * v[..., 1]
        column += R[:, 2, i] * v[..., 2]
    return out


def is_signed_permutation(M: np.ndarray) -> bool:
    """Whether every row of the 3×3 matrix *M* (or of each in a stack) is one ±1 and zeros."""
    nz = np.asarray(M) != 0
    return bool(np.all(nz.sum(axis=-1) == 1) and np.all(np.abs(np.asarray(M)[nz]) == 1))


def rotate(M: np.ndarray, v: np.ndarray) -> np.ndarray:
    """M v for one 3×3 matrix and a stack of vectors (n, 3) (faster than v @ M.T for small M).

    A signed permutation (a chip mounting) is applied by indexing, exactly.
    """
    return rotation(M)(v)


def rotation(M: np.ndarray) -> Rotation:
    """:func:`rotate` by *M* as a function of the stack of vectors: the same numbers, *M* looked
    at once (for one matrix applied to many stacks)."""
    return Rotation(np.asarray(M))


class Rotation:
    """``rotate(M, v)`` of one *M* (a picklable function of *v*), and :meth:`rows`: the same
    numbers for vectors stored a component a row."""

    def __init__(self, M: np.ndarray):
        self.permutes = is_signed_permutation(M)
        if self.permutes:
            self.cols = np.argmax(M != 0, axis=1)
            self.signs = M[np.arange(3), self.cols]
        else:
            self.c0, self.c1, self.c2 = M[:, 0], M[:, 1], M[:, 2]

    def __call__(self, v: np.ndarray) -> np.ndarray:
        if self.permutes:
            return v[:, self.cols] * self.signs
        return v[:, 0:1] * self.c0 + v[:, 1:2] * self.c1 + v[:, 2:3] * self.c2

    def rows(self, v: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """M v for vectors stored a component a row, *v* (3, …): ``rotate(M, v.T).T`` bit for bit
        (each component the same products summed in the same order), into *out* when given.
        Each operation runs along a row, not across three components: many times faster."""
        if self.permutes:
            return np.multiply(v[self.cols], _column(self.signs, v.ndim), out=out)
        out = np.multiply(v[0], _column(self.c0, v.ndim), out=out)
        out += v[1] * _column(self.c1, v.ndim)
        out += v[2] * _column(self.c2, v.ndim)
        return out


def _column(c: np.ndarray, ndim: int) -> np.ndarray:
    """The vector *c* (3,) shaped to scale the rows of a stack of *ndim* dimensions (3, …)."""
    return c.reshape((3,) + (1,) * (ndim - 1))


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a × b for stacks of vectors (broadcasting over leading axes)."""
    ax, ay, az = a[..., 0], a[..., 1], a[..., 2]
    bx, by, bz = b[..., 0], b[..., 1], b[..., 2]
    out = np.empty(np.broadcast_shapes(np.shape(a), np.shape(b)), dtype=np.result_type(a, b))
    for k, (p, q, r, s) in enumerate(((ay, bz, az, by), (az, bx, ax, bz), (ax, by, ay, bx))):
        np.multiply(p, q, out=out[..., k])  # p q − r s, each component where it is kept
        out[..., k] -= r * s
    return out


def cross_rows(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """:func:`cross` for vectors stored a component a row (3, …), broadcasting over the rest:
    ``cross(a.T, b.T).T`` bit for bit, each operation along the rows."""
    lead, lag = [1, 2, 0], [2, 0, 1]  # (y, z, x) and (z, x, y): out = a_lead b_lag − a_lag b_lead
    out = a[lead] * b[lag]
    out -= a[lag] * b[lead]
    return out


def add_at_rows(rows: np.ndarray, at: np.ndarray, value: np.ndarray) -> None:
    """rows[:, at] += value, for vectors stored a component a row (3, n) and *value* (3, len(at)):
    a row at a time (many times faster than numpy's gather and scatter of rows of three)."""
    for row, v in zip(rows, value, strict=True):
        row[at] += v


def euler_to_quat(roll: np.ndarray, pitch: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z), body → navigation, of ZYX Euler angles."""
    cr, sr = np.cos(roll / 2), np.sin(roll / 2)
    cp, sp = np.cos(pitch / 2), np.sin(pitch / 2)
    cy, sy = np.cos(yaw / 2), np.sin(yaw / 2)
    return np.stack([
        cr * cp * cy + sr * sp * sy,
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
    ], axis=-1)


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrix of a unit quaternion (w, x, y, z)."""
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], axis=-1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], axis=-1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=-1),
    ], axis=-2)


@dataclass(frozen=True, eq=False)
class Kinematics:
    """Exact board motion at times ``t`` (see the module docstring for frames)."""

    t: np.ndarray  #: (n,) [s]
    pos: np.ndarray  #: (n, 3) [m] NED
    vel: np.ndarray  #: (n, 3) [m/s]
    acc: np.ndarray  #: (n, 3) [m/s²]
    euler: np.ndarray  #: (n, 3) roll, pitch, yaw [rad]; yaw continuous (not wrapped)
    R: np.ndarray  #: (n, 3, 3) body → navigation
    omega_b: np.ndarray  #: (n, 3) angular rate, body frame [rad/s]
    alpha_b: np.ndarray  #: (n, 3) angular acceleration, body frame [rad/s²]
    f_b: np.ndarray  #: (n, 3) specific force at the board centre, body frame [m/s²]
    stance: np.ndarray  #: (n,) bool, foot at rest
    gravity: float = 9.81

    @classmethod
    def from_euler(cls, t, pos, vel, acc, ang, dang, ddang, stance, gravity: float = 9.81) -> Kinematics:
        """Build from Euler angles and their first two time derivatives."""
        phi, th, psi = ang.T
        dphi, dth, dpsi = dang.T
        ddphi, ddth, ddpsi = ddang.T
        sf, cf, st, ct = np.sin(phi), np.cos(phi), np.sin(th), np.cos(th)
        omega = _body_rate(dang, sf, cf, st, ct)
        # the products two components share, each once (the same operations in the same order)
        dpsi_dth, dth_dphi, ddpsi_ct, dpsi_dphi_ct = dpsi * dth, dth * dphi, ddpsi * ct, dpsi * dphi * ct
        dpsi_dth_st = dpsi_dth * st
        alpha = np.stack([
            ddphi - ddpsi * st - dpsi_dth * ct,
            ddth * cf - dth_dphi * sf + ddpsi_ct * sf - dpsi_dth_st * sf + dpsi_dphi_ct * cf,
            -ddth * sf - dth_dphi * cf + ddpsi_ct * cf - dpsi_dth_st * cf - dpsi_dphi_ct * sf,
        ], axis=1)
        R = _matrix_of(cf, sf, ct, st, np.cos(psi), np.sin(psi))  # euler_to_matrix(*ang.T)
        a_minus_g = acc.copy()
        a_minus_g[:, 2] -= gravity  # acc − (0, 0, g): x − 0 is x
        f_b = mul_transposed(R, a_minus_g)
        return cls(t, pos, vel, acc, ang, R, omega, alpha, f_b, np.asarray(stance, dtype=bool), gravity)

    @property
    def quat(self) -> np.ndarray:
        """(n, 4) unit quaternion (w, x, y, z), body → navigation."""
        return euler_to_quat(*self.euler.T)

    def __len__(self) -> int:
        return len(self.t)


class GroundTruth:
    """What really happened in a simulated scenario, sampled at ``rate_hz``.

    Per sample: ``t``, ``pos``, ``vel``, ``quat``, ``euler``, ``omega_b``,
    ``f_b``, ``stance`` (attributes of :attr:`kinematics`). Per stance (one
    rest of the foot): ``stance_start``, ``stance_end`` [s] and
    ``stance_poses`` (m, 6): x, y, z, roll, pitch, yaw.
    """

    def __init__(self, kinematics: Kinematics, rate_hz: float, stance_start: np.ndarray,
                 stance_end: np.ndarray, stance_poses: np.ndarray):
        self.kinematics = kinematics  #: the per-sample motion (:class:`Kinematics`)
        self.rate_hz = float(rate_hz)
        self.stance_start = stance_start
        self.stance_end = stance_end
        self.stance_poses = stance_poses

    def __getattr__(self, name: str):
        if name in ("t", "pos", "vel", "acc", "euler", "R", "omega_b", "alpha_b", "f_b", "stance", "quat",
                    "gravity"):
            return getattr(self.kinematics, name)
        raise AttributeError(name)

    def __len__(self) -> int:
        return len(self.kinematics)

    def __repr__(self) -> str:
        return (f"GroundTruth({len(self)} samples at {self.rate_hz:g} Hz, {len(self.stance_start)} stances, "
                f"path {self.distance_m():.1f} m)")

    @property
    def stance_positions(self) -> np.ndarray:
        """(m, 3) where the foot rested, NED [m]."""
        return self.stance_poses[:, :3]

    def stances_in_start_frame(self) -> np.ndarray:
        """(m, 3) the rests of the foot in the frame a track starts in: origin at the first rest,
        x along the initial heading (the module's yaw is 0 at its alignment), z down."""
        stances = self.stance_positions
        psi0 = float(self.euler[0, 2])
        c, s = np.cos(-psi0), np.sin(-psi0)
        rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        return (stances - stances[0]) @ rot.T

    def heading_change(self) -> float:
        """The foot's heading at its last rest minus at its first [rad], wrapped to [−π, π]."""
        yaw = self.stance_poses[:, 5]
        return math.remainder(float(yaw[-1] - yaw[0]), 2.0 * math.pi)

    def distance_m(self) -> float:
        """Length of the path from rest to rest (sum of the straight lines between stances)."""
        p = self.stance_positions
        return float(np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1))) if len(p) > 1 else 0.0

    def to_csv(self, path: str | Path) -> Path:
        """Per-sample truth: t, x, y, z, vx, vy, vz, qw, qx, qy, qz, roll, pitch, yaw (wrapped), stance."""
        path = Path(path)
        k = self.kinematics
        eul = k.euler.copy()
        eul[:, 2] = (eul[:, 2] + math.pi) % (2 * math.pi) - math.pi
        table = np.hstack([k.t[:, None], k.pos, k.vel, k.quat, eul, k.stance[:, None].astype(float)])
        header = "t,x,y,z,vx,vy,vz,qw,qx,qy,qz,roll,pitch,yaw,stance"
        fmt = ["%.6f"] + ["%.9f"] * 13 + ["%d"]
        np.savetxt(path, table, delimiter=",", header=header, comments="", fmt=fmt)
        return path

    def stances_to_csv(self, path: str | Path) -> Path:
        """Per-stance truth: t_start, t_end, x, y, z, roll, pitch, yaw."""
        path = Path(path)
        table = np.hstack([self.stance_start[:, None], self.stance_end[:, None], self.stance_poses])
        np.savetxt(path, table, delimiter=",", header="t_start,t_end,x,y,z,roll,pitch,yaw", comments="",
                   fmt="%.9f")
        return path


def strapdown_rk4(f_b: np.ndarray, omega_b: np.ndarray, dt: float, p0: np.ndarray, v0: np.ndarray,
                  q0: np.ndarray, gravity: float = 9.81) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Integrate body-frame specific force and angular rate (float64, RK4 over pairs of samples).

    State: position, velocity (NED) and attitude quaternion (w, x, y, z),
    q̇ = ½ q ⊗ (0, ω), v̇ = R(q) f + g_n, ṗ = v. Returns them at the even
    samples 0, 2, 4, … (step h = 2·dt; the odd samples are the midpoint stage).
    Scalar Python floats: about 10 µs per step.
    """
    n = (len(f_b) - 1) // 2
    F = np.asarray(f_b, dtype=float).tolist()
    W = np.asarray(omega_b, dtype=float).tolist()
    h = 2.0 * dt
    g = float(gravity)
    state = [*map(float, q0), *map(float, v0), *map(float, p0)]
    out = np.empty((n + 1, 10))
    out[0] = state

    def deriv(s: list[float], f: list[float], w: list[float]) -> list[float]:
        qw, qx, qy, qz, vx, vy, vz = s[0], s[1], s[2], s[3], s[4], s[5], s[6]
        wx, wy, wz = w
        fx, fy, fz = f
        r00 = 1 - 2 * (qy * qy + qz * qz)
        r01 = 2 * (qx * qy - qw * qz)
        r02 = 2 * (qx * qz + qw * qy)
        r10 = 2 * (qx * qy + qw * qz)
        r11 = 1 - 2 * (qx * qx + qz * qz)
        r12 = 2 * (qy * qz - qw * qx)
        r20 = 2 * (qx * qz - qw * qy)
        r21 = 2 * (qy * qz + qw * qx)
        r22 = 1 - 2 * (qx * qx + qy * qy)
        return [
            0.5 * (-qx * wx - qy * wy - qz * wz),
            0.5 * (qw * wx + qy * wz - qz * wy),
            0.5 * (qw * wy - qx * wz + qz * wx),
            0.5 * (qw * wz + qx * wy - qy * wx),
            r00 * fx + r01 * fy + r02 * fz,
            r10 * fx + r11 * fy + r12 * fz,
            r20 * fx + r21 * fy + r22 * fz + g,
            vx, vy, vz,
        ]

    for k in range(n):
        f0, f1, f2 = F[2 * k], F[2 * k + 1], F[2 * k + 2]
        w0, w1, w2 = W[2 * k], W[2 * k + 1], W[2 * k + 2]
        k1 = deriv(state, f0, w0)
        k2 = deriv([a + 0.5 * h * b for a, b in zip(state, k1, strict=True)], f1, w1)
        k3 = deriv([a + 0.5 * h * b for a, b in zip(state, k2, strict=True)], f1, w1)
        k4 = deriv([a + h * b for a, b in zip(state, k3, strict=True)], f2, w2)
        state = [a + h / 6.0 * (b + 2 * c + 2 * d + e)
                 for a, b, c, d, e in zip(state, k1, k2, k3, k4, strict=True)]
        norm = math.sqrt(state[0] ** 2 + state[1] ** 2 + state[2] ** 2 + state[3] ** 2)
        state[0] /= norm
        state[1] /= norm
        state[2] /= norm
        state[3] /= norm
        out[k + 1] = state
    return out[:, 7:10], out[:, 4:7], out[:, 0:4]
