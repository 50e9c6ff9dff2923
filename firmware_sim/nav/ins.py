"""The ZUPT-aided INS and the step-wise reset (firmware.md §4), float32 throughout; and the emulator's
slope height compensation (function 0x25, docs/protocol-extensions.md), a measurement in the same filter.

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
transcendental functions are the C library's double ones rounded to float32
(:mod:`firmware_sim.nav.ins_arithmetic`, which also holds the rotations, quaternions and P's
triangle; the alignment's attitude alone uses numpy's float32 functions, as it always did). The
array-level functions are plain functions over arrays and scalars; their compiled counterparts,
of the same names and arguments, are in :mod:`firmware_sim.nav.ins_kernels` (which compiles some
of them, and the scalar helpers of :mod:`~firmware_sim.nav.ins_arithmetic`, as written).

Numbers a host set (SET_STATE of DT, U_K, P, the quaternion…) can make this arithmetic divide
by zero or overflow. The µC's FPU then gives inf or NaN and goes on, and so does the emulator,
bit for bit in both paths; numpy's warnings about it are switched off around exactly these
computations (the processing functions below, and :func:`alignment_quaternion`, which the
compiled path calls from object mode). Which commands and values do it:
docs/protocol-extensions.md, "Numbers that go non-finite".
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from firmware_sim.mcu.sequence import processing_function
from protocol.ids import ProcId, StateId

from . import config as cfg
from .ins_arithmetic import (
    _HALF,
    F32,
    P_IU,
    _0,
    _1,
    _atan2f,
    _cosf,
    _mm,
    _mv,
    _normalise,
    _sinf,
    _skew,
    _tanf,
    inv3_sym,
    pack_p,
    quat_mul,
    quat_to_rot,
    rot_to_yaw,
    unpack_p,
)
from .records import WorkRecord

if TYPE_CHECKING:  # pragma: no cover
    from firmware_sim.mcu.module import Module

__all__ = [
    "HeightWork",
    "InsWork",
    "height_work",
    "ins_work",
    "new_ins_work",
    "P24_INDEX",
    "POS_YAW_TRIANGLE",
    "alignment_quaternion",
    "initial_alignment",
    "mechanization",
    "time_update",
    "zupt_update",
    "stepwise_reset",
    "foot_angles",
    "slope_height_update",
    "note_step",
    "learn_posture",
    "height_compensation",
    "clear_stance",
    "start_stance",
]

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
    timers; ``p_full``: room for the full 9×9 P (the updates' scratch); ``t_swing`` [s]: the
    time without ZUPT since the last reset (SWING_TIME at the next one); ``noise``: the filter's
    noise figures (:meth:`~firmware_sim.nav.config.InsNoise.as_array`), set when the record is made.
    ``align_mean`` / ``attitude_due``: the compiled path's hand-over of a completed alignment's mean
    specific force, whose attitude the caller computes (:mod:`firmware_sim.nav.driver`); the
    reference functions leave them alone.
    """

    FIELDS = (
        ("f_n", np.float32, (3,)), ("align_sum", np.float32, (3,)), ("align_count", np.int32, (1,)),
        ("t_since_reset", np.float32, (1,)), ("t_pending", np.float32, (1,)), ("pending", np.bool_, (1,)),
        ("p_full", np.float32, (9, 9)), ("t_swing", np.float32, (1,)), ("noise", np.float32, (4,)),
        ("align_mean", np.float32, (3,)), ("attitude_due", np.bool_, (1,)),
    )

    def __repr__(self) -> str:
        return (f"InsWork(align_count={int(self.align_count[0])}, "
                f"t_since_reset={float(self.t_since_reset[0]):.3f} s, pending={bool(self.pending[0])})")


def new_ins_work(noise: cfg.InsNoise | None = None) -> InsWork:
    """A fresh INS state whose filter uses *noise* (default: the module's own figures)."""
    w = InsWork()
    w.noise[:] = (noise or cfg.MODULE_INS_NOISE).as_array()
    return w


def ins_work(module: Module) -> InsWork:
    """The module's INS state (created on first use, with ``module.config.ins`` noise figures)."""
    return module.work("ins", lambda: new_ins_work(getattr(getattr(module, "config", None), "ins", None)))


