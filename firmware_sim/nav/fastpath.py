"""Compiled (numba) path of the step-wise tracking sequence: the same bytes, faster.

The pure-Python processing functions (:mod:`firmware_sim.nav.inertial`,
:mod:`~firmware_sim.nav.frontend`, :mod:`~firmware_sim.nav.ins`, :mod:`~firmware_sim.mcu.sequence_control`)
are the reference. This module runs the tracking sequence of step-wise dead
reckoning (0x34) — READ_INERTIAL, PREPROC, STATDET, BIASEST, CONVCOMP,
STEPWISE_SYSTEM_RESET, MECHANIZATION, TIME_UPDATE, ZUPT_UPDATE, STATE_OUTPUT_IF —
as one compiled loop over the module's own live arrays (state memory and the
functions' work arrays), with the reference's arithmetic operation for
operation: int32/uint32 wrap like C with 64-bit intermediates, float32 stays
float32 (every product and sum rounded to single precision in the reference's
order, never fused), sin/cos/atan2 are the C library's double functions
rounded to float32 as in the reference. So the wire bytes are identical
(tests/tools/test_fastpath.py checks it on simulated walks and on the six
recordings).

Two entry points, used by :class:`~firmware_sim.mcu.module.Module` when the running
sequence is exactly that tracking sequence with the reference functions
registered:

* :meth:`FastNav.sequence_tick` — the process sequence of one loop (any tick):
  READ_INERTIAL and STATE_OUTPUT_IF run in Python (any sensor source, the
  conditional output), the eight numeric slots compiled.
* :meth:`FastNav.run_quiet` — whole loops while nothing but the sequence
  happens (nothing received, no output due, a waiting packet not due for a
  resend, no byte in flight reaching the µC or the host; :meth:`FastNav.quiet_ticks`): up to
  the loop of the next step reset, reading the sensor block directly; the
  clock, interrupt counter, GP_DT and PS_DT advance exactly as loop by loop.

Selection: numba importable and ``OPENSHOE_PURE`` not set to 1 (:func:`available`);
``ModuleConfig.compiled`` forces either path. numba is the optional ``fast``
extra; without it everything runs in pure Python, unchanged.
"""

from __future__ import annotations

import math
import os
from typing import TYPE_CHECKING, Any

import numpy as np

from firmware_sim.mcu import sequence_control as utility
from firmware_sim.mcu.imu_bus import imu_block
from firmware_sim.mcu.memory import Arena, StateMemory
from protocol.ids import MAX_IMU_IDS, NR_IMUS, ProcId, StateId
from protocol.states import STATES

from . import config as cfg
from . import frontend, inertial, ins

if TYPE_CHECKING:  # pragma: no cover
    from firmware_sim.mcu.module import Module

__all__ = ["ALIGNMENT_SLOTS", "TRACKING_SLOTS", "FastNav", "available", "numba_version", "reason_unavailable"]

P = ProcId
#: The running slots of step-wise dead reckoning after the initial alignment.
TRACKING_SLOTS = [P.READ_INERTIAL, P.FRONTEND_PREPROC, P.FRONTEND_STATDET, P.FRONTEND_BIASEST,
                  P.FRONTEND_CONVCOMP, P.STEPWISE_SYSTEM_RESET, P.MECHANIZATION, P.TIME_UPDATE,
                  P.ZUPT_UPDATE, P.STATE_OUTPUT_IF, 0, 0]
TRACKING_SLOTS = [int(p) for p in TRACKING_SLOTS]
#: The running slots of both INS modes until the initial alignment is done.
ALIGNMENT_SLOTS = [int(p) for p in (P.READ_INERTIAL, P.FRONTEND_PREPROC, P.FRONTEND_STATDET,
                                    P.FRONTEND_BIASEST, P.FRONTEND_CONVCOMP,
                                    P.FRONTEND_INITIAL_ALIGNMENT)] + [0] * 5 + [int(P.RESTORE_PROC_SEQU_IF)]
#: Kinds of running sequence the compiled path knows (FastNav.kind).
TRACKING, ALIGNMENT = 1, 2
#: The reference functions the compiled loop stands for (a re-registered id disables it).
_REFERENCE = {
    P.READ_INERTIAL: inertial.read_inertial,
    P.FRONTEND_PREPROC: frontend.frontend_preproc,
    P.FRONTEND_STATDET: frontend.frontend_statdet,
    P.FRONTEND_BIASEST: frontend.frontend_biasest,
    P.FRONTEND_CONVCOMP: frontend.frontend_convcomp,
    P.STEPWISE_SYSTEM_RESET: ins.ins_stepwise_system_reset,
    P.MECHANIZATION: ins.ins_mechanization,
    P.TIME_UPDATE: ins.ins_time_update,
    P.ZUPT_UPDATE: ins.ins_zupt_update,
    P.STATE_OUTPUT_IF: utility.state_output_if,
    P.FRONTEND_INITIAL_ALIGNMENT: ins.frontend_initial_alignment,
    P.RESTORE_PROC_SEQU_IF: utility.restore_proc_sequ_if,
}
#: States the compiled loop writes (a conditional output watching one of them ends a quiet run).
_WRITTEN = {StateId.IMU_TS, StateId.U_NEW, StateId.U_K, StateId.U_INT_K, StateId.T_INT_K, StateId.DT,
            StateId.T1S2F, StateId.T2S2F, StateId.ZUPT, StateId.ZARU, StateId.POSITION,
            StateId.VELOCITY, StateId.QUATERNION, StateId.P, StateId.DX, StateId.DP,
            StateId.STEP_COUNTER, StateId.FILTER_RESET_FLAG, StateId.INTERRUPT_COUNTER, StateId.GP_DT}

_U32 = 0xFFFFFFFF


def pure_requested() -> bool:
    """Whether the user asked for the pure-Python path (``OPENSHOE_PURE=1``)."""
    return os.environ.get("OPENSHOE_PURE", "") == "1"


try:  # numba is optional (the `fast` extra)
    if pure_requested():
        raise ImportError("OPENSHOE_PURE=1")
    import numba
    from numba import njit

    _NUMBA_ERROR = ""
except ImportError as _e:  # pragma: no cover - depends on the environment
    numba = None
    _NUMBA_ERROR = str(_e) or "numba is not installed"


def available() -> bool:
    """Whether the compiled path can be used (numba importable, OPENSHOE_PURE not 1, not disabled)."""
    return numba is not None and not _disabled


def reason_unavailable() -> str:
    return "" if available() else (_disabled or _NUMBA_ERROR)


_disabled = ""  #: why the compiled path was switched off in this process ("" = it was not)


def disable(reason: str) -> None:
    """Stop offering the compiled path in this process (e.g. its compile failed)."""
    global _disabled
    _disabled = reason or "disabled"


def numba_version() -> str | None:
    return None if numba is None else numba.__version__


# ---------------------------------------------------------------------------------------------
# the kernels (plain Python over arrays; compiled below when numba is present)

