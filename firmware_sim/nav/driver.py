"""The compiled INS sequences: the kernels called in slot order, loop after loop.

One loop of a known sequence runs here from READ_INERTIAL's registers to its last numeric slot,
reading and writing the states exactly as the processing functions do around the kernels
(:mod:`~firmware_sim.nav.frontend_kernels`, :mod:`~firmware_sim.nav.ins_kernels`). What needs
the module's Python objects — a sensor source's other registers, the conditional output, an
edit of the sequence, the clock, the interfaces — stays with the caller
(:class:`firmware_sim.nav.fastpath.FastNav`). The kernels get typed records
(:mod:`~firmware_sim.nav.records`): the state memory, and the work of the front end, of the INS,
of READ_INERTIAL and of HEIGHT_COMPENSATION; :func:`run_loops` takes them as their bytes (numba
recognises a byte array at once, a record array only after comparing its whole type: µs on every
call).

The sequences (:mod:`~firmware_sim.nav.loop_kinds`; slots 0–4 are READ_INERTIAL, PREPROC, STATDET,
BIASEST, CONVCOMP in all four):

* ``TRACKING`` — step-wise dead reckoning (0x34) after the alignment: STEPWISE_SYSTEM_RESET,
  MECHANIZATION, TIME_UPDATE, ZUPT_UPDATE, then STATE_OUTPUT_IF (the caller's);
* ``TRACKING_HEIGHT`` — the same with HEIGHT_COMPENSATION after STATE_OUTPUT_IF (slot 10).
  In a loop in which no step ends the step output does nothing (and any output only names
  states, read when the loop transmits), so HEIGHT_COMPENSATION runs here; in the loop in which
  a step ends :func:`run_loops` returns before it, and the caller runs the output and then
  HEIGHT_COMPENSATION (``HEIGHT_AFTER_OUTPUT``), in the slots' order;
* ``FULL_RATE_INS`` — the ZUPT-aided INS (0x33) after the alignment: MECHANIZATION,
  TIME_UPDATE, ZUPT_UPDATE;
* ``ALIGNMENT`` — both modes until the alignment is done: INITIAL_ALIGNMENT, then
  RESTORE_PROC_SEQU_IF (the caller's).

The alignment's attitude is numpy's float32 arctan2, sin and cos of the mean specific force
(:func:`~firmware_sim.nav.ins.alignment_quaternion`), which compiled code reaches only through
numba's object mode — and an object-mode block is compiled anew in every process that loads the
kernels from the cache (with numba's whole typing set-up: most of a cache load). So the loop
compiles INITIAL_ALIGNMENT with the mean handed over instead: in the loop that completes the
alignment it leaves the mean in the INS's work (``align_mean``, ``attitude_due``) and returns, and
the caller sets QUATERNION from it with the reference
(:func:`~firmware_sim.nav.loop_kinds.finish_alignment`) before anything reads it. The kernel
``ins_kernels.initial_alignment`` is the whole function.
"""

from __future__ import annotations

import numpy as np

from protocol.ids import NR_IMUS

from .frontend import FrontendWork
from .frontend_kernels import biasest, convcomp, preproc, statdet
from .inertial import InertialWork
from .ins import HeightWork, InsWork
from .ins import initial_alignment as _reference_alignment
from .ins_kernels import (
    clear_stance,
    foot_angles,
    height_compensation,
    mechanization,
    pack_p,
    stepwise_reset,
    time_update,
    zupt_update,
)
from .jit import bytes_at, compiled_reference, kernel
from .loop_kinds import (
    ALIGNMENT,
    FULL_RATE_INS,
    HEIGHT_AFTER_OUTPUT,
    NO_SAMPLES,
    TRACKING,
    TRACKING_HEIGHT,
    finish_alignment,
)
from .records import STATE_RECORD

__all__ = ["ALIGNMENT", "FULL_RATE_INS", "HEIGHT_AFTER_OUTPUT", "NO_SAMPLES", "RECORD_SIZES",
           "RUN_GROUP_SIGNATURE", "RUN_LOOPS_SIGNATURE", "TRACKING", "TRACKING_HEIGHT", "finish_alignment",
           "run_group", "run_loops"]

#: The argument types every caller gives :func:`run_loops` (the loop built ahead of time takes
#: exactly these: :mod:`firmware_sim.nav.aot`).
RUN_LOOPS_SIGNATURE = ("int64(int64, int64, int16[:, :, ::1], int64, int64, int64, uint8[::1], uint8[::1], "
                       "uint8[::1], uint8[::1], uint8[::1])")