class HeightWork(WorkRecord):
    """HEIGHT_COMPENSATION's private state: ``in_stance`` (ZUPT held in its last loop),
    ``f_sum`` (the specific force summed over the current stance but its last blocks) and
    ``t_sum`` [s] (the time it covers), ``f_prev`` / ``f_block`` (the last complete block of
    SLOPE_TRIM_S and the one being summed, not yet in ``f_sum``), ``t_block`` [s] (the current
    block's time), ``t_stance`` [s] (the stance's duration so far) and ``t_moving`` [s] (the time
    without ZUPT since the last stance); ``step_dir`` (the last step's horizontal direction in
    the foot's angles: along and −across over its length), ``step_slope`` (its rise over its
    length, as the INS saw it before the slope measurement) and ``step_seen`` (a step of
    MIN_POSTURE_STEP_M or more is noted and its stance not yet judged); ``posture_n`` (the level
    stances THETA_INIT learnt from since the alignment, at most POSTURE_STANCES); ``last_angles``,
    ``last_slope`` and ``last_reading`` (the last stance of a noted step: its pitch and roll, the INS's
    slope of that step, and the foot's slope along it against THETA_INIT), ``before_reading`` (the
    foot's slope along its step at the stance before that one) and ``stances_seen`` (how many of the
    two there are since the alignment)."""

    FIELDS = (("in_stance", np.bool_, (1,)), ("f_sum", np.float32, (3,)), ("t_sum", np.float32, (1,)),
              ("f_prev", np.float32, (3,)), ("t_prev", np.float32, (1,)), ("f_block", np.float32, (3,)),
              ("t_block", np.float32, (1,)),
              ("t_stance", np.float32, (1,)), ("t_moving", np.float32, (1,)),
              ("step_dir", np.float32, (2,)), ("step_slope", np.float32, (1,)), ("step_seen", np.bool_, (1,)),
              ("posture_n", np.float32, (1,)), ("last_angles", np.float32, (2,)),
              ("last_slope", np.float32, (1,)), ("last_reading", np.float32, (1,)),
              ("before_reading", np.float32, (1,)), ("stances_seen", np.int32, (1,)))

    def __repr__(self) -> str:
        return f"HeightWork(in_stance={bool(self.in_stance[0])}, t_stance={float(self.t_stance[0]):.3f} s)"


def height_work(module: Module) -> HeightWork:
    """The module's HEIGHT_COMPENSATION state (created on first use)."""
    return module.work("height", HeightWork)


# ---------------------------------------------------------------------------------------------
# kernels


def alignment_quaternion(f_mean: np.ndarray) -> np.ndarray:
    """Roll = atan2(−f̄y, −f̄z), pitch = atan2(f̄x, √(f̄y²+f̄z²)), yaw = 0 → q (float32); an
    f̄ that is not finite gives what IEEE arithmetic gives, without numpy's warnings."""
    with np.errstate(all="ignore"):
        roll = np.arctan2(-f_mean[1], -f_mean[2])
        pitch = np.arctan2(f_mean[0], np.sqrt(f_mean[1] * f_mean[1] + f_mean[2] * f_mean[2]))
        cr, sr = np.cos(roll * _HALF), np.sin(roll * _HALF)
        cp, sp = np.cos(pitch * _HALF), np.sin(pitch * _HALF)
        # q = q_z(0) ⊗ q_y(pitch) ⊗ q_x(roll)
        return np.array([sr * cp, cr * sp, -sr * sp, cr * cp], dtype=np.float32)


def foot_angles(f: np.ndarray) -> tuple:
    """Pitch atan2(f_x, √(f_y²+f_z²)) and roll atan2(−f_y, −f_z) of a specific force at rest
    (the alignment's formulas; two float32)."""
    pitch = _atan2f(f[0], np.sqrt(f[1] * f[1] + f[2] * f[2]))
    roll = _atan2f(-f[1], -f[2])
    return pitch, roll