_N = cfg.N
_NM = cfg.N - 1
_HALF_N = cfg.N >> 1
_HALF_M = cfg.M >> 1
_LOG2_M = cfg.LOG2_M
_LOG2_N = cfg.LOG2_N
_G_RED = cfg.G_RED
_SR_Q = cfg.SR_Q
_SR_SHIFT = cfg.SR_SHIFT
_RED_F = cfg.RED_SHIFT_F
_RED_G = cfg.RED_SHIFT_G
_LOG2_IMUS = cfg.LOG2_NR_IMUS
_ACC_SCALE = np.float32(cfg.ACC_SCALE)
_GYRO_SCALE = np.float32(cfg.GYRO_SCALE)
_CPU_HZ = np.float32(cfg.CPU_HZ)
_BIAS_Q = np.float32(cfg.BIAS_Q)
_BIAS_R = np.float32(cfg.BIAS_R)
_GRAVITY = np.float32(cfg.GRAVITY)
_SIG_ACC = np.float32(cfg.SIGMA_ACC)
_SIG_GYRO = np.float32(cfg.SIGMA_GYRO)
_SIG_ZUPT = np.float32(cfg.SIGMA_ZUPT)
_RESET_TH = np.float32(cfg.RESET_COV_THRESHOLD)
_MIN_T_RESET = np.float32(cfg.MIN_TIME_BETWEEN_RESETS)
_MAX_T_PENDING = np.float32(cfg.MAX_TIME_RESET_PENDING)
#: The module's loop period T₀ the noise densities refer to (Q = dt·T₀·σ², R = σ²_zupt·T₀/dt).
_T0 = np.float32(cfg.NOMINAL_PERIOD)
_F0 = np.float32(0.0)
_F1 = np.float32(1.0)
_F2 = np.float32(2.0)
_FH = np.float32(0.5)
_P24 = ins.P24_INDEX
_TRI_ROW = np.ascontiguousarray(ins.P_IU[0], dtype=np.int64)
_TRI_COL = np.ascontiguousarray(ins.P_IU[1], dtype=np.int64)
_POS_YAW = np.ascontiguousarray(ins.POS_YAW_TRIANGLE, dtype=np.int64)
_RESET_MASK = np.ascontiguousarray(ins._RESET_MASK, dtype=np.bool_)
_INT32_MIN = -0x80000000
_ALIGN_N = cfg.ALIGNMENT_SAMPLES



# ---------------------------------------------------------------------------------------------
# one-argument access: the module's state arena and the functions' work arena

#: Byte offsets of the states in every StateMemory's arena (the layout is fixed by the state table).
_MEM_OFFSETS = StateMemory().offsets
_MEM_BLOCKS = StateMemory().block_offsets
#: The per-sample work arrays of READ_INERTIAL, the front end and the INS the kernel uses,
#: re-homed into one arena per module by FastNav (group, attribute, dtype, shape).
_WORK_ITEMS = [
    ("fe", "cal", np.int32, (NR_IMUS, 2, 3, 3)), ("fe", "bias", np.int32, (6,)),
    ("fe", "buf32", np.int32, (cfg.N, 6)), ("fe", "buf16", np.int16, (cfg.N, 6)),
    ("fe", "norm", np.uint32, (cfg.N, 2)), ("fe", "ts", np.uint32, (cfg.N,)),
    ("fe", "newest", np.int32, (1,)), ("fe", "zaru_ab", np.int32, (6,)), ("fe", "zaru_cd", np.uint32, (4,)),
    ("fe", "zupt_a", np.int32, (3,)), ("fe", "zupt_cd", np.uint32, (4,)),
    ("fe", "gyro_bias", np.float32, (3,)), ("fe", "bias_p", np.float32, (1,)),
    ("fe", "t_prev", np.uint32, (1,)),
    ("ins", "f_n", np.float32, (3,)), ("ins", "t_since_reset", np.float32, (1,)),
    ("ins", "t_pending", np.float32, (1,)), ("ins", "pending", np.bool_, (1,)),
    ("ins", "align_sum", np.float32, (3,)), ("ins", "align_count", np.int32, (1,)),
    ("in", "prev_acc", np.int16, (NR_IMUS, 3)), ("in", "have_prev", np.bool_, (1,)),
    ("fp", "scratch", np.float32, (27, 9)),
]
_WORK_OFFSETS = Arena([((g, a), dt, sh) for g, a, dt, sh in _WORK_ITEMS]).offsets
_WORK_END = {(g, a): _WORK_OFFSETS[(g, a)] + np.dtype(dt).itemsize * int(np.prod(sh))
             for g, a, dt, sh in _WORK_ITEMS}
