"""The inertial front end: integer preprocessing and zero-velocity detection (firmware.md §3).

Processing functions, in sequence order:

* **FRONTEND_PREPROC (0x10)** — per chip a Q14 3×3 calibration of the
  accelerometer and of the gyro (chip axes → board axes), the four chips summed
  and shifted right by 2, the static bias subtracted: U_NEW (0x10), int32, raw
  LSB · 2^14. Also U_K (0x13) = float32(U_NEW) · scale for the plain IMU mode.
* **FRONTEND_STATDET (0x11)** — ring buffer of the last N combined samples,
  each also reduced to int16 with its squared norms; running sums over the
  ZUPT window (M samples centred in the buffer) and the ZARU window (all N);
  T1 (0x15) the SHOE / GLRT statistic, T2 (0x16) the total variance;
  ZUPT (0x17) = T1 < TH_ZUPT (0x19), ZARU (0x18) = ZUPT and T2 < TH_ZARU (0x1A);
  U_INT_K / T_INT_K (0x11 / 0x12) = the sample in the middle of the window.
* **FRONTEND_BIASEST (0x12)** — float32 scalar Kalman filter of the gyro bias
  from the middle sample while ZARU.
* **FRONTEND_CONVCOMP (0x14)** — U_K = float32(U_INT_K) · scale − gyro bias;
  DT (0x14) = float32((T_INT_K − previous) mod 2^32) / 64e6.
* **FRONTEND_CONV16 (0x15)** — U_INT16_K (0x1B) = U_K in int16 register units.

Every stored integer is an int32 / uint32 (int16 for reduced samples) that wraps
like C; intermediates that need it are 64-bit (the µC's 32 × 32 → 64 multiply).
The constants and the overflow proof are in :mod:`firmware_sim.nav.config`.

Layout for speed: the per-sample state of the front end lives in the flat typed
arrays of :class:`FrontendWork` (one record per module, ``module.work("frontend", …)``);
the array-level functions (``preproc``, ``statdet``, …) are plain functions over arrays and
scalars, free of object churn. Their compiled counterparts, of the same names and
arguments, are in :mod:`firmware_sim.nav.frontend_kernels`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from firmware_sim.mcu.sequence import processing_function
from protocol.ids import NR_IMUS, ProcId, StateId

from . import config as cfg
from .records import WorkRecord

if TYPE_CHECKING:  # pragma: no cover
    from firmware_sim.mcu.module import Module

__all__ = [
    "FrontendWork",
    "frontend_work",
    "apply_state_defaults",
    "isqrt64",
    "preproc",
    "statdet",
    "biasest",
    "convcomp",
    "conv16",
    "statistic_t1",
    "statistic_t2",
]

_M32 = 0xFFFFFFFF
_U32_MAX = 0xFFFFFFFF


def _i32(x: int) -> int:
    """C int32 wraparound of an integer."""
    return ((x + 0x80000000) & _M32) - 0x80000000


def isqrt64(x: int) -> int:
    """floor(√x) of a uint64, bit by bit (the µC's integer square root; no float)."""
    res = 0
    bit = 1 << 62
    while bit > x:
        bit >>= 2
    while bit:
        if x >= res + bit:
            x -= res + bit
            res = (res >> 1) + bit
        else:
            res >>= 1
        bit >>= 2
    return res


class FrontendWork(WorkRecord):
    """The front end's private per-sample state (flat typed arrays in one record, one per module).

    Ring buffer of N samples: ``buf32`` the int32 combined sample, ``buf16`` its
    int16 reduction, ``norm`` the squared norms of the reduced accelerometer and
    gyro triples (uint32), ``ts`` the timestamps. ``newest`` is the slot of the
    newest sample. Running sums (wrapping like C): ``zaru_ab`` (int32, Σ of the
    reduced acc xyz and gyro xyz over all N), ``zaru_cd`` (uint32, Σ of the norms'
    low 16 bits for acc, gyro, then of their high 16 bits), ``zupt_a`` and
    ``zupt_cd`` the same over the M-sample ZUPT window (accelerometer sum only).
    ``cal`` and ``bias`` are PREPROC's calibration, ``gyro_bias`` and ``bias_p`` BIASEST's
    estimate, ``t_prev`` CONVCOMP's previous T_INT_K, ``stat_out`` STATDET's results.
    """

    FIELDS = (
        ("cal", np.int32, (NR_IMUS, 2, 3, 3)), ("bias", np.int32, (6,)),
        ("buf32", np.int32, (cfg.N, 6)), ("buf16", np.int16, (cfg.N, 6)), ("norm", np.uint32, (cfg.N, 2)),
        ("ts", np.uint32, (cfg.N,)), ("newest", np.int32, (1,)),
        ("zaru_ab", np.int32, (6,)), ("zaru_cd", np.uint32, (4,)), ("zupt_a", np.int32, (3,)),
        ("zupt_cd", np.uint32, (4,)),
        ("gyro_bias", np.float32, (3,)),  # BIASEST estimate [rad/s]
        ("bias_p", np.float32, (1,)),
        ("bias_q", np.float32, (1,)),  # BIASEST's growth of bias_p per loop cycle
        ("t_prev", np.uint32, (1,)),  # CONVCOMP's previous T_INT_K
        ("stat_out", np.uint32, (5,)),  # STATDET's T1, T2, ZUPT, ZARU, T_INT_K
    )

    def __init__(self, config: cfg.FrontendConfig = cfg.DEFAULT_FRONTEND):
        super().__init__()
        self.config = config
        self.cal[...] = config.calibration  # (chips, 2, 3, 3)
        self.bias[...] = config.bias  # (6,)
        self.bias_p[0] = config.gyro_bias_p0
        self.bias_q[0] = config.gyro_bias_q

    def __repr__(self) -> str:
        return f"FrontendWork(N={cfg.N}, M={cfg.M}, newest={int(self.newest[0])})"


def frontend_work(module: Module) -> FrontendWork:
    """The module's front-end state (created on first use from ``module.config.frontend``)."""
    conf = getattr(getattr(module, "config", None), "frontend", None) or cfg.DEFAULT_FRONTEND
    return module.work("frontend", lambda: FrontendWork(conf))


def apply_state_defaults(memory) -> None:
    """Power-on values of the front end's settable states: TH_ZUPT (0x19), TH_ZARU (0x1A)."""
    memory[StateId.TH_ZUPT][...] = cfg.TH_ZUPT_DEFAULT
    memory[StateId.TH_ZARU][...] = cfg.TH_ZARU_DEFAULT


# ---------------------------------------------------------------------------------------------
# kernels


def preproc(raw: np.ndarray, cal: np.ndarray, bias: np.ndarray, u_new: np.ndarray, u_k: np.ndarray) -> None:
    """PREPROC: raw int16 (chips, 6) → U_NEW int32 (6,) and U_K float32 (6,).

    Per chip and sensor: 3 products int16 × Q14 summed in a 64-bit accumulator;
    the four chips summed (64 bits), arithmetic ``>> 2``, narrowed to int32, bias
    subtracted with int32 wraparound (cannot wrap for a valid FrontendConfig).
    """
    # (sensor, axis) sums over the chips and the row: integers, exact in any order
    sums = np.einsum("ksij,ksj->si", cal.astype(np.int64), raw.reshape(-1, 2, 3).astype(np.int64)).ravel()
    for i in range(6):
        u_new[i] = _i32(_i32(int(sums[i]) >> cfg.LOG2_NR_IMUS) - int(bias[i]))
    u_k[0:3] = u_new[0:3].astype(np.float32) * cfg.ACC_SCALE
    u_k[3:6] = u_new[3:6].astype(np.float32) * cfg.GYRO_SCALE


def _add_sample(ab: np.ndarray, cd: np.ndarray, s16: np.ndarray, norm: np.ndarray, sign: int,
                n: int) -> None:
    """Add (sign=+1) or remove (−1) one buffered sample from a window's running sums.

    ``ab[:n]`` (int32) accumulates the reduced sample's first *n* components;
    ``cd`` (uint32) the low and high 16 bits of its two squared norms. Both wrap
    modulo 2^32 like C (64-bit intermediate, narrowed by truncation).
    """
    add = np.add if sign > 0 else np.subtract  # numpy's int32 and uint32 arithmetic wraps as C's
    add(ab[:n], s16[:n], out=ab[:n])
    add(cd, np.concatenate((norm & 0xFFFF, norm >> 16)), out=cd)


def _sumsq3(v: np.ndarray, off: int) -> int:
    """Σ v[off+i]² of three int32 sums in a 64-bit intermediate."""
    a, b, c = int(v[off]), int(v[off + 1]), int(v[off + 2])
    return a * a + b * b + c * c


def _sat_u32(x: int) -> int:
    return 0 if x < 0 else (_U32_MAX if x > _U32_MAX else x)


def statistic_t1(zupt_a: np.ndarray, zupt_cd: np.ndarray, log2m: int, g_red: int, sr_q: int,
                 sr_shift: int) -> int:
    """T1 = C/M − 2g‖A‖/M + g² + SR·D/M over the ZUPT window (uint32, LSB_f²).

    C, D are recombined from their low/high 16-bit sums (64-bit intermediate);
    ‖A‖ is the integer square root of the 64-bit Σ A_i².
    """
    c = (int(zupt_cd[2]) << 16) + int(zupt_cd[0])
    d = (int(zupt_cd[3]) << 16) + int(zupt_cd[1])
    norm_a = isqrt64(_sumsq3(zupt_a, 0))
    t1 = (c >> log2m) - ((2 * g_red * norm_a) >> log2m) + g_red * g_red + ((sr_q * (d >> log2m)) >> sr_shift)
    return _sat_u32(t1)


def statistic_t2(zaru_ab: np.ndarray, zaru_cd: np.ndarray, log2n: int, sr_q: int, sr_shift: int) -> int:
    """T2 = (C/N − ‖A/N‖²) + SR·(D/N − ‖B/N‖²) over the whole buffer (uint32, LSB_f²)."""
    c = (int(zaru_cd[2]) << 16) + int(zaru_cd[0])
    d = (int(zaru_cd[3]) << 16) + int(zaru_cd[1])
    var_f = (c >> log2n) - (_sumsq3(zaru_ab, 0) >> (2 * log2n))
    var_g = (d >> log2n) - (_sumsq3(zaru_ab, 3) >> (2 * log2n))
    return _sat_u32(var_f + ((sr_q * var_g) >> sr_shift))


def statdet(u_new: np.ndarray, ts: int, buf32: np.ndarray, buf16: np.ndarray, norm: np.ndarray,
            tsbuf: np.ndarray, newest: np.ndarray, zaru_ab: np.ndarray, zaru_cd: np.ndarray,
            zupt_a: np.ndarray, zupt_cd: np.ndarray, th_zupt: int, th_zaru: int,
            u_int_k: np.ndarray, out: np.ndarray) -> None:
    """STATDET: push U_NEW into the ring buffer, update the windows, decide ZUPT / ZARU.

    ``out`` (uint32, 5): T1, T2, ZUPT, ZARU, T_INT_K. ``u_int_k`` receives the
    sample in the middle of the buffer (the one the windows are centred on).
    Window layout (slot indices modulo N, newest = j): the ZARU window is
    j−N+1 … j; the judged sample is k = j − N/2; the ZUPT window is
    k − M/2 + 1 … k + M/2. Order as on the µC: remove the leaving samples,
    overwrite the oldest slot, add the entering samples. The arrays are those of
    :class:`FrontendWork` (ring buffer, newest slot, running sums), passed one by
    one so the kernel is a plain function over arrays and scalars.
    """
    nm = cfg.N - 1
    half_n = cfg.N >> 1
    half_m = cfg.M >> 1
    j_old = int(newest[0])
    j = (j_old + 1) & nm
    # leaving: the oldest sample (ZARU) and the first of the old ZUPT window
    _add_sample(zaru_ab, zaru_cd, buf16[j], norm[j], -1, 6)
    z_out = (j_old - half_n - half_m + 1) & nm
    _add_sample(zupt_a, zupt_cd, buf16[z_out], norm[z_out], -1, 3)
    # store the newest sample, reduced to int16, with its squared norms
    s16 = buf16[j]
    for i in range(3):
        buf32[j, i] = u_new[i]
        buf32[j, 3 + i] = u_new[3 + i]
        s16[i] = int(u_new[i]) >> cfg.RED_SHIFT_F
        s16[3 + i] = int(u_new[3 + i]) >> cfg.RED_SHIFT_G
    norm[j, 0] = _sumsq3(s16, 0)
    norm[j, 1] = _sumsq3(s16, 3)
    tsbuf[j] = ts
    newest[0] = j
    # entering: the newest sample (ZARU) and the last of the new ZUPT window
    _add_sample(zaru_ab, zaru_cd, buf16[j], norm[j], +1, 6)
    z_in = (j - half_n + half_m) & nm
    _add_sample(zupt_a, zupt_cd, buf16[z_in], norm[z_in], +1, 3)
    # statistics and decisions
    t1 = statistic_t1(zupt_a, zupt_cd, cfg.LOG2_M, cfg.G_RED, cfg.SR_Q, cfg.SR_SHIFT)
    t2 = statistic_t2(zaru_ab, zaru_cd, cfg.LOG2_N, cfg.SR_Q, cfg.SR_SHIFT)
    zupt = t1 < th_zupt
    zaru = zupt and t2 < th_zaru
    k = (j - half_n) & nm
    u_int_k[:] = buf32[k]
    out[0] = t1
    out[1] = t2
    out[2] = zupt
    out[3] = zaru
    out[4] = tsbuf[k]


def biasest(u_int_k: np.ndarray, zaru: bool, gyro_bias: np.ndarray, p: np.ndarray, q: np.ndarray) -> None:
    """BIASEST: P += Q (``q[0]``); while ZARU: K = P/(P+R), b += K(ω − b), ``P *= 1 − K`` (float32)."""
    p[0] = p[0] + q[0]
    if zaru:
        omega = u_int_k[3:6].astype(np.float32) * cfg.GYRO_SCALE
        k = p[0] / (p[0] + cfg.BIAS_R)
        gyro_bias[:] = gyro_bias + k * (omega - gyro_bias)
        p[0] = p[0] * (np.float32(1.0) - k)


def convcomp(u_int_k: np.ndarray, t_int_k: int, gyro_bias: np.ndarray, t_prev: np.ndarray,
             u_k: np.ndarray, dt: np.ndarray) -> None:
    """CONVCOMP: U_K = float32(U_INT_K)·scale − gyro bias; DT = float32(ΔT mod 2^32)/64e6."""
    u_k[0:3] = u_int_k[0:3].astype(np.float32) * cfg.ACC_SCALE
    u_k[3:6] = u_int_k[3:6].astype(np.float32) * cfg.GYRO_SCALE - gyro_bias
    dt[...] = np.float32((t_int_k - int(t_prev[0])) & _M32) / cfg.CPU_HZ
    t_prev[0] = t_int_k


def conv16(u_k: np.ndarray, u16: np.ndarray) -> None:
    """CONV16: U_K → int16 in register units (1/2048 g, 1/16.4 °/s), truncated, saturated."""
    acc = u_k[0:3] * cfg.CONV16_ACC
    gyr = u_k[3:6] * cfg.CONV16_GYRO
    u16[0:3] = np.clip(np.trunc(acc), -32768, 32767).astype(np.int16)
    u16[3:6] = np.clip(np.trunc(gyr), -32768, 32767).astype(np.int16)


# ---------------------------------------------------------------------------------------------
# processing functions (registered in the module's sequence registry)


@processing_function(ProcId.FRONTEND_PREPROC, cycles=1800)
def frontend_preproc(module: Module) -> None:
    """0x10: calibrate, average and bias-compensate the four chips' raw samples."""
    w = frontend_work(module)
    mem = module.memory
    preproc(mem.imu_raw[:NR_IMUS], w.cal, w.bias, mem[StateId.U_NEW], mem[StateId.U_K])


@processing_function(ProcId.FRONTEND_STATDET, cycles=2600)
def frontend_statdet(module: Module) -> None:
    """0x11: zero-velocity (ZUPT) and zero-angular-rate (ZARU) detection."""
    w = frontend_work(module)
    mem = module.memory
    out = w.stat_out
    statdet(mem[StateId.U_NEW], int(mem[StateId.IMU_TS]), w.buf32, w.buf16, w.norm, w.ts, w.newest,
            w.zaru_ab, w.zaru_cd, w.zupt_a, w.zupt_cd, int(mem[StateId.TH_ZUPT]),
            int(mem[StateId.TH_ZARU]), mem[StateId.U_INT_K], out)
    mem[StateId.T1S2F][...] = out[0]
    mem[StateId.T2S2F][...] = out[1]
    mem[StateId.ZUPT][...] = bool(out[2])
    mem[StateId.ZARU][...] = bool(out[3])
    mem[StateId.T_INT_K][...] = out[4]


@processing_function(ProcId.FRONTEND_BIASEST, cycles=700)
def frontend_biasest(module: Module) -> None:
    """0x12: gyro bias estimation while the foot is perfectly still (ZARU)."""
    w = frontend_work(module)
    mem = module.memory
    biasest(mem[StateId.U_INT_K], bool(mem[StateId.ZARU]), w.gyro_bias, w.bias_p, w.bias_q)


@processing_function(ProcId.FRONTEND_CONVCOMP, cycles=600)
def frontend_convcomp(module: Module) -> None:
    """0x14: the filter's input U_K (float32, bias-compensated) and its time step DT."""
    w = frontend_work(module)
    mem = module.memory
    convcomp(mem[StateId.U_INT_K], int(mem[StateId.T_INT_K]), w.gyro_bias, w.t_prev,
             mem[StateId.U_K], mem[StateId.DT])


@processing_function(ProcId.FRONTEND_CONV16, cycles=250)
def frontend_conv16(module: Module) -> None:
    """0x15: U_INT16_K, the filter input in int16 register units. A U_K that is not finite (a
    host's SET_STATE of it, with this function run without CONVCOMP before it) is converted as
    numpy converts it, without numpy's warning (C leaves that conversion undefined)."""
    mem = module.memory
    with np.errstate(all="ignore"):
        conv16(mem[StateId.U_K], mem[StateId.U_INT16_K])
