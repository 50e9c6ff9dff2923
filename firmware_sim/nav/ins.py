"""The ZUPT-aided INS and the step-wise reset (firmware.md §4), float32 throughout.

Navigation frame x north, y east, z down. State: position p (0x20), velocity v
(0x21), attitude quaternion q (0x22) and the 9×9 error covariance P of
[δp, δv, δθ], kept as its 45-element upper triangle row by row (0x23).

Conventions (the spec leaves them open; these are ours, used consistently):

* The quaternion is stored **scalar last**, ``[x, y, z, w]`` (as the OpenShoe
  MATLAB implementation and firmware do); ``R(q)`` maps body (board) vectors
  to the navigation frame.
* Attitude error: R̂ = (I + [δθ×]) R, so δv' = −[f_n×] δθ where f_n = R(q) f is
  the **specific force** in the navigation frame (firmware.md writes a_n; with
  gravity added the coupling would vanish at rest and tilt would be
  unobservable). A ZUPT's estimated error δθ is removed by
  q ← [−δθ/2, 1] ⊗ q (renormalised), a small rotation of R(q).
* Index 24 of the 45-element triangle is P(3, 3): row 0 holds indices 0–8,
  row 1 9–16, row 2 17–23, row 3 starts at 24 — var(v_x), the reset criterion.

Every arithmetic operation is single precision: inputs are the float32 states,
constants are the ``numpy.float32`` values of :mod:`firmware_sim.nav.config`,
transcendental functions are numpy's on float32 scalars. The array-level functions are
plain functions over arrays and scalars; their compiled counterparts, of the same names
and arguments, are in :mod:`firmware_sim.nav.ins_kernels` (which compiles some of them, and
the scalar helpers :func:`rot_rows`, :func:`quat_product`, :func:`inv3_sym_upper`, as written).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from firmware_sim.mcu.sequence import processing_function
from protocol.ids import ProcId, StateId

from . import config as cfg
from .records import WorkRecord

if TYPE_CHECKING:  # pragma: no cover
    from firmware_sim.mcu.module import Module

__all__ = [
    "InsWork",
    "ins_work",
    "P_IU",
    "P24_INDEX",
    "POS_YAW_TRIANGLE",
    "quat_to_rot",
    "quat_mul",
    "quat_product",
    "rot_rows",
    "rot_to_yaw",
    "unpack_p",
    "pack_p",
    "alignment_quaternion",
    "initial_alignment",
    "mechanization",
    "time_update",
    "zupt_update",
    "inv3_sym",
    "inv3_sym_upper",
    "stepwise_reset",
]

F32 = np.float32
_0 = F32(0.0)
_1 = F32(1.0)
_2 = F32(2.0)
_HALF = F32(0.5)

#: Row/column indices of the 45-element upper triangle of P, row by row.
P_IU = np.triu_indices(9)
#: P[24] is (3, 3): var(v_x).
P24_INDEX = 24
assert (int(P_IU[0][P24_INDEX]), int(P_IU[1][P24_INDEX])) == (3, 3)
#: Indices into P's triangle of DP's 10 numbers: the (p_x, p_y, p_z, yaw) block, row by row.
_POS_YAW = (0, 1, 2, 8)
POS_YAW_TRIANGLE = np.array(
    [int(np.flatnonzero((P_IU[0] == _POS_YAW[r]) & (P_IU[1] == _POS_YAW[c]))[0])
     for r in range(4) for c in range(r, 4)]
)
#: Triangle elements zeroed by a reset: every term in a position row/column or the yaw row/column.
_RESET_MASK = np.isin(P_IU[0], _POS_YAW) | np.isin(P_IU[1], _POS_YAW)
_GRAVITY_N = np.array([0.0, 0.0, cfg.GRAVITY], dtype=np.float32)
#: The alignment's standard deviations of [δp, δv, δθ] (P = their squares on the diagonal).
_SIGMA_0 = np.array([cfg.SIGMA_P0] * 3 + [cfg.SIGMA_V0] * 3 + [cfg.SIGMA_TH0] * 3, dtype=np.float32)


class InsWork(WorkRecord):
    """The INS's private per-sample state (flat typed arrays in one record, one per module).

    ``f_n``: the specific force in the navigation frame from the last
    mechanization (TIME_UPDATE's F); ``align_sum`` / ``align_count``: the
    alignment's running accelerometer sum over consecutive stationary samples;
    ``t_since_reset``, ``t_pending`` [s] and ``pending``: the step-wise reset's
    timers; ``p_full``: room for the full 9×9 P (the updates' scratch).
    """

    FIELDS = (
        ("f_n", np.float32, (3,)), ("align_sum", np.float32, (3,)), ("align_count", np.int32, (1,)),
        ("t_since_reset", np.float32, (1,)), ("t_pending", np.float32, (1,)), ("pending", np.bool_, (1,)),
        ("p_full", np.float32, (9, 9)),
    )

    def __repr__(self) -> str:
        return (f"InsWork(align_count={int(self.align_count[0])}, "
                f"t_since_reset={float(self.t_since_reset[0]):.3f} s, pending={bool(self.pending[0])})")


def ins_work(module: Module) -> InsWork:
    """The module's INS state (created on first use)."""
    return module.work("ins", InsWork)


# ---------------------------------------------------------------------------------------------
# float32 helpers


def rot_rows(q) -> tuple:
    """R(q)'s three rows as float32 triples (:func:`quat_to_rot`'s arithmetic; q indexable as q[0..3])."""
    x, y, z, w = q[0], q[1], q[2], q[3]
    xx, yy, zz = x * x, y * y, z * z
    xy, xz, yz = x * y, x * z, y * z
    wx, wy, wz = w * x, w * y, w * z
    return ((_1 - _2 * (yy + zz), _2 * (xy - wz), _2 * (xz + wy)),
            (_2 * (xy + wz), _1 - _2 * (xx + zz), _2 * (yz - wx)),
            (_2 * (xz - wy), _2 * (yz + wx), _1 - _2 * (xx + yy)))


def quat_to_rot(q: np.ndarray) -> np.ndarray:
    """R(q) (body → navigation), q = [x, y, z, w], float32 3×3."""
    return np.array(rot_rows(q), dtype=np.float32)


def quat_product(a, b) -> tuple:
    """a ⊗ b as four float32 (:func:`quat_mul`'s arithmetic; a, b indexable as a[0..3])."""
    ax, ay, az, aw = a[0], a[1], a[2], a[3]
    bx, by, bz, bw = b[0], b[1], b[2], b[3]
    return (aw * bx + bw * ax + (ay * bz - az * by),
            aw * by + bw * ay + (az * bx - ax * bz),
            aw * bz + bw * az + (ax * by - ay * bx),
            aw * bw - (ax * bx + ay * by + az * bz))


def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product a ⊗ b of scalar-last quaternions (R(a ⊗ b) = R(a) R(b)), float32."""
    return np.array(quat_product(a, b), dtype=np.float32)


def _mv(a: np.ndarray, x: np.ndarray) -> np.ndarray:
    """a @ x for a small float32 matrix: y_i = a_i0·x_0 + a_i1·x_1 + … left to right, every
    product and sum rounded to float32 (not BLAS, whose order and fused multiply-adds depend
    on the machine): the same bytes everywhere, and what the compiled path computes."""
    y = a[:, 0] * x[0]
    for k in range(1, a.shape[1]):
        y = y + a[:, k] * x[k]
    return y


def _mm(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a @ b for small float32 matrices, in the order of :func:`_mv` (no BLAS)."""
    c = a[:, 0:1] * b[0:1, :]
    for k in range(1, a.shape[1]):
        c = c + a[:, k:k + 1] * b[k:k + 1, :]
    return c


def _double(x: np.float32) -> float:
    """x widened to a double (``float(x)`` alone would stay single precision in compiled code)."""
    return float(np.float64(x))


def _sinf(x: np.float32) -> np.float32:
    """sin of a float32, rounded from the C library's double sin (numpy's float32 sin is
    machine-dependent SIMD code); the compiled path runs this function too. ±inf gives
    NaN as in C (Python's math.sin would raise)."""
    v = _double(x)
    return F32(v - v) if math.isinf(v) else F32(math.sin(v))


def _cosf(x: np.float32) -> np.float32:
    v = _double(x)
    return F32(v - v) if math.isinf(v) else F32(math.cos(v))


def _atan2f(y: np.float32, x: np.float32) -> np.float32:
    """atan2 of float32, rounded from the C library's double atan2; a NaN argument gives the
    quiet NaN whatever its payload, as Python's math.atan2 does (C's would pass the payload on)."""
    vy, vx = _double(y), _double(x)
    return F32(math.nan) if math.isnan(vy) or math.isnan(vx) else F32(math.atan2(vy, vx))


def _normalise(q: np.ndarray) -> np.ndarray:
    return q / np.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])