_O_IMU_RAW = _MEM_BLOCKS["imu_raw"]
_O_IMU_RAW_END = _O_IMU_RAW + 2 * 6 * MAX_IMU_IDS
_W_PREV_ACC = _WORK_OFFSETS[("in", "prev_acc")]
_W_PREV_ACC_END = _WORK_END[("in", "prev_acc")]
_W_HAVE_PREV = _WORK_OFFSETS[("in", "have_prev")]
_W_HAVE_PREV_END = _WORK_END[("in", "have_prev")]
_O_IMU_TS = _MEM_OFFSETS[StateId.IMU_TS]
_O_IMU_TS_END = _O_IMU_TS + STATES[StateId.IMU_TS].size
_W_CAL = _WORK_OFFSETS[("fe", "cal")]
_W_CAL_END = _WORK_END[("fe", "cal")]
_W_BIAS = _WORK_OFFSETS[("fe", "bias")]
_W_BIAS_END = _WORK_END[("fe", "bias")]
_W_BUF32 = _WORK_OFFSETS[("fe", "buf32")]
_W_BUF32_END = _WORK_END[("fe", "buf32")]
_W_BUF16 = _WORK_OFFSETS[("fe", "buf16")]
_W_BUF16_END = _WORK_END[("fe", "buf16")]
_W_NORM = _WORK_OFFSETS[("fe", "norm")]
_W_NORM_END = _WORK_END[("fe", "norm")]
_W_TS = _WORK_OFFSETS[("fe", "ts")]
_W_TS_END = _WORK_END[("fe", "ts")]
_W_NEWEST = _WORK_OFFSETS[("fe", "newest")]
_W_NEWEST_END = _WORK_END[("fe", "newest")]
_W_ZARU_AB = _WORK_OFFSETS[("fe", "zaru_ab")]
_W_ZARU_AB_END = _WORK_END[("fe", "zaru_ab")]
_W_ZARU_CD = _WORK_OFFSETS[("fe", "zaru_cd")]
_W_ZARU_CD_END = _WORK_END[("fe", "zaru_cd")]
_W_ZUPT_A = _WORK_OFFSETS[("fe", "zupt_a")]
_W_ZUPT_A_END = _WORK_END[("fe", "zupt_a")]
_W_ZUPT_CD = _WORK_OFFSETS[("fe", "zupt_cd")]
_W_ZUPT_CD_END = _WORK_END[("fe", "zupt_cd")]
_W_GYRO_BIAS = _WORK_OFFSETS[("fe", "gyro_bias")]
_W_GYRO_BIAS_END = _WORK_END[("fe", "gyro_bias")]
_W_BIAS_P = _WORK_OFFSETS[("fe", "bias_p")]
_W_BIAS_P_END = _WORK_END[("fe", "bias_p")]
_W_T_PREV = _WORK_OFFSETS[("fe", "t_prev")]
_W_T_PREV_END = _WORK_END[("fe", "t_prev")]
_O_U_NEW = _MEM_OFFSETS[StateId.U_NEW]
_O_U_NEW_END = _O_U_NEW + STATES[StateId.U_NEW].size
_O_U_K = _MEM_OFFSETS[StateId.U_K]
_O_U_K_END = _O_U_K + STATES[StateId.U_K].size
_O_U_INT_K = _MEM_OFFSETS[StateId.U_INT_K]
_O_U_INT_K_END = _O_U_INT_K + STATES[StateId.U_INT_K].size
_O_T_INT_K = _MEM_OFFSETS[StateId.T_INT_K]
_O_T_INT_K_END = _O_T_INT_K + STATES[StateId.T_INT_K].size
_O_DT_S = _MEM_OFFSETS[StateId.DT]
_O_DT_S_END = _O_DT_S + STATES[StateId.DT].size
_O_T1_S = _MEM_OFFSETS[StateId.T1S2F]
_O_T1_S_END = _O_T1_S + STATES[StateId.T1S2F].size
_O_T2_S = _MEM_OFFSETS[StateId.T2S2F]
_O_T2_S_END = _O_T2_S + STATES[StateId.T2S2F].size
_O_ZUPT_S = _MEM_OFFSETS[StateId.ZUPT]
_O_ZUPT_S_END = _O_ZUPT_S + STATES[StateId.ZUPT].size
_O_ZARU_S = _MEM_OFFSETS[StateId.ZARU]
_O_ZARU_S_END = _O_ZARU_S + STATES[StateId.ZARU].size
_O_TH_ZUPT = _MEM_OFFSETS[StateId.TH_ZUPT]
_O_TH_ZUPT_END = _O_TH_ZUPT + STATES[StateId.TH_ZUPT].size
_O_TH_ZARU = _MEM_OFFSETS[StateId.TH_ZARU]
_O_TH_ZARU_END = _O_TH_ZARU + STATES[StateId.TH_ZARU].size
_O_POS = _MEM_OFFSETS[StateId.POSITION]
_O_POS_END = _O_POS + STATES[StateId.POSITION].size
_O_VEL = _MEM_OFFSETS[StateId.VELOCITY]
_O_VEL_END = _O_VEL + STATES[StateId.VELOCITY].size
_O_QUAT = _MEM_OFFSETS[StateId.QUATERNION]
_O_QUAT_END = _O_QUAT + STATES[StateId.QUATERNION].size
_O_P45 = _MEM_OFFSETS[StateId.P]
_O_P45_END = _O_P45 + STATES[StateId.P].size
_O_DX_OUT = _MEM_OFFSETS[StateId.DX]
_O_DX_OUT_END = _O_DX_OUT + STATES[StateId.DX].size
_O_DP_OUT = _MEM_OFFSETS[StateId.DP]
_O_DP_OUT_END = _O_DP_OUT + STATES[StateId.DP].size
_O_STEP_COUNTER = _MEM_OFFSETS[StateId.STEP_COUNTER]
_O_STEP_COUNTER_END = _O_STEP_COUNTER + STATES[StateId.STEP_COUNTER].size
_O_RESET_FLAG = _MEM_OFFSETS[StateId.FILTER_RESET_FLAG]
_O_RESET_FLAG_END = _O_RESET_FLAG + STATES[StateId.FILTER_RESET_FLAG].size
_W_F_N = _WORK_OFFSETS[("ins", "f_n")]
_W_F_N_END = _WORK_END[("ins", "f_n")]
_W_T_SINCE = _WORK_OFFSETS[("ins", "t_since_reset")]
_W_T_SINCE_END = _WORK_END[("ins", "t_since_reset")]
_W_T_PENDING = _WORK_OFFSETS[("ins", "t_pending")]
_W_T_PENDING_END = _WORK_END[("ins", "t_pending")]
_W_PENDING = _WORK_OFFSETS[("ins", "pending")]
_W_PENDING_END = _WORK_END[("ins", "pending")]
_W_ALIGN_SUM = _WORK_OFFSETS[("ins", "align_sum")]
_W_ALIGN_SUM_END = _WORK_END[("ins", "align_sum")]
_W_ALIGN_COUNT = _WORK_OFFSETS[("ins", "align_count")]
_W_ALIGN_COUNT_END = _WORK_END[("ins", "align_count")]
_W_SCRATCH = _WORK_OFFSETS[("fp", "scratch")]
_W_SCRATCH_END = _WORK_END[("fp", "scratch")]


def _run(n, do_read, mode, imu, start_cycles, period, ts_off, mem, work):
    """:func:`_run_arrays` on a module's state arena *mem* and work arena *work* (few arguments:
    a compiled call costs a few µs instead of ~17 with every array passed on its own)."""
    imu_raw = mem[_O_IMU_RAW:_O_IMU_RAW_END].view(np.int16).reshape((MAX_IMU_IDS, 6))
    prev_acc = work[_W_PREV_ACC:_W_PREV_ACC_END].view(np.int16).reshape((4, 3))
    have_prev = work[_W_HAVE_PREV:_W_HAVE_PREV_END].view(np.bool_)
    imu_ts = mem[_O_IMU_TS:_O_IMU_TS_END].view(np.uint32)
    cal = work[_W_CAL:_W_CAL_END].view(np.int32).reshape((4, 2, 3, 3))
    bias = work[_W_BIAS:_W_BIAS_END].view(np.int32)
    buf32 = work[_W_BUF32:_W_BUF32_END].view(np.int32).reshape((_N, 6))
    buf16 = work[_W_BUF16:_W_BUF16_END].view(np.int16).reshape((_N, 6))
    norm = work[_W_NORM:_W_NORM_END].view(np.uint32).reshape((_N, 2))
    tsbuf = work[_W_TS:_W_TS_END].view(np.uint32)
    newest = work[_W_NEWEST:_W_NEWEST_END].view(np.int32)
    zaru_ab = work[_W_ZARU_AB:_W_ZARU_AB_END].view(np.int32)
    zaru_cd = work[_W_ZARU_CD:_W_ZARU_CD_END].view(np.uint32)
    zupt_a = work[_W_ZUPT_A:_W_ZUPT_A_END].view(np.int32)
    zupt_cd = work[_W_ZUPT_CD:_W_ZUPT_CD_END].view(np.uint32)
    gyro_bias = work[_W_GYRO_BIAS:_W_GYRO_BIAS_END].view(np.float32)
    bias_p = work[_W_BIAS_P:_W_BIAS_P_END].view(np.float32)
    t_prev = work[_W_T_PREV:_W_T_PREV_END].view(np.uint32)
    u_new = mem[_O_U_NEW:_O_U_NEW_END].view(np.int32)
    u_k = mem[_O_U_K:_O_U_K_END].view(np.float32)
    u_int_k = mem[_O_U_INT_K:_O_U_INT_K_END].view(np.int32)
    t_int_k = mem[_O_T_INT_K:_O_T_INT_K_END].view(np.uint32)
    dt_s = mem[_O_DT_S:_O_DT_S_END].view(np.float32)
    t1_s = mem[_O_T1_S:_O_T1_S_END].view(np.uint32)
    t2_s = mem[_O_T2_S:_O_T2_S_END].view(np.uint32)
    zupt_s = mem[_O_ZUPT_S:_O_ZUPT_S_END].view(np.bool_)
    zaru_s = mem[_O_ZARU_S:_O_ZARU_S_END].view(np.bool_)
    th_zupt = mem[_O_TH_ZUPT:_O_TH_ZUPT_END].view(np.uint32)
    th_zaru = mem[_O_TH_ZARU:_O_TH_ZARU_END].view(np.uint32)
    pos = mem[_O_POS:_O_POS_END].view(np.float32)
    vel = mem[_O_VEL:_O_VEL_END].view(np.float32)
    quat = mem[_O_QUAT:_O_QUAT_END].view(np.float32)
    p45 = mem[_O_P45:_O_P45_END].view(np.float32)
    dx_out = mem[_O_DX_OUT:_O_DX_OUT_END].view(np.float32)
    dp_out = mem[_O_DP_OUT:_O_DP_OUT_END].view(np.float32)
    step_counter = mem[_O_STEP_COUNTER:_O_STEP_COUNTER_END].view(np.uint16)
    reset_flag = mem[_O_RESET_FLAG:_O_RESET_FLAG_END].view(np.bool_)
    f_n = work[_W_F_N:_W_F_N_END].view(np.float32)
    t_since = work[_W_T_SINCE:_W_T_SINCE_END].view(np.float32)
    t_pending = work[_W_T_PENDING:_W_T_PENDING_END].view(np.float32)
    pending = work[_W_PENDING:_W_PENDING_END].view(np.bool_)
    align_sum = work[_W_ALIGN_SUM:_W_ALIGN_SUM_END].view(np.float32)
    align_count = work[_W_ALIGN_COUNT:_W_ALIGN_COUNT_END].view(np.int32)
    scratch = work[_W_SCRATCH:_W_SCRATCH_END].view(np.float32).reshape((27, 9))
    return _run_arrays(n, do_read, mode, imu, start_cycles, period, ts_off,
                       imu_raw, prev_acc, have_prev, imu_ts, cal, bias, buf32, buf16,
                       norm, tsbuf, newest, zaru_ab, zaru_cd, zupt_a, zupt_cd, gyro_bias,
                       bias_p, t_prev, u_new, u_k, u_int_k, t_int_k, dt_s, t1_s,
                       t2_s, zupt_s, zaru_s, th_zupt, th_zaru, pos, vel, quat,
                       p45, dx_out, dp_out, step_counter, reset_flag, f_n, t_since, t_pending,
                       pending, align_sum, align_count, scratch)

