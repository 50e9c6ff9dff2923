"""The float32 INS compiled: :mod:`~firmware_sim.nav.ins`'s array-level functions (and
:mod:`~firmware_sim.nav.ins_arithmetic`'s helpers) as kernels of the same names and arguments, with
the same results bit for bit (NaN payloads and signed zeros included).

Compiled as written (:func:`~firmware_sim.nav.jit.compiled_reference`), the helpers they call
going to kernels: ``initial_alignment`` and ``stepwise_reset`` (a few arrays made per call, only
at the end of an alignment or of a step), ``height_compensation`` and its
``slope_height_update`` (arrays made once per stance), ``foot_angles``, ``quat_to_rot``,
``quat_mul``, ``rot_to_yaw``, ``_normalise``, ``_mv``, ``_mm``, the scalar helpers ``rot_rows``,
``quat_product``, ``inv3_sym_upper``, and ``_sinf``, ``_cosf``, ``_tanf``, ``_atan2f`` — float32
of the C library's double sin, cos, tan and atan2, with the reference's answer on ±0, ±inf and NaN.

Written again as loops over scalars, in the reference's order of operations, so that a sample
makes no array: ``mechanization``, ``time_update``, ``zupt_update``, ``unpack_p``, ``pack_p``
(the reference indexes with two index arrays, which numba cannot). ``alignment_quaternion``
calls the reference from compiled code (numpy's float32 arctan2, sin and cos are numpy's own
code, which a compiled kernel cannot reproduce on every machine; it runs once per alignment).

``time_update`` multiplies by F only where F can be other than +0 (see :func:`time_update`).
Every product and sum is rounded to float32 as in the reference; no multiply-add is fused.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from . import ins
from . import ins_arithmetic as arith
from .jit import compiled_reference, kernel, objmode

__all__ = ["clear_stance", "foot_angles", "height_compensation", "initial_alignment", "mechanization",
           "pack_p", "slope_height_update", "start_stance", "stepwise_reset", "time_update", "unpack_p",
           "zupt_update"]

_0 = np.float32(0.0)
_1 = np.float32(1.0)
_HALF = np.float32(0.5)
_GRAVITY_N = ins._GRAVITY_N
#: Row and column of each element of P's 45-element triangle, and each (row, column)'s element.
_ROW = np.ascontiguousarray(arith.P_IU[0], dtype=np.int64)
_COL = np.ascontiguousarray(arith.P_IU[1], dtype=np.int64)
_TRI = np.zeros((9, 9), dtype=np.int64)
_TRI[_ROW, _COL] = _TRI[_COL, _ROW] = np.arange(45)
_DIAG = np.ascontiguousarray(np.diag(_TRI))  # the diagonal's elements

_double = compiled_reference(arith._double)
_sinf = compiled_reference(arith._sinf, _double=_double)
_cosf = compiled_reference(arith._cosf, _double=_double)
_atan2f = compiled_reference(arith._atan2f, _double=_double)
_tanf = compiled_reference(arith._tanf, _double=_double)
_mv = compiled_reference(arith._mv)
_mm = compiled_reference(arith._mm)
_normalise = compiled_reference(arith._normalise)
rot_rows = compiled_reference(arith.rot_rows)
quat_product = compiled_reference(arith.quat_product)
inv3_sym_upper = compiled_reference(arith.inv3_sym_upper)
quat_to_rot = compiled_reference(arith.quat_to_rot, rot_rows=rot_rows)
quat_mul = compiled_reference(arith.quat_mul, quat_product=quat_product)
rot_to_yaw = compiled_reference(arith.rot_to_yaw, _atan2f=_atan2f)


@kernel
def _unit(q):
    """q/‖q‖ of four float32 as a tuple (:func:`ins_arithmetic._normalise`'s arithmetic)."""
    n = np.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    return q[0] / n, q[1] / n, q[2] / n, q[3] / n


@kernel
def unpack_p(p45, out):
    """Expand P's 45-element upper triangle into the symmetric 9×9 ``out``."""
    for e in range(45):
        out[_ROW[e], _COL[e]] = p45[e]
        out[_COL[e], _ROW[e]] = p45[e]
    return out


@kernel
def pack_p(pm, p45):
    """Store the upper triangle of the 9×9 ``pm`` into P's 45 elements."""
    for e in range(45):
        p45[e] = pm[_ROW[e], _COL[e]]


@functools.partial(kernel, nogil=False)
def alignment_quaternion(f_mean):
    """The alignment's attitude from the mean specific force: the reference, from object mode."""
    with objmode(q="float32[::1]"):
        q = ins.alignment_quaternion(f_mean)
    return q


foot_angles = compiled_reference(ins.foot_angles, _atan2f=_atan2f)
initial_alignment = compiled_reference(ins.initial_alignment, alignment_quaternion=alignment_quaternion,
                                       pack_p=pack_p, foot_angles=foot_angles)
stepwise_reset = compiled_reference(ins.stepwise_reset, quat_to_rot=quat_to_rot, rot_to_yaw=rot_to_yaw,
                                    quat_mul=quat_mul, _normalise=_normalise, _sinf=_sinf, _cosf=_cosf)
slope_height_update = compiled_reference(ins.slope_height_update, quat_to_rot=quat_to_rot,
                                         rot_to_yaw=rot_to_yaw, _cosf=_cosf, _sinf=_sinf, _tanf=_tanf,
                                         unpack_p=unpack_p, _mv=_mv, _normalise=_normalise, quat_mul=quat_mul,
                                         _mm=_mm, pack_p=pack_p)
start_stance = compiled_reference(ins.start_stance)
clear_stance = compiled_reference(ins.clear_stance, start_stance=start_stance)
note_step = compiled_reference(ins.note_step, quat_to_rot=quat_to_rot, rot_to_yaw=rot_to_yaw, _cosf=_cosf,
                               _sinf=_sinf)
learn_posture = compiled_reference(ins.learn_posture, _tanf=_tanf)
height_compensation = compiled_reference(ins.height_compensation, slope_height_update=slope_height_update,
                                         foot_angles=foot_angles, start_stance=start_stance,
                                         note_step=note_step, learn_posture=learn_posture)


@kernel
def mechanization(u_k, dt, zaru, pos, vel, quat, f_n):
    """MECHANIZATION: a_n = R(q) f + [0, 0, g]; p += v·dt (not while ZARU); v += a_n·dt;
    q ← q ⊗ exp(ω·dt/2), renormalised; while ZARU ω loses its vertical component first.
    ``f_n`` receives R(q) f for TIME_UPDATE."""
    r = rot_rows(quat)
    o0, o1, o2 = u_k[3], u_k[4], u_k[5]
    if zaru:
        up = r[2]  # the navigation z axis in body coordinates
        proj = up[0] * o0 + up[1] * o1 + up[2] * o2
        o0, o1, o2 = o0 - proj * up[0], o1 - proj * up[1], o2 - proj * up[2]
    for i in range(3):
        f_n[i] = r[i][0] * u_k[0] + r[i][1] * u_k[1] + r[i][2] * u_k[2]
    if not zaru:
        for i in range(3):
            pos[i] = pos[i] + vel[i] * dt
    for i in range(3):
        vel[i] = vel[i] + (f_n[i] + _GRAVITY_N[i]) * dt
    t0, t1, t2 = o0 * dt, o1 * dt, o2 * dt
    angle = np.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
    dq = (_0, _0, _0, _1)
    if angle > _0:
        s = _sinf(angle * _HALF) / angle
        dq = (t0 * s, t1 * s, t2 * s, _cosf(angle * _HALF))
    q = _unit(quat_product(quat, dq))
    for i in range(4):
        quat[i] = q[i]


# ------------------------------------------------------------------------------------------------
# TIME_UPDATE: P ← F P Fᵀ + Q with F sparse

#: Row i of F can be other than +0 only in the columns _F_TERMS[i] (ascending; −1: no more).
_F_TERMS = np.array([[0, 3, -1, -1], [1, 4, -1, -1], [2, 5, -1, -1], [3, 6, 7, 8], [4, 6, 7, 8],
                     [5, 6, 7, 8], [6, -1, -1, -1], [7, -1, -1, -1], [8, -1, -1, -1]], dtype=np.int64)


@kernel
def _f_terms(f_n, dt, zaru):
    """F at _F_TERMS row by row (+0 after a row's terms), as the reference builds F: the identity,
    dt on δp–δv unless ZARU, −[f_n×]·dt on δv–δθ (its diagonal −0·dt)."""
    d = _0 if zaru else dt
    z = -_0 * dt
    return ((_1, d, _0, _0), (_1, d, _0, _0), (_1, d, _0, _0),
            (_1, z, f_n[2] * dt, -f_n[1] * dt), (_1, -f_n[2] * dt, z, f_n[0] * dt),
            (_1, f_n[1] * dt, -f_n[0] * dt, z), (_1, _0, _0, _0), (_1, _0, _0, _0), (_1, _0, _0, _0))


@kernel
def _f_at(f, i, t):
    """F[i, t] from _f_terms' *f*."""
    for u in range(4):
        if _F_TERMS[i, u] == t:
            return f[i][u]
    return _0


@kernel
def _negative_zero(x):
    return x == 0 and math.copysign(1.0, x) < 0


@kernel
def _fp_in_full(f, p45, i, j):
    """(F P)[i, j]: the nine products F[i,t]·P[t,j] summed left to right."""
    s = _f_at(f, i, 0) * p45[_TRI[0, j]]
    for t in range(1, 9):
        s = s + _f_at(f, i, t) * p45[_TRI[t, j]]
    return s


@kernel
def _fpft_in_full(f, fp, i, j):
    """(FP Fᵀ)[i, j]: the nine products FP[i,t]·F[j,t] summed left to right."""
    s = fp[i, 0] * _f_at(f, j, 0)
    for t in range(1, 9):
        s = s + fp[i, t] * _f_at(f, j, t)
    return s


@kernel
def _finite_terms(f):
    for i in range(9):
        for u in range(4):
            if not f[i][u] - f[i][u] == 0:
                return False
    return True


@kernel
def time_update(f_n, dt, zaru, p45, pm, noise):
    """TIME_UPDATE: P ← F P Fᵀ + Q (see :func:`ins.time_update`), F's products summed only
    where F can be other than +0, left to right as the reference sums all nine.

    Exact: with finite F and P the other products are ±0, which change no non-zero partial
    sum, so the short sum has the full one's value — and its sign when it is zero, unless it
    is −0: the full sum is −0 only if all nine products are −0 (x + y is −0 only for −0 + −0),
    so a −0 is summed again in full, as is everything when F or P is not finite. ``pm`` is
    scratch: it is left holding F P (the reference leaves P there; neither is a result).
    """
    f = _f_terms(f_n, dt, zaru)
    dense = not _finite_terms(f)
    for e in range(45):
        dense = dense or not p45[e] - p45[e] == 0
    fp_finite = True
    for i in range(9):  # F P, row by row
        a0, a1, a2, a3 = f[i]
        t0, t1, t2, t3 = _F_TERMS[i, 0], _F_TERMS[i, 1], _F_TERMS[i, 2], _F_TERMS[i, 3]
        for j in range(9):
            s = a0 * p45[_TRI[t0, j]]
            if t1 >= 0:
                s = s + a1 * p45[_TRI[t1, j]]
            if t2 >= 0:
                s = s + a2 * p45[_TRI[t2, j]]
            if t3 >= 0:
                s = s + a3 * p45[_TRI[t3, j]]
            if dense or _negative_zero(s):
                s = _fp_in_full(f, p45, i, j)
            pm[i, j] = s
            fp_finite = fp_finite and s - s == 0
    dense = not (fp_finite and _finite_terms(f))
    for j in range(9):  # (F P) Fᵀ, the upper triangle column by column
        a0, a1, a2, a3 = f[j]
        t0, t1, t2, t3 = _F_TERMS[j, 0], _F_TERMS[j, 1], _F_TERMS[j, 2], _F_TERMS[j, 3]
        for i in range(j + 1):
            s = pm[i, t0] * a0
            if t1 >= 0:
                s = s + pm[i, t1] * a1
            if t2 >= 0:
                s = s + pm[i, t2] * a2
            if t3 >= 0:
                s = s + pm[i, t3] * a3
            if dense or _negative_zero(s):
                s = _fpft_in_full(f, pm, i, j)
            p45[_TRI[i, j]] = s
    dt2 = dt * noise[3]  # dt·T₀ (= dt² at the figures' own rate)
    qa = dt2 * noise[0] * noise[0]
    qg = dt2 * noise[1] * noise[1]
    for d in range(3, 9):
        if d < 6:
            p45[_DIAG[d]] += qa
        elif d < 8 or not zaru:
            p45[_DIAG[d]] += qg


@kernel
def zupt_update(pos, vel, quat, p45, pm, dt, noise):
    """ZUPT_UPDATE: pseudo-measurement v = 0, R = σ²_zupt·(T₀/dt)·I with *noise* = [σ_acc, σ_gyro,
    σ_zupt, T₀]; correct p, v, q; P ← P − K H P (see :func:`ins.zupt_update`), K one row at a time."""
    unpack_p(p45, pm)
    scale = noise[3] / dt
    r = noise[2] * noise[2] * scale  # R's diagonal
    z = _0 * scale  # R's off-diagonal: +0, as the reference's 0·scale
    i00, i01, i02, i11, i12, i22 = inv3_sym_upper(
        pm[3, 3] + r, pm[3, 4] + z, pm[3, 5] + z, pm[4, 4] + r, pm[4, 5] + z, pm[5, 5] + r)
    v0, v1, v2 = vel[0], vel[1], vel[2]
    e6 = e7 = e8 = _0  # the attitude error
    for a in range(9):
        # row a of K = P Hᵀ S⁻¹ and of the estimated error K v
        k0 = pm[a, 3] * i00 + pm[a, 4] * i01 + pm[a, 5] * i02
        k1 = pm[a, 3] * i01 + pm[a, 4] * i11 + pm[a, 5] * i12
        k2 = pm[a, 3] * i02 + pm[a, 4] * i12 + pm[a, 5] * i22
        dx = k0 * v0 + k1 * v1 + k2 * v2
        if a < 3:
            pos[a] = pos[a] - dx
        elif a < 6:
            vel[a - 3] = vel[a - 3] - dx
        elif a == 6:
            e6 = dx
        elif a == 7:
            e7 = dx
        else:
            e8 = dx
        for b in range(a, 9):
            p45[_TRI[a, b]] = pm[a, b] - (k0 * pm[3, b] + k1 * pm[4, b] + k2 * pm[5, b])
    q = _unit(quat_product(_unit((-e6 * _HALF, -e7 * _HALF, -e8 * _HALF, _1)), quat))
    for i in range(4):
        quat[i] = q[i]