def rot_to_yaw(r: np.ndarray) -> np.float32:
    """Heading ψ = atan2(R21, R11) of a body → navigation rotation."""
    return _atan2f(r[1, 0], r[0, 0])


def unpack_p(p45: np.ndarray, out: np.ndarray) -> np.ndarray:
    """Expand P's 45-element upper triangle into the symmetric 9×9 ``out``."""
    out[P_IU] = p45
    out[P_IU[1], P_IU[0]] = p45
    return out


def pack_p(pm: np.ndarray, p45: np.ndarray) -> None:
    """Store the upper triangle of the 9×9 ``pm`` into P's 45 elements (symmetrises)."""
    p45[...] = pm[P_IU]


def _skew(v: np.ndarray) -> np.ndarray:
    return np.array([[_0, -v[2], v[1]], [v[2], _0, -v[0]], [-v[1], v[0], _0]], dtype=np.float32)


# ---------------------------------------------------------------------------------------------
# kernels


def alignment_quaternion(f_mean: np.ndarray) -> np.ndarray:
    """Roll = atan2(−f̄y, −f̄z), pitch = atan2(f̄x, √(f̄y²+f̄z²)), yaw = 0 → q (float32)."""
    roll = np.arctan2(-f_mean[1], -f_mean[2])
    pitch = np.arctan2(f_mean[0], np.sqrt(f_mean[1] * f_mean[1] + f_mean[2] * f_mean[2]))
    cr, sr = np.cos(roll * _HALF), np.sin(roll * _HALF)
    cp, sp = np.cos(pitch * _HALF), np.sin(pitch * _HALF)
    # q = q_z(0) ⊗ q_y(pitch) ⊗ q_x(roll)
    return np.array([sr * cp, cr * sp, -sr * sp, cr * cp], dtype=np.float32)


