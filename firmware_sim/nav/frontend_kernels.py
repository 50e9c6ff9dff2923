"""The integer front end compiled: :mod:`~firmware_sim.nav.frontend`'s array-level functions as
kernels of the same names and arguments, with the same results bit for bit.

A function that numba compiles as it is written, with no array made per call, *is* its kernel
(:func:`~firmware_sim.nav.jit.compiled_reference`): ``statdet``, ``statistic_t1``, ``biasest``
(whose few temporaries exist only while ZARU holds), ``_i32``, ``_sat_u32``. The others are
written again as loops over scalars, in the reference's order of operations:

* ``preproc`` (the reference sums with ``einsum``) and ``convcomp`` (array temporaries every
  sample); ``_add_sample`` (array temporaries, four times a sample);
* ``isqrt64``, ``_sumsq3`` and ``statistic_t2``, where the reference's Python integers are
  unbounded: the sum of three squared int32 reaches 3·2^62, beyond int64, so it is a uint64
  here (the µC's 64-bit intermediate) and the root is taken of the uint64.

Every stored integer wraps like C's (``_i32``, ``& 0xFFFFFFFF``); intermediates are int64 and
cannot overflow for any int16 register, int32 state or uint32 sum.
"""

from __future__ import annotations

import math

import numpy as np

from . import config as cfg
from . import frontend
from .jit import compiled_reference, kernel

__all__ = ["biasest", "convcomp", "isqrt64", "preproc", "statdet", "statistic_t1", "statistic_t2"]

_M32 = 0xFFFFFFFF
_ACC_SCALE = cfg.ACC_SCALE
_GYRO_SCALE = cfg.GYRO_SCALE
_CPU_HZ = cfg.CPU_HZ
#: The largest root of a uint64 (so that r·r cannot wrap), and 1, as uint64.
_ROOT_MAX = np.uint64(0xFFFFFFFF)
_U1 = np.uint64(1)

_i32 = compiled_reference(frontend._i32)
_sat_u32 = compiled_reference(frontend._sat_u32)


@kernel
def isqrt64(x):
    """floor(√x) of a uint64, as int64 (:func:`frontend.isqrt64` walks the bits as the µC does;
    here the double root, corrected to the exact floor: a double has 53 bits)."""
    x = np.uint64(x)
    r = np.uint64(math.sqrt(np.float64(x)))
    if r > _ROOT_MAX:
        r = _ROOT_MAX
    while r * r > x:
        r -= _U1
    while r < _ROOT_MAX and (r + _U1) * (r + _U1) <= x:
        r += _U1
    return np.int64(r)


@kernel
def _sumsq3(v, off):
    """Σ v[off+i]² of three int32, as uint64 (up to 3·2^62)."""
    total = np.uint64(0)
    for i in range(3):
        a = np.int64(v[off + i])
        total += np.uint64(a * a)
    return total


@kernel
def _add_sample(ab, cd, s16, norm, sign, n):
    """Add (sign +1) or remove (−1) one buffered sample from a window's running sums, wrapping
    like C: ``ab[:n]`` int32, ``cd`` uint32 (low 16 bits of the two norms, then their high bits)."""
    for i in range(n):
        ab[i] = _i32(np.int64(ab[i]) + sign * np.int64(s16[i]))
    for k in range(4):
        part = np.int64(norm[k & 1])
        part = part >> 16 if k >= 2 else part & 0xFFFF
        cd[k] = (np.int64(cd[k]) + sign * part) & _M32


statistic_t1 = compiled_reference(frontend.statistic_t1, isqrt64=isqrt64, _sumsq3=_sumsq3, _sat_u32=_sat_u32)


#: T2's SR·(D/N − ‖B/N‖²) in int64 for any sums: ‖B‖² < 3·2^62, divided by N².
assert cfg.SR_Q * ((3 << 62) >> (2 * cfg.LOG2_N)) < 2 ** 63


@kernel
def statistic_t2(zaru_ab, zaru_cd, log2n, sr_q, sr_shift):
    """T2 = (C/N − ‖A/N‖²) + SR·(D/N − ‖B/N‖²) over the whole buffer (uint32, LSB_f²); for the
    detector's N and SR (checked above: no int64 can wrap, whatever the sums)."""
    c = (np.int64(zaru_cd[2]) << 16) + np.int64(zaru_cd[0])
    d = (np.int64(zaru_cd[3]) << 16) + np.int64(zaru_cd[1])
    shift = np.uint64(2 * log2n)
    var_f = (c >> log2n) - np.int64(_sumsq3(zaru_ab, 0) >> shift)
    var_g = (d >> log2n) - np.int64(_sumsq3(zaru_ab, 3) >> shift)
    return _sat_u32(var_f + ((sr_q * var_g) >> sr_shift))


statdet = compiled_reference(frontend.statdet, _add_sample=_add_sample, _sumsq3=_sumsq3,
                             statistic_t1=statistic_t1, statistic_t2=statistic_t2)


@kernel
def preproc(raw, cal, bias, u_new, u_k):
    """PREPROC: raw int16 (chips, 6) → U_NEW int32 (6,) and U_K float32 (6,); per sensor s and
    axis i the chips' three int16 × Q14 products summed in int64, ``>> 2``, bias subtracted."""
    for s in range(2):  # accelerometer, gyro
        for i in range(3):
            acc = np.int64(0)
            for chip in range(raw.shape[0]):
                for j in range(3):
                    acc += np.int64(cal[chip, s, i, j]) * np.int64(raw[chip, 3 * s + j])
            u_new[3 * s + i] = _i32(_i32(acc >> cfg.LOG2_NR_IMUS) - np.int64(bias[3 * s + i]))
    for i in range(3):
        u_k[i] = np.float32(u_new[i]) * _ACC_SCALE
        u_k[3 + i] = np.float32(u_new[3 + i]) * _GYRO_SCALE


biasest = compiled_reference(frontend.biasest)


@kernel
def convcomp(u_int_k, t_int_k, gyro_bias, t_prev, u_k, dt):
    """CONVCOMP: U_K = float32(U_INT_K)·scale − gyro bias; DT = float32(ΔT mod 2^32)/64e6."""
    for i in range(3):
        u_k[i] = np.float32(u_int_k[i]) * _ACC_SCALE
        u_k[3 + i] = np.float32(u_int_k[3 + i]) * _GYRO_SCALE - gyro_bias[i]
    dt[...] = np.float32((np.int64(t_int_k) - np.int64(t_prev[0])) & _M32) / _CPU_HZ
    t_prev[0] = t_int_k