# the integer helpers are the reference's own (plain ints: compiled as they are)
_i32 = frontend._i32
_isqrt64 = frontend.isqrt64


def _sat_u32(x):
    if x < 0:
        return 0
    if x > 0xFFFFFFFF:
        return 0xFFFFFFFF
    return x


def _window(ab, cd, s16, norm, j, sign, n):
    """Add (sign +1) / remove (−1) buffered sample j from a window's running sums (wrapping)."""
    for i in range(n):
        ab[i] = np.int64(ab[i]) + sign * np.int64(s16[j, i])
    n0 = np.int64(norm[j, 0])
    n1 = np.int64(norm[j, 1])
    cd[0] = np.int64(cd[0]) + sign * (n0 & 0xFFFF)
    cd[1] = np.int64(cd[1]) + sign * (n1 & 0xFFFF)
    cd[2] = np.int64(cd[2]) + sign * (n0 >> 16)
    cd[3] = np.int64(cd[3]) + sign * (n1 >> 16)


def _quat_mul(a, b, out):
    ax, ay, az, aw = a[0], a[1], a[2], a[3]
    bx, by, bz, bw = b[0], b[1], b[2], b[3]
    out[0] = aw * bx + bw * ax + (ay * bz - az * by)
    out[1] = aw * by + bw * ay + (az * bx - ax * bz)
    out[2] = aw * bz + bw * az + (ax * by - ay * bx)
    out[3] = aw * bw - (ax * bx + ay * by + az * bz)


def _normalise_into(q, out):
    n = np.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    for i in range(4):
        out[i] = q[i] / n


def _quat_to_rot(q, r):
    x, y, z, w = q[0], q[1], q[2], q[3]
    xx, yy, zz = x * x, y * y, z * z
    xy, xz, yz = x * y, x * z, y * z
    wx, wy, wz = w * x, w * y, w * z
    r[0, 0] = _F1 - _F2 * (yy + zz)
    r[0, 1] = _F2 * (xy - wz)
    r[0, 2] = _F2 * (xz + wy)
    r[1, 0] = _F2 * (xy + wz)
    r[1, 1] = _F1 - _F2 * (xx + zz)
    r[1, 2] = _F2 * (yz - wx)
    r[2, 0] = _F2 * (xz - wy)
    r[2, 1] = _F2 * (yz + wx)
    r[2, 2] = _F1 - _F2 * (xx + yy)


def _mm(a, b, out):
    """out = a @ b, each element a[i,0]·b[0,j] + a[i,1]·b[1,j] + … left to right (as ins._mm)."""
    n, k = a.shape
    m = b.shape[1]
    for i in range(n):
        for j in range(m):
            s = a[i, 0] * b[0, j]
            for t in range(1, k):
                s = s + a[i, t] * b[t, j]
            out[i, j] = s


def _unpack(p45, pm):
    for e in range(45):
        pm[_TRI_ROW[e], _TRI_COL[e]] = p45[e]
    for e in range(45):
        pm[_TRI_COL[e], _TRI_ROW[e]] = p45[e]


def _pack(pm, p45):
    for e in range(45):
        p45[e] = pm[_TRI_ROW[e], _TRI_COL[e]]


#: Columns t where row i of TIME_UPDATE's F can be non-zero (ascending; −1 ends a row):
#: I, dt on the δp–δv block, −[f_n×]·dt on the δv–δθ block. Every other entry is ±0.
_F_TERMS = np.array([[0, 3, -1, -1], [1, 4, -1, -1], [2, 5, -1, -1], [3, 6, 7, 8], [4, 6, 7, 8],
                     [5, 6, 7, 8], [6, -1, -1, -1], [7, -1, -1, -1], [8, -1, -1, -1]], dtype=np.int64)
_D33, _D44, _D55, _D66, _D77, _D88 = (
    int(np.flatnonzero((ins.P_IU[0] == d) & (ins.P_IU[1] == d))[0]) for d in (3, 4, 5, 6, 7, 8))


def _finite(a):
    for x in a.flat:
        if not (x - x == 0):
            return False
    return True


def _f_pm(fm, pm, out):
    """out = F @ P with _mm's rounding, summing only F's structurally non-zero terms.

    Exact: with finite inputs, a ±0 product added to a non-zero partial sum changes
    nothing and a zero partial sum followed by x gives x, so the short sum equals the
    full one except perhaps for the sign of an exactly-zero result, which is then
    recomputed in full (as is everything when an input is not finite).
    """
    if not (_finite(fm) and _finite(pm)):
        _mm(fm, pm, out)
        return
    for i in range(9):
        for j in range(9):
            t = _F_TERMS[i, 0]
            s = fm[i, t] * pm[t, j]
            for u in range(1, 4):
                t = _F_TERMS[i, u]
                if t < 0:
                    break
                s = s + fm[i, t] * pm[t, j]
            if s == 0:
                s = _zero_sign(fm, pm, i, j, _F_TERMS[i], True)
            out[i, j] = s