@kernel
def latch(imu, raw, prev_acc, have_prev):
    """:func:`~firmware_sim.nav.inertial.latch_registers` element by element (the same int16 copies,
    without the slices' array views, which cost as much as the copies): the gyro as read, the
    accelerometer the previous read's, or on the very first read the current one."""
    first = not have_prev[0]
    for c in range(NR_IMUS):
        for a in range(3):
            raw[c, a] = imu[c, a] if first else prev_acc[c, a]
            prev_acc[c, a] = imu[c, a]
            raw[c, 3 + a] = imu[c, 3 + a]
    have_prev[0] = True
#: The work records' types (compiled code takes a dtype, not a class).
_FRONTEND_WORK, _INS_WORK, _INERTIAL_WORK = FrontendWork.DTYPE, InsWork.DTYPE, InertialWork.DTYPE
_HEIGHT_WORK = HeightWork.DTYPE
#: The bytes of each record :func:`run_loops` takes, in its order (:func:`run_group` reaches them by
#: address).
RECORD_SIZES = tuple(d.itemsize for d in (STATE_RECORD, _FRONTEND_WORK, _INS_WORK, _INERTIAL_WORK,
                                          _HEIGHT_WORK))
_STATE_SIZE, _FRONTEND_SIZE, _INS_SIZE, _INERTIAL_SIZE, _HEIGHT_SIZE = RECORD_SIZES
#: The bytes of one loop's registers (NR_IMUS × 6 int16).
_SAMPLE_SIZE = NR_IMUS * 6 * 2
#: :func:`run_group`'s argument types (exported by the loop built ahead of time too).
RUN_GROUP_SIGNATURE = "int64(int64[::1], int64[::1], int64[:, ::1], int64[:, ::1], int64[::1])"


@kernel
def front_end(s, fw):
    """PREPROC, STATDET, BIASEST, CONVCOMP of the sample in the raw states (*s*: the states,
    *fw*: the front end's work)."""
    preproc(s.imu_raw[:NR_IMUS], fw.cal, fw.bias, s.u_new, s.u_k)
    out = fw.stat_out
    statdet(s.u_new, np.int64(s.imu_ts[0]), fw.buf32, fw.buf16, fw.norm, fw.ts, fw.newest, fw.zaru_ab,
            fw.zaru_cd, fw.zupt_a, fw.zupt_cd, np.int64(s.th_zupt[0]), np.int64(s.th_zaru[0]), s.u_int_k, out)
    s.t1s2f[0] = out[0]
    s.t2s2f[0] = out[1]
    s.zupt[0] = out[2] != 0
    s.zaru[0] = out[3] != 0
    s.t_int_k[0] = out[4]
    biasest(s.u_int_k, s.zaru[0] != 0, fw.gyro_bias, fw.bias_p, fw.bias_q)
    convcomp(s.u_int_k, np.int64(s.t_int_k[0]), fw.gyro_bias, fw.t_prev, s.u_k, s.dt)


@kernel
def _mean_for_caller(f_mean):
    """Stands for alignment_quaternion in the loop's INITIAL_ALIGNMENT: the mean itself (and NaN),
    which :func:`alignment` moves to the INS's work for the caller."""
    q = np.full(4, np.nan, dtype=np.float32)
    q[0:3] = f_mean
    return q


_initial_alignment = compiled_reference(_reference_alignment, alignment_quaternion=_mean_for_caller,
                                        pack_p=pack_p, foot_angles=foot_angles)


@kernel
def alignment(s, iw, hw):
    """INITIAL_ALIGNMENT (*iw*: the INS's work); sets INIT_DONE, clears HEIGHT_COMPENSATION's stance
    (*hw*) and returns True when complete, the attitude then due from the caller
    (:func:`~firmware_sim.nav.loop_kinds.finish_alignment`)."""
    done = _initial_alignment(s.u_k[0:3], s.zupt[0] != 0, iw, s.position, s.velocity, s.quaternion, s.p,
                              s.theta_init, s.theta_ground)
    if done:
        iw.align_mean[:] = s.quaternion[0:3]
        iw.attitude_due[0] = True
        s.init_done[0] = True
        clear_stance(hw)
    return done


@kernel
def step_reset(s, iw):
    """STEPWISE_SYSTEM_RESET: FILTER_RESET_FLAG, and STEP_COUNTER + 1 when a step ends; returns the flag."""
    flag = stepwise_reset(s.zupt[0] != 0, s.dt[0], iw, s.position, s.quaternion, s.p, s.dx, s.dp,
                          s.swing_time)
    s.filter_reset_flag[0] = flag
    if flag:
        s.step_counter[0] = (np.int64(s.step_counter[0]) + 1) & 0xFFFF
    return flag