def initial_alignment(f: np.ndarray, zupt: bool, w: InsWork, pos: np.ndarray, vel: np.ndarray,
                      quat: np.ndarray, p45: np.ndarray) -> bool:
    """INITIAL_ALIGNMENT: average f over ALIGNMENT_SAMPLES consecutive ZUPT samples.

    Motion restarts the count. When the count is complete: attitude from the
    mean specific force (yaw 0), p = v = 0, P = diag(σ²_p0, σ²_v0, σ²_θ0);
    returns True (INIT_DONE).
    """
    if not zupt:
        w.align_count[0] = 0
        w.align_sum[:] = _0
        return False
    w.align_sum[:] = w.align_sum + f
    w.align_count[0] += 1
    if w.align_count[0] < cfg.ALIGNMENT_SAMPLES:
        return False
    f_mean = w.align_sum / F32(cfg.ALIGNMENT_SAMPLES)
    quat[:] = alignment_quaternion(f_mean)
    pos[:] = _0
    vel[:] = _0
    pm = np.zeros((9, 9), dtype=np.float32)
    for i in range(9):
        pm[i, i] = _SIGMA_0[i] * _SIGMA_0[i]
    pack_p(pm, p45)
    w.align_count[0] = 0
    w.align_sum[:] = _0
    w.t_since_reset[0] = _0
    w.t_pending[0] = _0
    w.pending[0] = False
    return True


def mechanization(u_k: np.ndarray, dt: np.float32, zaru: bool, pos: np.ndarray, vel: np.ndarray,
                  quat: np.ndarray, f_n: np.ndarray) -> None:
    """MECHANIZATION: a_n = R(q) f + [0, 0, g]; p += v·dt (not while ZARU); v += a_n·dt;
    q ← q ⊗ exp(ω·dt/2), renormalised. While ZARU the vertical component of ω is
    removed first. ``f_n`` receives R(q) f for TIME_UPDATE.
    """
    r = quat_to_rot(quat)
    f = u_k[0:3]
    omega = u_k[3:6]
    if zaru:
        up = r[2]  # the navigation z axis in body coordinates
        omega = omega - (up[0] * omega[0] + up[1] * omega[1] + up[2] * omega[2]) * up
    fn = _mv(r, f)
    f_n[:] = fn
    if not zaru:
        pos[:] = pos + vel * dt
    vel[:] = vel + (fn + _GRAVITY_N) * dt
    theta = omega * dt
    angle = np.sqrt(theta[0] * theta[0] + theta[1] * theta[1] + theta[2] * theta[2])
    dq = np.empty(4, dtype=np.float32)
    if angle > _0:
        s = _sinf(angle * _HALF) / angle
        dq[0:3] = theta * s
        dq[3] = _cosf(angle * _HALF)
    else:
        dq[0:3] = _0
        dq[3] = _1
    quat[:] = _normalise(quat_mul(quat, dq))