def _zero_sign(a, b, i, j, terms, left_f):
    """The full sum's value when the short sum is exactly zero (finite inputs).

    A sum that comes out zero is −0 only if every term is −0 (x + (−x), +0 + −0 and
    +0 + +0 all give +0), so one short term that is not −0 settles it as +0; only
    otherwise is the full sum computed. ``left_f``: the terms are F[i,t]·b[t,j] (F P),
    else a[i,t]·F[j,t] (… Fᵀ).
    """
    for u in range(4):
        t = terms[u]
        if t < 0:
            break
        p = a[i, t] * b[t, j] if left_f else a[i, t] * b[j, t]
        if p != 0 or math.copysign(1.0, p) > 0:
            return _F0
    if left_f:
        s = a[i, 0] * b[0, j]
        for t in range(1, 9):
            s = s + a[i, t] * b[t, j]
    else:
        s = a[i, 0] * b[j, 0]
        for t in range(1, 9):
            s = s + a[i, t] * b[j, t]
    return s


def _pm_ft_upper(tp, fm, p45):
    """Upper triangle of tp @ Fᵀ into p45, with the short sums of :func:`_f_pm`."""
    dense = not (_finite(fm) and _finite(tp))
    for e in range(45):
        i = _TRI_ROW[e]
        j = _TRI_COL[e]
        # (tp @ Fᵀ)[i, j] = Σ_t tp[i, t] · F[j, t]
        if not dense:
            t = _F_TERMS[j, 0]
            s = tp[i, t] * fm[j, t]
            for u in range(1, 4):
                t = _F_TERMS[j, u]
                if t < 0:
                    break
                s = s + tp[i, t] * fm[j, t]
        if dense:
            s = tp[i, 0] * fm[j, 0]
            for t in range(1, 9):
                s = s + tp[i, t] * fm[j, t]
        elif s == 0:
            s = _zero_sign(tp, fm, i, j, _F_TERMS[j], False)
        p45[e] = s


def _sinf(x):
    return np.float32(math.sin(np.float64(x)))


def _cosf(x):
    return np.float32(math.cos(np.float64(x)))


def _atan2f(y, x):
    return np.float32(math.atan2(np.float64(y), np.float64(x)))