def initial_alignment(f: np.ndarray, zupt: bool, w: InsWork, pos: np.ndarray, vel: np.ndarray,
                      quat: np.ndarray, p45: np.ndarray, theta_init: np.ndarray,
                      theta_ground: np.ndarray) -> bool:
    """INITIAL_ALIGNMENT: average f over ALIGNMENT_SAMPLES consecutive ZUPT samples.

    Motion restarts the count. When the count is complete: attitude from the
    mean specific force (yaw 0), p = v = 0, P = diag(σ²_p0, σ²_v0, σ²_θ0);
    THETA_INIT = (pitch, roll) of the mean specific force (:func:`foot_angles`: the
    foot standing on level ground), THETA_GROUND = 0, the swing timer 0; returns True
    (INIT_DONE).
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
    pitch, roll = foot_angles(f_mean)
    theta_init[0] = pitch
    theta_init[1] = roll
    theta_ground[:] = _0
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
    w.t_swing[0] = _0
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


def time_update(f_n: np.ndarray, dt: np.float32, zaru: bool, p45: np.ndarray, pm: np.ndarray,
                noise: np.ndarray) -> None:
    """TIME_UPDATE: P ← F P Fᵀ + Q, F = I + [[0, I, 0], [0, 0, −[f_n×]], [0, 0, 0]]·dt,
    Q = dt·T₀·diag(0, σ²_acc I, σ²_gyro I) with *noise* = [σ_acc, σ_gyro, σ_zupt, T₀]
    (:class:`~firmware_sim.nav.config.InsNoise`) — dt²·diag(…) at the figures' own rate (the
    module's: 1 kHz), the same noise per second at any other loop rate. While ZARU position
    and yaw do not grow (no δp' = δv coupling, no yaw noise)."""
    unpack_p(p45, pm)
    fm = np.eye(9, dtype=np.float32)
    if not zaru:
        fm[0, 3] = fm[1, 4] = fm[2, 5] = dt
    fm[3:6, 6:9] = -_skew(f_n) * dt
    pm = _mm(_mm(fm, pm), fm.T)
    dt2 = dt * noise[3]  # = dt² at the figures' own rate (see nav_config.InsNoise)
    qa = dt2 * noise[0] * noise[0]
    qg = dt2 * noise[1] * noise[1]
    pm[3, 3] += qa
    pm[4, 4] += qa
    pm[5, 5] += qa
    pm[6, 6] += qg
    pm[7, 7] += qg
    if not zaru:
        pm[8, 8] += qg
    pack_p(pm, p45)


_EYE3 = np.eye(3, dtype=np.float32)


def zupt_update(pos: np.ndarray, vel: np.ndarray, quat: np.ndarray, p45: np.ndarray, pm: np.ndarray,
                dt: np.float32, noise: np.ndarray) -> None:
    """ZUPT_UPDATE: pseudo-measurement v = 0 (H = [0 I 0], R = σ²_zupt·(T₀/dt)·I, *noise* as
    :func:`time_update`'s); correct p, v, q; P ← P − K H P. R is σ²_zupt at the figures' own rate."""
    unpack_p(p45, pm)
    ph = pm[:, 3:6]  # P Hᵀ (9×3)
    k = _mm(ph, inv3_sym(pm[3:6, 3:6] + _EYE3 * (noise[2] * noise[2]) * (noise[3] / dt)))
    dx = _mv(k, vel)  # estimated error of [p, v, θ] (estimate minus truth)
    pos[:] = pos - dx[0:3]
    vel[:] = vel - dx[3:6]
    dq = np.array([-dx[6] * _HALF, -dx[7] * _HALF, -dx[8] * _HALF, _1], dtype=np.float32)
    quat[:] = _normalise(quat_mul(_normalise(dq), quat))
    pm = pm - _mm(k, pm[3:6, :])
    pack_p(pm, p45)


def stepwise_reset(zupt: bool, dt: np.float32, w: InsWork, pos: np.ndarray, quat: np.ndarray,
                   p45: np.ndarray, dx_out: np.ndarray, dp_out: np.ndarray, swing_out: np.ndarray) -> bool:
    """STEPWISE_SYSTEM_RESET; returns True in the cycle of a reset (FILTER_RESET_FLAG).

    Pending when P[24] = var(v_x) < 1e-4 and more than 0.75 s since the last
    reset; a pending reset happens at the end of the stance (ZUPT false) or
    after 0.25 s pending. On reset: DX = [p, yaw], DP = the (p, yaw) covariance
    (10 numbers), p ← 0, yaw ← 0 (roll, pitch kept), every covariance term of
    position and yaw ← 0; SWING_TIME (``swing_out[0]``) = the time without ZUPT
    since the last reset (every call counts its dt while ZUPT is false, this one's too).
    """
    if not zupt:
        w.t_swing[0] = w.t_swing[0] + dt
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
    swing_out[0] = w.t_swing[0]
    w.t_swing[0] = _0
    w.t_since_reset[0] = _0
    w.t_pending[0] = _0
    w.pending[0] = False
    return True


_R_SLOPE = cfg.SIGMA_SLOPE_HEIGHT * cfg.SIGMA_SLOPE_HEIGHT


def slope_height_update(pos: np.ndarray, vel: np.ndarray, quat: np.ndarray, p45: np.ndarray, pm: np.ndarray,
                        theta_ground: np.ndarray) -> None:
    """The slope measurement of HEIGHT_COMPENSATION: the step so far (p, since the last reset)
    lies on the ground of slope THETA_GROUND (along, across the foot).

    With ψ the heading, along = p_x cos ψ + p_y sin ψ and across = p_y cos ψ − p_x sin ψ, the
    pseudo-measurement h = p_z + tan θ·along − tan φ·across is 0 (z down: forward on a nose-up
    slope climbs); H = [tan θ cos ψ + tan φ sin ψ, tan θ sin ψ − tan φ cos ψ, 1, 0…], R = σ²_slope.
    Skipped when |h| > SLOPE_GATE_M (a stair) or h is no number; else K = P Hᵀ/S, p, v and q
    corrected as ZUPT_UPDATE corrects them, P ← P − K (H P).
    """
    r = quat_to_rot(quat)
    yaw = rot_to_yaw(r)
    c, s = _cosf(yaw), _sinf(yaw)
    t_along, t_across = _tanf(theta_ground[0]), _tanf(theta_ground[1])
    along = pos[0] * c + pos[1] * s
    across = pos[1] * c - pos[0] * s
    innovation = pos[2] + t_along * along - t_across * across
    if not abs(innovation) <= cfg.SLOPE_GATE_M:
        return
    h = np.zeros(9, dtype=np.float32)
    h[0] = t_along * c + t_across * s
    h[1] = t_along * s - t_across * c
    h[2] = _1
    unpack_p(p45, pm)
    ph = _mv(pm, h)  # P Hᵀ (= (H P)ᵀ: P is symmetric)
    hph = h[0] * ph[0]
    for i in range(1, 9):
        hph = hph + h[i] * ph[i]
    k = ph / (hph + _R_SLOPE)
    dx = k * innovation  # estimated error of [p, v, θ]
    pos[:] = pos - dx[0:3]
    vel[:] = vel - dx[3:6]
    dq = np.array([-dx[6] * _HALF, -dx[7] * _HALF, -dx[8] * _HALF, _1], dtype=np.float32)
    quat[:] = _normalise(quat_mul(_normalise(dq), quat))
    updated = pm - _mm(k.reshape(9, 1), ph.reshape(1, 9))
    pack_p(updated, p45)


def note_step(pos: np.ndarray, quat: np.ndarray, w: HeightWork) -> None:
    """The step that ends at this stance, as the INS tracked it (before the slope measurement):
    its direction in the foot's angles and its slope, for :func:`learn_posture`; noted only for a
    step of MIN_POSTURE_STEP_M or more (a shorter one's slope is mostly the INS's noise)."""
    yaw = rot_to_yaw(quat_to_rot(quat))
    c, s = _cosf(yaw), _sinf(yaw)
    along = pos[0] * c + pos[1] * s
    across = pos[1] * c - pos[0] * s
    length = np.sqrt(along * along + across * across)
    if length >= cfg.MIN_POSTURE_STEP_M:
        w.step_dir[0] = along / length
        w.step_dir[1] = -across / length
        w.step_slope[0] = -pos[2] / length
        w.step_seen[0] = True


def learn_posture(w: HeightWork, pitch: np.float32, roll: np.float32, theta_init: np.ndarray) -> None:
    """THETA_INIT learns the foot's walking posture from level stances: it moves 1/n of the way to a
    level stance's pitch and roll (n the level stances since the alignment, at most POSTURE_STANCES),
    so that level ground reads level however the foot stands while walking.

    Called at each stance that ends a noted step, it judges the stance *before* this one: level when
    the INS's own slope of the step to it is strictly nearer 0 than to the slopes the foot read
    (against THETA_INIT) at the stances either side of it — on a ramp the INS climbs as the foot
    reads, a posture the foot reads alone — and its own reading is at most MAX_POSTURE. A stance's
    own reading never decides whether it is learnt: else THETA_INIT would be the mean of the stances
    whose reading lay away from the INS's slope, a subset their own noise chose, off the foot's mean.
    """
    d0, d1 = w.step_dir[0], w.step_dir[1]
    reading = d0 * _tanf(pitch - theta_init[0]) + d1 * _tanf(roll - theta_init[1])
    if w.stances_seen[0] == 2:
        last_slope = w.last_slope[0]
        beside = abs(last_slope) < abs(reading - last_slope) and \
            abs(last_slope) < abs(w.before_reading[0] - last_slope)
        last_pitch, last_roll = w.last_angles[0], w.last_angles[1]
        off = d0 * (last_pitch - theta_init[0]) + d1 * (last_roll - theta_init[1])
        if beside and abs(off) <= cfg.MAX_POSTURE:
            if w.posture_n[0] < cfg.POSTURE_STANCES:
                w.posture_n[0] = w.posture_n[0] + _1
            gain = _1 / w.posture_n[0]
            theta_init[0] = theta_init[0] + gain * (last_pitch - theta_init[0])
            theta_init[1] = theta_init[1] + gain * (last_roll - theta_init[1])
    else:
        w.stances_seen[0] = w.stances_seen[0] + 1
    w.before_reading[0] = w.last_reading[0]
    w.last_reading[0] = reading
    w.last_angles[0] = pitch
    w.last_angles[1] = roll
    w.last_slope[0] = w.step_slope[0]


def height_compensation(zupt: bool, f: np.ndarray, dt: np.float32, w: HeightWork, pos: np.ndarray,
                        vel: np.ndarray, quat: np.ndarray, p45: np.ndarray, pm: np.ndarray,
                        theta_init: np.ndarray, theta_ground: np.ndarray) -> None:
    """HEIGHT_COMPENSATION: the ground's slope from the foot's angle in stance, and the step's
    height from the slope.

    At the first loop of a stance (ZUPT after a loop without) the slope measurement
    (:func:`slope_height_update`) is applied — if MIN_SLOPE_SWING_S or more passed without ZUPT
    before it (a shorter gap is a detector blip within the same stance, measured already) — and
    the stance's sums start; every ZUPT loop adds f and dt to the current block, and each block of
    SLOPE_TRIM_S goes into the stance's sum one block later, so that the stance's last one to two
    blocks never do: the detector holds ZUPT a few tens of ms into the push-off, when the foot no
    longer lies flat. At the first loop after the stance, if the sum covers MIN_SLOPE_STANCE_S or
    more, the foot's pitch and roll of the summed f minus THETA_INIT is the slope seen in this
    stance, and THETA_GROUND moves SLOPE_LOWPASS of the way to it — unless either is steeper than
    MAX_SLOPE (the foot did not lie flat on walkable ground, e.g. it turned on its toes).
    """
    if zupt:
        if not w.in_stance[0]:
            w.in_stance[0] = True
            if w.t_moving[0] >= cfg.MIN_SLOPE_SWING_S:
                note_step(pos, quat, w)
                slope_height_update(pos, vel, quat, p45, pm, theta_ground)
            start_stance(w)
        w.f_block[:] = w.f_block + f
        w.t_block[0] = w.t_block[0] + dt
        w.t_stance[0] = w.t_stance[0] + dt
        if w.t_block[0] >= cfg.SLOPE_TRIM_S:
            w.f_sum[:] = w.f_sum + w.f_prev
            w.t_sum[0] = w.t_sum[0] + w.t_prev[0]
            if w.t_stance[0] > w.t_block[0]:
                w.f_prev[:] = w.f_block
                w.t_prev[0] = w.t_block[0]
            else:  # the stance's first block: the foot is still settling from its landing
                w.f_prev[:] = _0
                w.t_prev[0] = _0
            w.f_block[:] = _0
            w.t_block[0] = _0
        return
    w.t_moving[0] = w.t_moving[0] + dt
    if w.in_stance[0]:
        w.in_stance[0] = False
        if w.t_sum[0] >= cfg.MIN_SLOPE_STANCE_S:
            pitch, roll = foot_angles(w.f_sum)
            if w.step_seen[0]:
                w.step_seen[0] = False
                learn_posture(w, pitch, roll, theta_init)
            slope, side = pitch - theta_init[0], roll - theta_init[1]
            if abs(slope) <= cfg.MAX_SLOPE and abs(side) <= cfg.MAX_SLOPE:
                alpha = cfg.SLOPE_LOWPASS
                theta_ground[0] = theta_ground[0] + alpha * (slope - theta_ground[0])
                theta_ground[1] = theta_ground[1] + alpha * (side - theta_ground[1])


# ---------------------------------------------------------------------------------------------
# processing functions


@processing_function(ProcId.FRONTEND_INITIAL_ALIGNMENT, cycles=900)
def frontend_initial_alignment(module: Module) -> None:
    """0x23: initial alignment over consecutive stationary samples; sets INIT_DONE."""
    with np.errstate(all="ignore"):  # IEEE results, as on the µC's FPU
        mem = module.memory
        if initial_alignment(mem[StateId.U_K][0:3], bool(mem[StateId.ZUPT]), ins_work(module),
                             mem[StateId.POSITION], mem[StateId.VELOCITY], mem[StateId.QUATERNION],
                             mem[StateId.P], mem[StateId.THETA_INIT], mem[StateId.THETA_GROUND]):
            mem[StateId.INIT_DONE][...] = True
            clear_stance(height_work(module))


def clear_stance(w: HeightWork) -> None:
    """A new alignment: HEIGHT_COMPENSATION starts with no stance (its work cleared)."""
    w.in_stance[0] = False
    w.step_seen[0] = False
    w.stances_seen[0] = 0
    w.posture_n[0] = _0
    start_stance(w)


def start_stance(w: HeightWork) -> None:
    """A stance's sums start from zero, and so does the time without ZUPT."""
    w.f_sum[:] = _0
    w.t_sum[0] = _0
    w.f_prev[:] = _0
    w.t_prev[0] = _0
    w.f_block[:] = _0
    w.t_block[0] = _0
    w.t_stance[0] = _0
    w.t_moving[0] = _0


@processing_function(ProcId.MECHANIZATION, cycles=7000)
def ins_mechanization(module: Module) -> None:
    """0x20: strapdown mechanization of position, velocity and attitude."""
    with np.errstate(all="ignore"):  # IEEE results, as on the µC's FPU
        mem = module.memory
        mechanization(mem[StateId.U_K], mem[StateId.DT][()], bool(mem[StateId.ZARU]), mem[StateId.POSITION],
                      mem[StateId.VELOCITY], mem[StateId.QUATERNION], ins_work(module).f_n)


@processing_function(ProcId.TIME_UPDATE, cycles=26000)
def ins_time_update(module: Module) -> None:
    """0x21: covariance propagation."""
    with np.errstate(all="ignore"):  # IEEE results, as on the µC's FPU
        mem = module.memory
        w = ins_work(module)
        time_update(w.f_n, mem[StateId.DT][()], bool(mem[StateId.ZARU]), mem[StateId.P], w.p_full, w.noise)


@processing_function(ProcId.ZUPT_UPDATE, cycles=15000)
def ins_zupt_update(module: Module) -> None:
    """0x22: zero-velocity measurement update while ZUPT."""
    with np.errstate(all="ignore"):  # IEEE results, as on the µC's FPU
        mem = module.memory
        if bool(mem[StateId.ZUPT]):
            w = ins_work(module)
            zupt_update(mem[StateId.POSITION], mem[StateId.VELOCITY], mem[StateId.QUATERNION], mem[StateId.P],
                        w.p_full, mem[StateId.DT][()], w.noise)


@processing_function(ProcId.STEPWISE_SYSTEM_RESET, cycles=2500)
def ins_stepwise_system_reset(module: Module) -> None:
    """0x24: end a step: hand DX/DP to the host, reset position and heading."""
    with np.errstate(all="ignore"):  # IEEE results, as on the µC's FPU
        mem = module.memory
        flag = stepwise_reset(bool(mem[StateId.ZUPT]), mem[StateId.DT][()], ins_work(module),
                              mem[StateId.POSITION], mem[StateId.QUATERNION], mem[StateId.P],
                              mem[StateId.DX], mem[StateId.DP], mem[StateId.SWING_TIME].reshape(1))
        mem[StateId.FILTER_RESET_FLAG][...] = flag
        if flag:
            mem[StateId.STEP_COUNTER][...] = (int(mem[StateId.STEP_COUNTER]) + 1) & 0xFFFF


@processing_function(ProcId.HEIGHT_COMPENSATION, cycles=3000)
def ins_height_compensation(module: Module) -> None:
    """0x25 (an emulator extension): the step's height from the ground's slope, a measurement in
    the INS's filter once per stance; learns the slope (THETA_GROUND) from the foot's angle."""
    with np.errstate(all="ignore"):  # IEEE results, as on the µC's FPU
        mem = module.memory
        height_compensation(bool(mem[StateId.ZUPT]), mem[StateId.U_K][0:3], mem[StateId.DT][()],
                            height_work(module), mem[StateId.POSITION], mem[StateId.VELOCITY],
                            mem[StateId.QUATERNION], mem[StateId.P], ins_work(module).p_full,
                            mem[StateId.THETA_INIT], mem[StateId.THETA_GROUND])
