"""The INS's float32 arithmetic (firmware.md §4): R(q) and the Hamilton product of scalar-last
quaternions, the heading of a rotation, P's 45-element upper triangle and the cofactor inverse of a
symmetric 3×3, small matrix products in a fixed order, and sin, cos, tan and atan2 rounded from the
C library's double functions.

Every operation is single precision, the same bytes on every machine (no BLAS, no numpy float32
transcendental functions); :mod:`firmware_sim.nav.ins` is written in it, and
:mod:`firmware_sim.nav.ins_kernels` compiles these helpers as written (same names and arguments).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "F32",
    "P_IU",
    "quat_to_rot",
    "quat_mul",
    "quat_product",
    "rot_rows",
    "rot_to_yaw",
    "unpack_p",
    "pack_p",
    "inv3_sym",
    "inv3_sym_upper",
]

F32 = np.float32
_0 = F32(0.0)
_1 = F32(1.0)
_2 = F32(2.0)
_HALF = F32(0.5)

#: Row/column indices of the 45-element upper triangle of P, row by row.
P_IU = np.triu_indices(9)


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
    p = a * x  # every product a_ik·x_k, rounded to float32
    y = p[:, 0].copy()
    for k in range(1, a.shape[1]):
        y += p[:, k]
    return y


def _mm(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a @ b for small float32 matrices, in the order of :func:`_mv` (no BLAS)."""
    p = a[:, :, None] * b[None, :, :]  # every product a_ik·b_kj, rounded to float32
    c = p[:, 0, :].copy()
    for k in range(1, a.shape[1]):
        c += p[:, k, :]
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


def _tanf(x: np.float32) -> np.float32:
    """tan of a float32, rounded from the C library's double tan (as :func:`_sinf`)."""
    v = _double(x)
    return F32(v - v) if math.isinf(v) else F32(math.tan(v))


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