def _run_arrays(n, do_read, mode, imu, start_cycles, period, ts_off,
                imu_raw, prev_acc, have_prev, imu_ts,
                cal, bias, buf32, buf16, norm, tsbuf, newest, zaru_ab, zaru_cd, zupt_a, zupt_cd,
                gyro_bias, bias_p, t_prev,
                u_new, u_k, u_int_k, t_int_k, dt_s, t1_s, t2_s, zupt_s, zaru_s, th_zupt, th_zaru,
                pos, vel, quat, p45, dx_out, dp_out, step_counter, reset_flag,
                f_n, t_since, t_pending, pending, align_sum, align_count, scratch):
    """Slots 0–8 of the tracking sequence for up to *n* loops; stops after a loop with a reset.

    With *do_read* the loop reads ``imu[i]`` (READ_INERTIAL, timestamp
    ``start_cycles + i·period + ts_off``); without, the caller has read one sample.
    *mode* 0: the tracking sequence's slots 0–8; 1: the front end only (slots 0–4);
    2: the alignment sequence's front end and INITIAL_ALIGNMENT's averaging, stopping
    before the loop whose sample completes the alignment (returned as −loops: that
    loop's INITIAL_ALIGNMENT is left to the caller). Returns the loops run.
    """
    pm = scratch[0:9, :]
    fm = scratch[9:18, :]
    tmp = scratch[18:27, :]
    r = np.empty((3, 3), np.float32)
    q2 = np.empty(4, np.float32)
    q3 = np.empty(4, np.float32)
    dq = np.empty(4, np.float32)
    k = np.empty((9, 3), np.float32)
    sinv = np.empty((3, 3), np.float32)
    d = np.empty(9, np.float32)
    for it in range(n):
        # ---- READ_INERTIAL (0x13)
        if do_read:
            for c in range(NR_IMUS):
                for a in range(3):
                    cur = imu[it, c, a]
                    if have_prev[0]:
                        imu_raw[c, a] = prev_acc[c, a]
                    else:
                        imu_raw[c, a] = cur
                    prev_acc[c, a] = cur
                    imu_raw[c, 3 + a] = imu[it, c, 3 + a]
            have_prev[0] = True
            imu_ts[0] = (start_cycles + it * period + ts_off) & 0xFFFFFFFF
        # ---- FRONTEND_PREPROC (0x10)
        for s in range(2):
            for i in range(3):
                acc = np.int64(0)
                for c in range(NR_IMUS):
                    for jj in range(3):
                        acc += np.int64(cal[c, s, i, jj]) * np.int64(imu_raw[c, 3 * s + jj])
                v = _i32(_i32(acc >> _LOG2_IMUS) - np.int64(bias[3 * s + i]))
                u_new[3 * s + i] = v
        for i in range(3):
            u_k[i] = np.float32(u_new[i]) * _ACC_SCALE
            u_k[3 + i] = np.float32(u_new[3 + i]) * _GYRO_SCALE
        # ---- FRONTEND_STATDET (0x11)
        ts = np.int64(imu_ts[0])
        j_old = np.int64(newest[0])
        j = (j_old + 1) & _NM
        _window(zaru_ab, zaru_cd, buf16, norm, j, -1, 6)
        z_out = (j_old - _HALF_N - _HALF_M + 1) & _NM
        _window(zupt_a, zupt_cd, buf16, norm, z_out, -1, 3)
        for i in range(3):
            buf32[j, i] = u_new[i]
            buf32[j, 3 + i] = u_new[3 + i]
            buf16[j, i] = np.int64(u_new[i]) >> _RED_F
            buf16[j, 3 + i] = np.int64(u_new[3 + i]) >> _RED_G
        sa = np.int64(buf16[j, 0])
        sb = np.int64(buf16[j, 1])
        sc = np.int64(buf16[j, 2])
        norm[j, 0] = sa * sa + sb * sb + sc * sc
        sa = np.int64(buf16[j, 3])
        sb = np.int64(buf16[j, 4])
        sc = np.int64(buf16[j, 5])
        norm[j, 1] = sa * sa + sb * sb + sc * sc
        tsbuf[j] = ts
        newest[0] = j
        _window(zaru_ab, zaru_cd, buf16, norm, j, 1, 6)
        z_in = (j - _HALF_N + _HALF_M) & _NM
        _window(zupt_a, zupt_cd, buf16, norm, z_in, 1, 3)
        # T1 over the ZUPT window
        c_ = (np.int64(zupt_cd[2]) << 16) + np.int64(zupt_cd[0])
        d_ = (np.int64(zupt_cd[3]) << 16) + np.int64(zupt_cd[1])
        a0 = np.int64(zupt_a[0])
        a1 = np.int64(zupt_a[1])
        a2 = np.int64(zupt_a[2])
        norm_a = _isqrt64(a0 * a0 + a1 * a1 + a2 * a2)
        t1 = ((c_ >> _LOG2_M) - ((2 * _G_RED * norm_a) >> _LOG2_M) + _G_RED * _G_RED
              + ((_SR_Q * (d_ >> _LOG2_M)) >> _SR_SHIFT))
        t1 = _sat_u32(t1)
        # T2 over the whole buffer
        c_ = (np.int64(zaru_cd[2]) << 16) + np.int64(zaru_cd[0])
        d_ = (np.int64(zaru_cd[3]) << 16) + np.int64(zaru_cd[1])
        a0 = np.int64(zaru_ab[0])
        a1 = np.int64(zaru_ab[1])
        a2 = np.int64(zaru_ab[2])
        b0 = np.int64(zaru_ab[3])
        b1 = np.int64(zaru_ab[4])
        b2 = np.int64(zaru_ab[5])
        var_f = (c_ >> _LOG2_N) - ((a0 * a0 + a1 * a1 + a2 * a2) >> (2 * _LOG2_N))
        var_g = (d_ >> _LOG2_N) - ((b0 * b0 + b1 * b1 + b2 * b2) >> (2 * _LOG2_N))
        t2 = _sat_u32(var_f + ((_SR_Q * var_g) >> _SR_SHIFT))
        zupt = t1 < np.int64(th_zupt[0])
        zaru = zupt and t2 < np.int64(th_zaru[0])
        kk = (j - _HALF_N) & _NM
        for i in range(6):
            u_int_k[i] = buf32[kk, i]
        t1_s[0] = t1
        t2_s[0] = t2
        zupt_s[0] = zupt
        zaru_s[0] = zaru
        t_int_k[0] = tsbuf[kk]
        # ---- FRONTEND_BIASEST (0x12)
        bias_p[0] = bias_p[0] + _BIAS_Q
        if zaru:
            pk = bias_p[0]
            kg = pk / (pk + _BIAS_R)
            for i in range(3):
                om = np.float32(u_int_k[3 + i]) * _GYRO_SCALE
                gyro_bias[i] = gyro_bias[i] + kg * (om - gyro_bias[i])
            bias_p[0] = pk * (_F1 - kg)
        # ---- FRONTEND_CONVCOMP (0x14)
        for i in range(3):
            u_k[i] = np.float32(u_int_k[i]) * _ACC_SCALE
            u_k[3 + i] = np.float32(u_int_k[3 + i]) * _GYRO_SCALE - gyro_bias[i]
        tik = np.int64(t_int_k[0])
        dt_s[0] = np.float32((tik - np.int64(t_prev[0])) & 0xFFFFFFFF) / _CPU_HZ
        t_prev[0] = tik
        dt = dt_s[0]
        if mode == 1:
            continue
        if mode == 2:
            # INITIAL_ALIGNMENT's averaging (the completing sample is left to the reference)
            if not zupt:
                align_count[0] = 0
                for i in range(3):
                    align_sum[i] = _F0
            elif align_count[0] + 1 >= _ALIGN_N:
                return -(it + 1)
            else:
                for i in range(3):
                    align_sum[i] = align_sum[i] + u_k[i]
                align_count[0] += 1
            continue
        # ---- STEPWISE_SYSTEM_RESET (0x24)
        flag = False
        t_since[0] = t_since[0] + dt
        go = True
        if not pending[0]:
            if p45[_P24] < _RESET_TH and t_since[0] > _MIN_T_RESET:
                pending[0] = True
                t_pending[0] = _F0
            else:
                go = False
        if go:
            t_pending[0] = t_pending[0] + dt
            if not (zupt and not t_pending[0] > _MAX_T_PENDING):
                _quat_to_rot(quat, r)
                yaw = _atan2f(r[1, 0], r[0, 0])
                for i in range(3):
                    dx_out[i] = pos[i]
                dx_out[3] = yaw
                for i in range(10):
                    dp_out[i] = p45[_POS_YAW[i]]
                for i in range(3):
                    pos[i] = _F0
                half = -yaw * _FH
                dq[0] = _F0
                dq[1] = _F0
                dq[2] = _sinf(half)
                dq[3] = _cosf(half)
                _quat_mul(dq, quat, q2)
                _normalise_into(q2, quat)
                for e in range(45):
                    if _RESET_MASK[e]:
                        p45[e] = _F0
                t_since[0] = _F0
                t_pending[0] = _F0
                pending[0] = False
                flag = True
        reset_flag[0] = flag
        if flag:
            step_counter[0] = (np.int64(step_counter[0]) + 1) & 0xFFFF
        # ---- MECHANIZATION (0x20)
        _quat_to_rot(quat, r)
        f0, f1, f2 = u_k[0], u_k[1], u_k[2]
        o0, o1, o2 = u_k[3], u_k[4], u_k[5]
        if zaru:
            up0, up1, up2 = r[2, 0], r[2, 1], r[2, 2]
            proj = up0 * o0 + up1 * o1 + up2 * o2
            o0 = o0 - proj * up0
            o1 = o1 - proj * up1
            o2 = o2 - proj * up2
        fn0 = r[0, 0] * f0 + r[0, 1] * f1 + r[0, 2] * f2
        fn1 = r[1, 0] * f0 + r[1, 1] * f1 + r[1, 2] * f2
        fn2 = r[2, 0] * f0 + r[2, 1] * f1 + r[2, 2] * f2
        f_n[0] = fn0
        f_n[1] = fn1
        f_n[2] = fn2
        if not zaru:
            for i in range(3):
                pos[i] = pos[i] + vel[i] * dt
        vel[0] = vel[0] + (fn0 + _F0) * dt
        vel[1] = vel[1] + (fn1 + _F0) * dt
        vel[2] = vel[2] + (fn2 + _GRAVITY) * dt
        th0 = o0 * dt
        th1 = o1 * dt
        th2 = o2 * dt
        angle = np.sqrt(th0 * th0 + th1 * th1 + th2 * th2)
        if angle > _F0:
            sh = _sinf(angle * _FH) / angle
            dq[0] = th0 * sh
            dq[1] = th1 * sh
            dq[2] = th2 * sh
            dq[3] = _cosf(angle * _FH)
        else:
            dq[0] = _F0
            dq[1] = _F0
            dq[2] = _F0
            dq[3] = _F1
        _quat_mul(quat, dq, q2)
        _normalise_into(q2, quat)
        # ---- TIME_UPDATE (0x21)
        _unpack(p45, pm)
        for a in range(9):
            for b in range(9):
                fm[a, b] = _F1 if a == b else _F0
        if not zaru:
            fm[0, 3] = dt
            fm[1, 4] = dt
            fm[2, 5] = dt
        # −[f_n×]·dt, element by element as −(skew)·dt
        fm[3, 6] = -_F0 * dt
        fm[3, 7] = f_n[2] * dt
        fm[3, 8] = -f_n[1] * dt
        fm[4, 6] = -f_n[2] * dt
        fm[4, 7] = -_F0 * dt
        fm[4, 8] = f_n[0] * dt
        fm[5, 6] = f_n[1] * dt
        fm[5, 7] = -f_n[0] * dt
        fm[5, 8] = -_F0 * dt
        _f_pm(fm, pm, tmp)  # tmp = F P
        dt2 = dt * _T0  # dt·T₀ (= dt² at the module's 1 kHz)
        qa = dt2 * _SIG_ACC * _SIG_ACC
        qg = dt2 * _SIG_GYRO * _SIG_GYRO
        _pm_ft_upper(tmp, fm, p45)  # upper triangle of (F P) Fᵀ
        p45[_D33] += qa
        p45[_D44] += qa
        p45[_D55] += qa
        p45[_D66] += qg
        p45[_D77] += qg
        if not zaru:
            p45[_D88] += qg
        # ---- ZUPT_UPDATE (0x22)
        if zupt:
            _unpack(p45, pm)
            rz = (_SIG_ZUPT * _SIG_ZUPT) * (_T0 / dt)  # σ²_zupt·(T₀/dt)
            for a in range(3):
                for b in range(3):
                    sinv[a, b] = pm[3 + a, 3 + b] + (rz if a == b else _F0)
            sa_ = sinv[0, 0]
            sb_ = sinv[0, 1]
            sc_ = sinv[0, 2]
            sd_ = sinv[1, 1]
            se_ = sinv[1, 2]
            sf_ = sinv[2, 2]
            c00 = sd_ * sf_ - se_ * se_
            c01 = sc_ * se_ - sb_ * sf_
            c02 = sb_ * se_ - sc_ * sd_
            c11 = sa_ * sf_ - sc_ * sc_
            c12 = sb_ * sc_ - sa_ * se_
            c22 = sa_ * sd_ - sb_ * sb_
            inv_det = _F1 / (sa_ * c00 + sb_ * c01 + sc_ * c02)
            sinv[0, 0] = c00 * inv_det
            sinv[0, 1] = c01 * inv_det
            sinv[0, 2] = c02 * inv_det
            sinv[1, 0] = c01 * inv_det
            sinv[1, 1] = c11 * inv_det
            sinv[1, 2] = c12 * inv_det
            sinv[2, 0] = c02 * inv_det
            sinv[2, 1] = c12 * inv_det
            sinv[2, 2] = c22 * inv_det
            _mm(pm[:, 3:6], sinv, k)
            v0, v1, v2 = vel[0], vel[1], vel[2]
            for a in range(9):
                d[a] = k[a, 0] * v0 + k[a, 1] * v1 + k[a, 2] * v2
            for i in range(3):
                pos[i] = pos[i] - d[i]
                vel[i] = vel[i] - d[3 + i]
            dq[0] = -d[6] * _FH
            dq[1] = -d[7] * _FH
            dq[2] = -d[8] * _FH
            dq[3] = _F1
            _normalise_into(dq, q3)
            _quat_mul(q3, quat, q2)
            _normalise_into(q2, quat)
            for e in range(45):  # P − K·P[3:6, :], upper triangle
                a = _TRI_ROW[e]
                b = _TRI_COL[e]
                p45[e] = pm[a, b] - (k[a, 0] * pm[3, b] + k[a, 1] * pm[4, b] + k[a, 2] * pm[5, b])
        if flag:
            return it + 1
    return n


