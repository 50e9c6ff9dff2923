"""The kernel of :mod:`~firmware_sim.nav.slot_loop`: the numeric slots of any sequence, one by one.

Compiled with numba when it is there (it imports :mod:`~firmware_sim.nav.jit`); the rest of the
emulator reaches it through :func:`firmware_sim.nav.slot_loop.slots_runner`, which prefers the
module built ahead of time.
"""

from __future__ import annotations

import numpy as np

from protocol.ids import NR_IMUS, ProcId

from .driver import alignment, slope_height, step_reset
from .frontend import FrontendWork
from .frontend_kernels import biasest, convcomp, preproc, statdet
from .ins import HeightWork, InsWork
from .ins_kernels import mechanization, time_update, zupt_update
from .jit import kernel
from .records import STATE_RECORD

__all__ = ["run_slots"]

_FRONTEND_WORK, _INS_WORK, _HEIGHT_WORK = FrontendWork.DTYPE, InsWork.DTYPE, HeightWork.DTYPE
_PREPROC, _STATDET, _BIASEST, _CONVCOMP = (int(ProcId.FRONTEND_PREPROC), int(ProcId.FRONTEND_STATDET),
                                           int(ProcId.FRONTEND_BIASEST), int(ProcId.FRONTEND_CONVCOMP))
_ALIGNMENT, _MECHANIZATION, _TIME_UPDATE, _ZUPT_UPDATE = (
    int(ProcId.FRONTEND_INITIAL_ALIGNMENT), int(ProcId.MECHANIZATION), int(ProcId.TIME_UPDATE),
    int(ProcId.ZUPT_UPDATE))
_STEP_RESET, _HEIGHT = int(ProcId.STEPWISE_SYSTEM_RESET), int(ProcId.HEIGHT_COMPENSATION)


@kernel
def run_slots(slots, start, stop, memory, frontend_work, ins_work, height_work):
    """The processing functions of ``slots[start:stop]`` (ids; 0: an empty slot) in order, each as
    its processing function runs it; returns the slot after the last one run: *stop*, or the slot
    after an INITIAL_ALIGNMENT that completed the alignment (its attitude then due from the caller).
    Every id in the range is 0 or one of :data:`~firmware_sim.nav.slot_loop.COMPILED_SLOTS`. The
    records' bytes as :func:`~firmware_sim.nav.driver.run_loops` takes them (the state memory, the
    works of the front end, the INS and HEIGHT_COMPENSATION)."""
    s = memory.view(STATE_RECORD)[0]
    fw = frontend_work.view(_FRONTEND_WORK)[0]
    iw = ins_work.view(_INS_WORK)[0]
    hw = height_work.view(_HEIGHT_WORK)[0]
    for j in range(start, stop):
        pid = slots[j]
        if pid == _PREPROC:
            preproc(s.imu_raw[:NR_IMUS], fw.cal, fw.bias, s.u_new, s.u_k)
        elif pid == _STATDET:
            out = fw.stat_out
            statdet(s.u_new, np.int64(s.imu_ts[0]), fw.buf32, fw.buf16, fw.norm, fw.ts, fw.newest, fw.zaru_ab,
                    fw.zaru_cd, fw.zupt_a, fw.zupt_cd, np.int64(s.th_zupt[0]), np.int64(s.th_zaru[0]),
                    s.u_int_k, out)
            s.t1s2f[0] = out[0]
            s.t2s2f[0] = out[1]
            s.zupt[0] = out[2] != 0
            s.zaru[0] = out[3] != 0
            s.t_int_k[0] = out[4]
        elif pid == _BIASEST:
            biasest(s.u_int_k, s.zaru[0] != 0, fw.gyro_bias, fw.bias_p, fw.bias_q)
        elif pid == _CONVCOMP:
            convcomp(s.u_int_k, np.int64(s.t_int_k[0]), fw.gyro_bias, fw.t_prev, s.u_k, s.dt)
        elif pid == _ALIGNMENT:
            if alignment(s, iw, hw):
                return j + 1
        elif pid == _MECHANIZATION:
            mechanization(s.u_k, s.dt[0], s.zaru[0] != 0, s.position, s.velocity, s.quaternion, iw.f_n)
        elif pid == _TIME_UPDATE:
            time_update(iw.f_n, s.dt[0], s.zaru[0] != 0, s.p, iw.p_full, iw.noise)
        elif pid == _ZUPT_UPDATE:
            if s.zupt[0] != 0:
                zupt_update(s.position, s.velocity, s.quaternion, s.p, iw.p_full, s.dt[0], iw.noise)
        elif pid == _STEP_RESET:
            step_reset(s, iw)
        elif pid == _HEIGHT:
            slope_height(s, iw, hw)
    return stop