def time_update(f_n: np.ndarray, dt: np.float32, zaru: bool, p45: np.ndarray, pm: np.ndarray) -> None:
    """TIME_UPDATE: P ← F P Fᵀ + Q, F = I + [[0, I, 0], [0, 0, −[f_n×]], [0, 0, 0]]·dt,
    Q = dt·T₀·diag(0, σ²_acc I, σ²_gyro I) — dt²·diag(…) at the module's 1 kHz (T₀ = 1 ms),
    the same noise per second at any other loop rate (nav_config). While ZARU position
    and yaw do not grow (no δp' = δv coupling, no yaw noise)."""
    unpack_p(p45, pm)
    fm = np.eye(9, dtype=np.float32)
    if not zaru:
        fm[0, 3] = fm[1, 4] = fm[2, 5] = dt
    fm[3:6, 6:9] = -_skew(f_n) * dt
    pm = _mm(_mm(fm, pm), fm.T)
    dt2 = dt * cfg.NOMINAL_PERIOD  # = dt² at the module's 1 kHz (see nav_config)
    qa = dt2 * cfg.SIGMA_ACC * cfg.SIGMA_ACC
    qg = dt2 * cfg.SIGMA_GYRO * cfg.SIGMA_GYRO
    pm[3, 3] += qa
    pm[4, 4] += qa
    pm[5, 5] += qa
    pm[6, 6] += qg
    pm[7, 7] += qg
    if not zaru:
        pm[8, 8] += qg
    pack_p(pm, p45)


def inv3_sym_upper(a, b, c, d, e, f) -> tuple:
    """The inverse of the symmetric [[a, b, c], [b, d, e], [c, e, f]] by cofactors, as its upper
    triangle row by row (six float32: [0,0], [0,1], [0,2], [1,1], [1,2], [2,2])."""
    c00 = d * f - e * e
    c01 = c * e - b * f
    c02 = b * e - c * d
    c11 = a * f - c * c
    c12 = b * c - a * e
    c22 = a * d - b * b
    inv_det = _1 / (a * c00 + b * c01 + c * c02)
    return c00 * inv_det, c01 * inv_det, c02 * inv_det, c11 * inv_det, c12 * inv_det, c22 * inv_det


def inv3_sym(s: np.ndarray) -> np.ndarray:
    """Inverse of a symmetric 3×3 float32 matrix by cofactors."""
    i00, i01, i02, i11, i12, i22 = inv3_sym_upper(s[0, 0], s[0, 1], s[0, 2], s[1, 1], s[1, 2], s[2, 2])
    return np.array([[i00, i01, i02], [i01, i11, i12], [i02, i12, i22]], dtype=np.float32)


_R_ZUPT = np.eye(3, dtype=np.float32) * (cfg.SIGMA_ZUPT * cfg.SIGMA_ZUPT)


def zupt_update(pos: np.ndarray, vel: np.ndarray, quat: np.ndarray, p45: np.ndarray, pm: np.ndarray,
                dt: np.float32 = cfg.NOMINAL_PERIOD) -> None:
    """ZUPT_UPDATE: pseudo-measurement v = 0 (H = [0 I 0], R = σ²_zupt·(T₀/dt)·I); correct p, v, q;
    P ← P − K H P. R is σ²_zupt at the module's 1 kHz loop (T₀ = 1 ms), see nav_config."""
    unpack_p(p45, pm)
    ph = pm[:, 3:6]  # P Hᵀ (9×3)
    k = _mm(ph, inv3_sym(pm[3:6, 3:6] + _R_ZUPT * (cfg.NOMINAL_PERIOD / dt)))
    dx = _mv(k, vel)  # estimated error of [p, v, θ] (estimate minus truth)
    pos[:] = pos - dx[0:3]
    vel[:] = vel - dx[3:6]
    dq = np.array([-dx[6] * _HALF, -dx[7] * _HALF, -dx[8] * _HALF, _1], dtype=np.float32)
    quat[:] = _normalise(quat_mul(_normalise(dq), quat))
    pm = pm - _mm(k, pm[3:6, :])
    pack_p(pm, p45)