if numba is not None:
    # error_model="numpy": a float division by zero gives inf/nan as in the reference, never raises
    _jit = njit(cache=True, nogil=True, error_model="numpy")
    _i32 = _jit(_i32)
    _isqrt64 = _jit(_isqrt64)
    _sat_u32 = _jit(_sat_u32)
    _window = _jit(_window)
    _quat_mul = _jit(_quat_mul)
    _normalise_into = _jit(_normalise_into)
    _quat_to_rot = _jit(_quat_to_rot)
    _mm = _jit(_mm)
    _finite = _jit(_finite)
    _zero_sign = _jit(_zero_sign)
    _f_pm = _jit(_f_pm)
    _pm_ft_upper = _jit(_pm_ft_upper)
    _unpack = _jit(_unpack)
    _pack = _jit(_pack)
    _sinf = _jit(_sinf)
    _cosf = _jit(_cosf)
    _atan2f = _jit(_atan2f)
    _run_arrays = _jit(_run_arrays)
    _run = _jit(_run)


# ---------------------------------------------------------------------------------------------
# binding to one module


class FastNav:
    """The compiled tracking sequence bound to one module's live arrays."""

    def __init__(self, module: Module):
        mem = module.memory
        fw = frontend.frontend_work(module)
        iw = ins.ins_work(module)
        iwk = inertial.inertial_work(module)
        self._empty_imu = np.zeros((1, NR_IMUS, 6), dtype=np.int16)
        # the kernel's work arrays move into one arena (values kept; the functions look
        # their arrays up on every call, so they use the new homes from now on)
        arena = Arena([((g, a), dt, sh) for g, a, dt, sh in _WORK_ITEMS])
        owners = {"fe": fw, "ins": iw, "in": iwk, "fp": None}
        for g, a, dt, sh in _WORK_ITEMS:
            view = arena.views[(g, a)]
            owner = owners[g]
            if owner is None:
                continue
            old = owner[a] if isinstance(owner, dict) else getattr(owner, a)
            if old.dtype != np.dtype(dt) or old.shape != sh:
                raise TypeError(f"work array {g}.{a} is {old.dtype} {old.shape}, "
                                f"the kernel expects {np.dtype(dt)} {sh}")
            view[...] = old
            if isinstance(owner, dict):
                owner[a] = view
            else:
                setattr(owner, a, view)
        self._scratch = arena.views[("fp", "scratch")]
        self._cond_keys = _WRITTEN
        self.work_arena = arena.buf
        #: Arguments after (n, do_read, mode, imu, start, period, ts_off): the two arenas.
        self.arrays: tuple[Any, ...] = (mem.arena, arena.buf)
        self._ids = [p for p in TRACKING_SLOTS if p]
        funcs = module.firmware.functions
        self._costs = [funcs[p].cycles + module.costs.slot_call for p in self._ids]
        self.seq_cycles = sum(self._costs)
        self._mid_cycles = sum(self._costs[1:9])
        self._fe_cycles = sum(self._costs[1:5])
        self._align_costs = [funcs[p].cycles + module.costs.slot_call
                             for p in (P.FRONTEND_INITIAL_ALIGNMENT, P.RESTORE_PROC_SEQU_IF)]
        self._align_seq_cycles = self._costs[0] + self._fe_cycles + sum(self._align_costs)
        self._ps_dt = np.array(self._costs, dtype=np.uint32)
        #: Loops run compiled, loop by loop and in quiet runs (for the benchmark).
        self.ticks_single = 0
        self.ticks_quiet = 0

    # -------------------------------------------------------------- eligibility
    @staticmethod
    def kind(module: Module) -> int:
        """TRACKING or ALIGNMENT if the running slots are one of those sequences with the
        reference functions registered, else 0 (the pure-Python sequence runs)."""
        slots = module.sequence.slots
        if slots == TRACKING_SLOTS:
            kind = TRACKING
        elif slots == ALIGNMENT_SLOTS:
            kind = ALIGNMENT
        else:
            return 0
        funcs = module.firmware.functions
        for pid in slots:
            if pid:
                pf = funcs.get(pid)
                if pf is None or pf.fn is not _REFERENCE[pid]:
                    return 0
        return kind

    @classmethod
    def sequence_matches(cls, module: Module) -> bool:
        """The running slots are the tracking sequence and every id is the reference function."""
        return cls.kind(module) == TRACKING

    # ------------------------------------------------------------ one loop's sequence
    def sequence_tick(self, module: Module, kind: int = TRACKING) -> None:
        """run_process_sequence() of one loop of a known sequence, the numeric slots compiled."""
        seq = module.sequence
        seq.runs += 1
        clock = module.clock
        costs = self._costs
        ps_dt = module.memory.ps_dt
        # slot 0 in Python: any sensor source, exhaustion, temperature and magnetometer
        inertial.read_inertial(module)
        clock.now_cycles += costs[0]
        if kind == TRACKING:
            _run(1, False, 0, self._empty_imu, 0, 0, 0, *self.arrays)
            clock.now_cycles += self._mid_cycles
            utility.state_output_if(module)
            clock.now_cycles += costs[9]
            ps_dt[:10] = self._ps_dt
        else:
            _run(1, False, 1, self._empty_imu, 0, 0, 0, *self.arrays)
            clock.now_cycles += self._fe_cycles
            ins.frontend_initial_alignment(module)
            clock.now_cycles += self._align_costs[0]
            utility.restore_proc_sequ_if(module)
            clock.now_cycles += self._align_costs[1]
            ps_dt[:5] = self._ps_dt[:5]
            ps_dt[5] = self._align_costs[0]
            ps_dt[11] = self._align_costs[1]
        self.ticks_single += 1

    # ------------------------------------------------------------------ quiet runs
    def quiet_ticks(self, module: Module, max_ticks: int) -> int:
        """How many of the next loops (at most *max_ticks*) run with nothing but the sequence
        happening (see the module doc); 0 = the next loop is not quiet.

        Nothing may be received, pending or due for output, and a lossless packet waiting for
        its ACK must not be due for a resend. The ports bound the run
        (:meth:`~firmware_sim.mcu.port.IdealPort.quiet_until`): a link model with bytes in flight
        is quiet until the first of them could reach the µC or the host, and a scheduled
        disconnect or reconnect ends the run before it; the loop of such an event then runs
        loop by loop as usual."""
        src = module.sensors
        if module.sensors_exhausted or not (hasattr(src, "imu_block") or hasattr(src, "imu")):
            return 0  # (whether it has a block now, run_quiet asks)
        clock = module.clock
        first = clock._next_interrupt
        if clock.now_cycles > first:
            return 0
        c = module.costs
        if c.loop_overhead + 2 * c.rx_poll + self.seq_cycles > clock.cycles_per_tick:
            return 0
        n = max_ticks
        for iface in module.interface_list:
            if iface._need or iface._periodic or iface._pulled:
                return 0
            port = iface.port
            queue = iface.queue
            if queue.frames and port.connected:
                # a lossless packet waiting for its ACK: every loop counts the resend delay
                # down, and the loop that resends it is not quiet
                if not iface.lossless or queue.frames[0].single or queue.delay_counter == 0:
                    return 0
                n = min(n, queue.resend_cycles - queue.delay_counter)
            quiet_until = getattr(port, "quiet_until", None)
            if quiet_until is None:
                return 0
            until = quiet_until()
            if until is not None:
                # loop i advances its ports at first + i·period + loop_overhead: all before `until`
                n = min(n, (until - first - c.loop_overhead - 1) // clock.cycles_per_tick + 1)
                if n < 1:
                    return 0
        cond = module.cond_output
        if cond.from_mask and cond.flag_id != StateId.FILTER_RESET_FLAG and (
                cond.flag_id in self._cond_keys or module.memory.flag(cond.flag_id)):
            return 0
        return n

    def run_quiet(self, module: Module, max_ticks: int, kind: int = TRACKING) -> int:
        """Run up to *max_ticks* quiet loops of a known sequence (*kind*); returns loops run.

        A tracking run stops after a step reset's loop, an alignment run after the loop
        that completes the alignment (the sequence then switches). The caller checked
        :meth:`quiet` and :meth:`kind`.
        """
        clock = module.clock
        start = clock.ticks  # sample index of the first loop
        imu = imu_block(module.sensors, start, max_ticks)
        if imu is None:
            return 0
        n = len(imu)
        c = module.costs
        period = clock.cycles_per_tick
        first = clock._next_interrupt
        ts_off = c.loop_overhead + 2 * c.rx_poll
        tracking = kind == TRACKING
        done = _run(n, True, 0 if tracking else 2, imu, first, period, ts_off, *self.arrays)
        completing = done < 0
        done = abs(done)
        last_start = first + (done - 1) * period
        # what `done` loops did to the clock and the loop's own states
        clock.ticks += done
        clock.interrupts += done
        clock._next_interrupt = first + done * period
        clock.loop_start = last_start
        seq_cycles = self.seq_cycles if tracking else self._align_seq_cycles
        loop_cycles = ts_off + seq_cycles
        clock.now_cycles = last_start + loop_cycles
        clock.last_loop_cycles = loop_cycles
        mem = module.memory
        module._interrupt_counter[...] = clock.interrupts & _U32
        module._gp_dt[...] = loop_cycles & _U32
        if tracking:
            mem.ps_dt[:10] = self._ps_dt
        else:
            mem.ps_dt[:5] = self._ps_dt[:5]
            mem.ps_dt[5] = self._align_costs[0]
            mem.ps_dt[11] = self._align_costs[1]
        module.sequence.runs += done
        sample = module.sensors.read(start + done - 1)  # temperature, magnetometer of the last read
        if sample is not None:
            mem.imu_temp[:NR_IMUS] = sample.temp
            mem.imu_mag[:NR_IMUS] = sample.mag
        step_end = completing or (tracking and mem.flag(StateId.FILTER_RESET_FLAG))
        for iface in module.interface_list:
            port = iface.port
            if not port.idle():
                # bytes in flight: the link moves tick by tick, as between loops (same chunks)
                advance = port.advance
                for i in range(done - 1):
                    advance(first + i * period + c.loop_overhead)
            port.advance(last_start + c.loop_overhead)
            queue = iface.queue
            if queue.frames and port.connected:
                # each loop's send_lossless() counted the resend delay (the last loop's
                # transmit_data() runs below when it is a step's)
                counted = done - 1 if step_end else done
                queue.delay_counter = (queue.delay_counter + counted) % queue.resend_cycles
        if completing:
            # the alignment's last sample: INITIAL_ALIGNMENT and RESTORE_PROC_SEQU_IF (the
            # tracking sequence comes in), then transmit_data(), as Module.step does
            ins.frontend_initial_alignment(module)
            utility.restore_proc_sequ_if(module)
            self._finish_loop(module)
        elif step_end:
            # the step's loop: STATE_OUTPUT_IF and transmit_data() in Python, as Module.step does
            utility.state_output_if(module)
            self._finish_loop(module)
        self.ticks_quiet += done
        return done

    @staticmethod
    def _finish_loop(module: Module) -> None:
        clock = module.clock
        module.usb.transmit()
        module.bt.transmit()
        clock.last_loop_cycles = clock.now_cycles - clock.loop_start
        module.memory[StateId.GP_DT][...] = clock.last_loop_cycles & _U32


class _TrackingCompiledPath:
    """The compiled path as the runtime sees it (:class:`firmware_sim.mcu.firmware.CompiledPath`)."""

    @staticmethod
    def available() -> bool:
        return available()

    @staticmethod
    def reason_unavailable() -> str:
        return reason_unavailable()

    @staticmethod
    def kind(module: Module) -> int:
        return FastNav.kind(module)

    @staticmethod
    def runner(module: Module) -> FastNav:
        return FastNav(module)


#: Handed to the runtime by the tracking firmware (:data:`firmware_sim.nav.firmware.OPENSHOE`).
COMPILED_PATH = _TrackingCompiledPath()