@kernel
def navigation(s, iw):
    """MECHANIZATION, TIME_UPDATE, and ZUPT_UPDATE while ZUPT."""
    mechanization(s.u_k, s.dt[0], s.zaru[0] != 0, s.position, s.velocity, s.quaternion, iw.f_n)
    time_update(iw.f_n, s.dt[0], s.zaru[0] != 0, s.p, iw.p_full, iw.noise)
    if s.zupt[0] != 0:
        zupt_update(s.position, s.velocity, s.quaternion, s.p, iw.p_full, s.dt[0], iw.noise)


@kernel
def slope_height(s, iw, hw):
    """HEIGHT_COMPENSATION (*hw*: its work)."""
    height_compensation(s.zupt[0] != 0, s.u_k[0:3], s.dt[0], hw, s.position, s.velocity, s.quaternion, s.p,
                        iw.p_full, s.theta_init, s.theta_ground)


@kernel
def run_loops(kind, n, imu, first_wake, period, ts_offset, memory, frontend_work, ins_work, inertial_work,
              height_work):
    """The numeric slots of up to *n* loops of the sequence *kind*; returns the loops run.

    Loop i reads the registers ``imu[i]`` (READ_INERTIAL: the accelerometer one read late,
    IMU_TS the cycle counter at ``first_wake + i·period + ts_offset``); with no registers
    (``NO_SAMPLES``) the caller has read the one loop's sample. Stops after a loop in which
    a step ends (TRACKING, TRACKING_HEIGHT: before that loop's HEIGHT_COMPENSATION) or the
    alignment completes (ALIGNMENT). *kind* ``HEIGHT_AFTER_OUTPUT`` runs only that
    HEIGHT_COMPENSATION (no sample; returns 1). *memory* is the bytes of the state memory's
    arena, the work arguments the bytes of the FrontendWork, InsWork, InertialWork and
    HeightWork records (uint8 arrays; a numpy.recarray of them in plain Python).
    """
    s = memory.view(STATE_RECORD)[0]
    fw = frontend_work.view(_FRONTEND_WORK)[0]
    iw = ins_work.view(_INS_WORK)[0]
    rw = inertial_work.view(_INERTIAL_WORK)[0]
    hw = height_work.view(_HEIGHT_WORK)[0]
    if kind == HEIGHT_AFTER_OUTPUT:
        slope_height(s, iw, hw)
        return 1
    for i in range(n):
        if len(imu):
            latch(imu[i], s.imu_raw, rw.prev_acc, rw.have_prev)
            s.imu_ts[0] = (first_wake + i * period + ts_offset) & 0xFFFFFFFF
        front_end(s, fw)
        if kind == ALIGNMENT:
            if alignment(s, iw, hw):
                return i + 1
        elif kind == TRACKING or kind == TRACKING_HEIGHT:
            step_ended = step_reset(s, iw)
            navigation(s, iw)
            if step_ended:
                return i + 1
            if kind == TRACKING_HEIGHT:
                slope_height(s, iw, hw)
        else:
            navigation(s, iw)
    return n


@kernel
def run_group(kinds, ns, clocks, addresses, done):
    """:func:`run_loops` of K modules in one call, one module after the other: each module's loops
    exactly as it runs them alone (the same kernels, in the same order, on its own records).

    Module k runs up to ``ns[k]`` (at least 1) loops of the sequence ``kinds[k]``; ``clocks[k]`` is
    its ``(first_wake, period, ts_offset)``; ``addresses[k]`` the addresses of its register block
    (``ns[k]`` × NR_IMUS × 6 int16, C order) and of its five records, in :func:`run_loops`'s order
    (sizes :data:`RECORD_SIZES`). ``done[k]`` receives the loops module k ran. Returns K.
    """
    for k in range(len(kinds)):
        a = addresses[k]
        n = ns[k]
        imu = bytes_at(a[0], n * _SAMPLE_SIZE).view(np.int16).reshape((n, NR_IMUS, 6))
        done[k] = run_loops(kinds[k], n, imu, clocks[k, 0], clocks[k, 1], clocks[k, 2],
                            bytes_at(a[1], _STATE_SIZE), bytes_at(a[2], _FRONTEND_SIZE),
                            bytes_at(a[3], _INS_SIZE), bytes_at(a[4], _INERTIAL_SIZE),
                            bytes_at(a[5], _HEIGHT_SIZE))
    return len(kinds)