def stepwise_reset(zupt: bool, dt: np.float32, w: InsWork, pos: np.ndarray, quat: np.ndarray,
                   p45: np.ndarray, dx_out: np.ndarray, dp_out: np.ndarray) -> bool:
    """STEPWISE_SYSTEM_RESET; returns True in the cycle of a reset (FILTER_RESET_FLAG).

    Pending when P[24] = var(v_x) < 1e-4 and more than 0.75 s since the last
    reset; a pending reset happens at the end of the stance (ZUPT false) or
    after 0.25 s pending. On reset: DX = [p, yaw], DP = the (p, yaw) covariance
    (10 numbers), p ← 0, yaw ← 0 (roll, pitch kept), every covariance term of
    position and yaw ← 0.
    """
    w.t_since_reset[0] = w.t_since_reset[0] + dt
    if not w.pending[0]:
        if p45[P24_INDEX] < cfg.RESET_COV_THRESHOLD and w.t_since_reset[0] > cfg.MIN_TIME_BETWEEN_RESETS:
            w.pending[0] = True
            w.t_pending[0] = _0
        else:
            return False
    w.t_pending[0] = w.t_pending[0] + dt
    if zupt and not w.t_pending[0] > cfg.MAX_TIME_RESET_PENDING:
        return False
    r = quat_to_rot(quat)
    yaw = rot_to_yaw(r)
    dx_out[0:3] = pos
    dx_out[3] = yaw
    dp_out[:] = p45[POS_YAW_TRIANGLE]
    pos[:] = _0
    half = -yaw * _HALF  # q ← q_z(−ψ) ⊗ q
    quat[:] = _normalise(quat_mul(np.array([_0, _0, _sinf(half), _cosf(half)], dtype=np.float32), quat))
    p45[_RESET_MASK] = _0
    w.t_since_reset[0] = _0
    w.t_pending[0] = _0
    w.pending[0] = False
    return True


# ---------------------------------------------------------------------------------------------
# processing functions


@processing_function(ProcId.FRONTEND_INITIAL_ALIGNMENT, cycles=900)
def frontend_initial_alignment(module: Module) -> None:
    """0x23: initial alignment over consecutive stationary samples; sets INIT_DONE."""
    mem = module.memory
    if initial_alignment(mem[StateId.U_K][0:3], bool(mem[StateId.ZUPT]), ins_work(module),
                         mem[StateId.POSITION], mem[StateId.VELOCITY], mem[StateId.QUATERNION],
                         mem[StateId.P]):
        mem[StateId.INIT_DONE][...] = True


@processing_function(ProcId.MECHANIZATION, cycles=7000)
def ins_mechanization(module: Module) -> None:
    """0x20: strapdown mechanization of position, velocity and attitude."""
    mem = module.memory
    mechanization(mem[StateId.U_K], mem[StateId.DT][()], bool(mem[StateId.ZARU]), mem[StateId.POSITION],
                  mem[StateId.VELOCITY], mem[StateId.QUATERNION], ins_work(module).f_n)


@processing_function(ProcId.TIME_UPDATE, cycles=26000)
def ins_time_update(module: Module) -> None:
    """0x21: covariance propagation."""
    mem = module.memory
    w = ins_work(module)
    time_update(w.f_n, mem[StateId.DT][()], bool(mem[StateId.ZARU]), mem[StateId.P], w.p_full)


@processing_function(ProcId.ZUPT_UPDATE, cycles=15000)
def ins_zupt_update(module: Module) -> None:
    """0x22: zero-velocity measurement update while ZUPT."""
    mem = module.memory
    if bool(mem[StateId.ZUPT]):
        zupt_update(mem[StateId.POSITION], mem[StateId.VELOCITY], mem[StateId.QUATERNION], mem[StateId.P],
                    ins_work(module).p_full, mem[StateId.DT][()])


@processing_function(ProcId.STEPWISE_SYSTEM_RESET, cycles=2500)
def ins_stepwise_system_reset(module: Module) -> None:
    """0x24: end a step: hand DX/DP to the host, reset position and heading."""
    mem = module.memory
    flag = stepwise_reset(bool(mem[StateId.ZUPT]), mem[StateId.DT][()], ins_work(module),
                          mem[StateId.POSITION], mem[StateId.QUATERNION], mem[StateId.P],
                          mem[StateId.DX], mem[StateId.DP])
    mem[StateId.FILTER_RESET_FLAG][...] = flag
    if flag:
        mem[StateId.STEP_COUNTER][...] = (int(mem[StateId.STEP_COUNTER]) + 1) & 0xFFFF
