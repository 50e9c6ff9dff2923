"""Every tuning constant of the navigation firmware (front end and INS), in one place.

Two groups, as on the module:

* **Front end** (firmware.md §3, integer): fixed-point formats, the zero-velocity
  detector's windows, shifts and weights, the default thresholds TH_ZUPT /
  TH_ZARU (states 0x19 / 0x1A, which the host may overwrite), the array
  calibration (Q14) and the static bias. :class:`FrontendConfig` bundles the
  per-board part (calibration, bias); the rest are build-time constants.
* **INS** (firmware.md §4, float32): every constant is a ``numpy.float32``
  so that no float64 can leak into the float32 arithmetic of the filter.

Units of the integer front end
------------------------------
``U_NEW`` (state 0x10) is the calibrated array mean in **raw LSB · 2^14**
(the Q14 calibration keeps its 14 fraction bits): 1 g = 2048 · 2^14 = 2^25,
1 °/s = 16.4 · 2^14. The detector works on samples reduced by
``RED_SHIFT`` = 16 bits to int16: one reduced accelerometer unit ("LSB_f") is
2^-9 g = 19.2 mm/s², one reduced gyro unit ("LSB_g") is 4/16.4 °/s = 4.26 mrad/s.
T1 (0x15) and T2 (0x16) are in LSB_f² (uint32).

Overflow budget (proved by tests/nav/test_frontend_overflow.py)
---------------------------------------------------------------
* PREPROC: per chip 3 products int16 × Q14 in a 64-bit accumulator, four chips
  summed in 64 bits, ``>> 2``, then narrowed: fits int32 whenever every row of
  every calibration matrix has an absolute sum ≤ ``CAL_ROW_ABS_MAX`` = 1.5 (Q14
  24576) — real calibrations are ≈ 1.0 — because |mean| ≤ 32768 · 1.5 · 2^14
  = 1.5 · 2^29, and |static bias| ≤ ``BIAS_ABS_MAX`` = 2^27 (4 g / 500 °/s):
  |U_NEW| ≤ 1.75 · 2^29 < 2^30.
* Reduction ``>> 16``: |reduced| ≤ 1.75 · 2^13 < 2^14 → int16; saturated
  default board: ±2^13 = 8192.
* Squared norm of a reduced triple < 3 · (1.75 · 2^13)^2 < 2^29.2 → uint32. The
  running sums keep the norms split into their low and high 16 bits (two uint32
  sums each, as the module's firmware does): < N · 2^16 and < N · 2^13.2, so no
  window up to 2^15 samples can wrap them; A, B (sums of N int16) < 2^19 → int32.
* ‖A‖² (3 squares of int32 sums) < 2^40 in a 64-bit intermediate (32 × 32 → 64);
  its integer square root < 2^20. Every term of T1 and T2 is < 2^31 (C/M, SR·D/M
  < 2^30.2, 2g‖A‖/M < 2^25, g² = 2^18), so T1, T2 < 2^32 fit uint32; they are
  evaluated in 64 bits, and the only value outside uint32 reachable is the −1 of
  truncation when a statistic is exactly 0, stored as 0.

Detector constants, justified in tests/nav/test_fidelity.py on the walks
-------------------------------------------------------------------------
The statistic is the SHOE / GLRT of Skog et al. (2010) as in the OpenShoe MATLAB
reference (GLRT, σ_a = 0.01 m/s², σ_g = 0.1 °/s, window W = 3 at 250 Hz,
γ = 0.3e5): T = (1/W) Σ ‖f − g f̄/‖f̄‖‖²/σ_a² + ‖ω‖²/σ_g². Ours is the same
sum multiplied by σ_a² (in LSB_f²), so TH_ZUPT = γ σ_a² and SR = σ_a²/σ_g².
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from firmware_sim.board import MIMU22BT, Q14_ONE
from protocol.ids import NR_IMUS

# ---------------------------------------------------------------------------------------------
# front end: fixed point

#: Q14 calibration: 16384 = 1.0.
CAL_SHIFT = 14
#: log2 of the number of chips averaged (sum, then >> 2).
LOG2_NR_IMUS = 2
assert 1 << LOG2_NR_IMUS == NR_IMUS
#: Largest allowed absolute row sum of a calibration matrix (Q14): 1.5.
CAL_ROW_ABS_MAX = 3 * Q14_ONE // 2
#: Largest allowed |static bias| in U_NEW units: 2^27 (4 g, ≈ 500 °/s).
BIAS_ABS_MAX = 1 << 27

#: Raw accelerometer LSB per g and gyro LSB per °/s (MPU9150 at ±16 g / ±2000 °/s).
ACC_LSB_PER_G = 2048.0
GYRO_LSB_PER_DPS = 16.4
#: Standard gravity: the unit "g" of the accelerometer registers.
G0 = 9.80665

#: U_NEW (raw · 2^14) → m/s² and rad/s, float32 (CONVCOMP, PREPROC's U_K).
ACC_SCALE = np.float32(G0 / (ACC_LSB_PER_G * Q14_ONE))
GYRO_SCALE = np.float32(math.pi / 180.0 / (GYRO_LSB_PER_DPS * Q14_ONE))
#: CPU cycles per second (DT = cycles / 64e6).
CPU_HZ = np.float32(64e6)

#: Ring buffer: N = 2^LOG2_N samples (ZARU window, filter delay N/2).
LOG2_N = 5
N = 1 << LOG2_N
#: ZUPT window: M = 2^LOG2_M samples centred in the buffer.
LOG2_M = 2
M = 1 << LOG2_M
#: U_NEW → int16 reduction of the detector's samples (accelerometer, gyro).
RED_SHIFT_F = 16
RED_SHIFT_G = 16
#: Gravity in reduced accelerometer units (2^25 / 2^16 = 512 per g; 9.81 m/s² → 512.2).
G_RED = 512
#: SR = σ_a² / σ_g² in reduced units, Q8: σ_a = 0.01 m/s² = 0.522 LSB_f,
#: σ_g = 0.1 °/s = 0.41 LSB_g → SR = 1.62 → 415 / 256.
SR_SHIFT = 8
SR_Q = 415
#: Default thresholds (states 0x19, 0x1A), LSB_f². One window at γ σ_a² = 3e4 · 0.522² = 8172 is
#: stricter than the reference, which marks a sample stationary when ANY of the W windows holding it
#: passes; ≈ 2 γ σ_a² gives the reference's stance detection and accuracy on the six walks
#: (tests/nav/test_fidelity.py; 8172 → mean 0.57 %, walk 2 1.2 %; 16000 → 0.60 %, ≤ 0.94 %).
#: Neighbourhood (mean / worst walk, %): TH_ZUPT 15000 → 0.61 / 0.94, 17000 → 0.59 / 0.92;
#: TH_ZARU 14 → 0.56 / 0.89, 18 → 0.58 / 0.94; TH_ZARU 32 → 0.57 / 1.21 (ZARU in walking stances).
#: On the module's own sensors at 1 kHz, swaying stances, it misses no mid-stance sample and
#: accepts no mid-swing one (stance T1 ≤ 3300, 6800 running; ≥ 200000 between 20 % and 80 % of a
#: swing: ``python -m tests.oracle.threshold --simulated``, docs/accuracy.md).
TH_ZUPT_DEFAULT = 16000
#: TH_ZARU: total variance (acc + SR · gyro) in LSB_f²; on the walks T2 is 7–13 (5–95 %) while
#: standing and ≥ 88 (1st percentile) in walking stances: 16 = only a foot that is really still.
TH_ZARU_DEFAULT = 16

#: BIASEST: scalar Kalman filter of the gyro bias (float32, (rad/s)²).
BIAS_P0 = np.float32(4e-4)  # (0.02 rad/s)² a-priori uncertainty
BIAS_Q = np.float32(1e-11)  # per loop cycle: slow random walk of the bias
BIAS_R = np.float32(3e-6)  # one stationary gyro sample: (1.7 mrad/s)²

#: CONV16: U_K → int16, LSB 1/2048 g and 1/16.4 °/s (the registers' own units).
CONV16_ACC = np.float32(ACC_LSB_PER_G / G0)
CONV16_GYRO = np.float32(GYRO_LSB_PER_DPS * 180.0 / math.pi)


def _default_calibration() -> np.ndarray:
    cal = MIMU22BT.default_calibration_q14()  # (chips, 3, 3), one matrix per chip
    return np.stack([cal, cal], axis=1).astype(np.int32)  # (chips, 2, 3, 3): acc, gyro


@dataclass(frozen=True, eq=False)
class FrontendConfig:
    """The board's calibration for PREPROC.

    ``calibration[i, 0]`` / ``calibration[i, 1]``: chip *i*'s Q14 3×3 matrix for
    the accelerometer / gyro (raw chip axes → board axes, scale and
    misalignment); ``bias``: the static bias (int32, U_NEW units: acc xyz,
    gyro xyz) subtracted after averaging.
    """

    calibration: np.ndarray = field(default_factory=_default_calibration)
    bias: np.ndarray = field(default_factory=lambda: np.zeros(6, dtype=np.int32))
    #: BIASEST's a-priori variance of the gyro bias [(rad/s)²] and its growth per loop cycle: the
    #: module's own (BIAS_P0, BIAS_Q) for its uncalibrated MPU9150s; 0 and 0 for a sensor whose
    #: rates are already bias-compensated (nav.profiles), which it then leaves as they are.
    gyro_bias_p0: float = float(BIAS_P0)
    gyro_bias_q: float = float(BIAS_Q)

    def __post_init__(self) -> None:
        cal = np.asarray(self.calibration)
        if cal.shape != (NR_IMUS, 2, 3, 3):
            raise ValueError(f"calibration must be ({NR_IMUS}, 2, 3, 3) Q14, got {cal.shape}")
        row_abs = np.abs(cal.astype(np.int64)).sum(axis=-1)
        if row_abs.max() > CAL_ROW_ABS_MAX:
            raise ValueError(
                f"calibration row absolute sum {row_abs.max()} exceeds {CAL_ROW_ABS_MAX} (1.5 in Q14): "
                "U_NEW could overflow int32"
            )
        bias = np.asarray(self.bias)
        if bias.shape != (6,) or np.abs(bias.astype(np.int64)).max() > BIAS_ABS_MAX:
            raise ValueError(f"bias must be 6 int32 values within ±2^27, got {bias!r}")


DEFAULT_FRONTEND = FrontendConfig()

# ---------------------------------------------------------------------------------------------
# INS (float32 throughout), firmware.md §4 default tuning

F32 = np.float32
GRAVITY = F32(9.81)
SIGMA_ACC = F32(0.7)  # m/s²
SIGMA_GYRO = F32(0.017)  # rad/s
SIGMA_ZUPT = F32(0.1)  # m/s
SIGMA_P0 = F32(1e-5)  # m
SIGMA_V0 = F32(0.01)  # m/s
SIGMA_TH0 = F32(0.00174)  # rad
#: Step-wise reset: var(v_x) = P[24] threshold [(m/s)²], spacing and pending limit [s].
RESET_COV_THRESHOLD = F32(1e-4)
MIN_TIME_BETWEEN_RESETS = F32(0.75)
MAX_TIME_RESET_PENDING = F32(0.25)
#: Initial alignment: consecutive stationary samples averaged.
ALIGNMENT_SAMPLES = 256
#: The module's loop period T₀ [s]. The σ's above are per loop cycle at 1 kHz, as on the module
#: (Q = dt²·σ², R = σ²_zupt). At another loop rate (a 250 Hz replay) the filter keeps the same noise
#: per second: Q = dt·T₀·σ², R = σ²_zupt·T₀/dt — identical at 1 kHz. Without this, at 250 Hz the
#: steady-state var(v_x) under ZUPT (≈ √(QR) ≈ 2.8e-4) never falls below the reset threshold 1e-4
#: and no step would ever be sent.
NOMINAL_PERIOD = F32(1e-3)


@dataclass(frozen=True)
class InsNoise:
    """The filter's noise figures: σ_acc [m/s²] and σ_gyro [rad/s] of TIME_UPDATE, σ_zupt [m/s] of
    ZUPT_UPDATE, each per loop cycle of *period* [s]. At a loop of dt the filter uses
    Q = dt·period·σ² and R = σ²_zupt·period/dt: the figures' own at dt = period, the same noise per
    second at any other rate. The module's own (:data:`MODULE_INS_NOISE`) are firmware.md §4's at
    1 kHz; a recording of another sensor brings its own (:mod:`firmware_sim.nav.profiles`)."""

    sigma_acc: float
    sigma_gyro: float
    sigma_zupt: float
    period: float

    def as_array(self) -> np.ndarray:
        """The figures as the filter reads them: float32 [σ_acc, σ_gyro, σ_zupt, period]."""
        return np.array([self.sigma_acc, self.sigma_gyro, self.sigma_zupt, self.period], dtype=np.float32)


#: The module's own noise figures (firmware.md §4 default tuning, per 1 kHz loop cycle).
MODULE_INS_NOISE = InsNoise(float(SIGMA_ACC), float(SIGMA_GYRO), float(SIGMA_ZUPT), float(NOMINAL_PERIOD))

# ---------------------------------------------------------------------------------------------
# HEIGHT_COMPENSATION (0x25, an emulator extension): the step's height from the ground's slope
# (shared/spec/aids.md §5; docs/protocol-extensions.md)

#: Shortest stance [s] whose foot angle updates the slope estimate: shorter "stances" are blips
#: of the zero-velocity detector, not a foot lying on the ground.
MIN_SLOPE_STANCE_S = F32(0.05)
#: Shortest time [s] without ZUPT before a stance whose first loop takes the slope measurement: a
#: shorter gap is a blip of the zero-velocity detector within one stance (at the foot's landing it
#: breaks the stance into pieces a few ms apart), and the measurement is one per stance.
MIN_SLOPE_SWING_S = F32(0.05)
#: Blocks [s] in which a stance's specific force is summed; the stance's last one to two blocks
#: are left out of its foot angle: the zero-velocity detector holds ZUPT 30–50 ms past the end of
#: the stance (its window's half and its hold-over), into the push-off, where the heel has lifted.
SLOPE_TRIM_S = F32(0.05)
#: Steepest ground [rad] a stance's foot angle is taken as: 15°, beyond the steepest roads (about
#: 11°, 20 %) and ramps (4.8°, 1:12, for wheelchairs); a steeper "slope" is a foot that did not lie
#: flat (a turn on the toes, a foot on a stair's edge) and would throw the estimate off.
MAX_SLOPE = F32(15.0 * math.pi / 180.0)
#: Low-pass gain of the slope estimate, per stance: one bad stance moves it half way; a new
#: slope is 7/8 learnt after three stances.
SLOPE_LOWPASS = F32(0.5)
#: σ [m] of the slope model's height of a step: the foot's angle varies by about 0.4° from
#: stance to stance, 1 cm over a 1.4 m step.
SIGMA_SLOPE_HEIGHT = F32(0.01)
#: Largest |innovation| [m] the slope measurement is applied with: the rise of a step of
#: stairs is ≥ 0.15 m by building codes, and the slope model does not hold there.
SLOPE_GATE_M = F32(0.10)
#: Shortest step [m] whose stance can teach THETA_INIT the walking posture: over a shorter one
#: (a shuffle, a turn on the spot) the INS's rise says little about the ground's slope.
MIN_POSTURE_STEP_M = F32(0.5)
#: Level stances THETA_INIT's walking posture averages over (1/n of the way for the n-th, then
#: 1/POSTURE_STANCES): the foot's angle varies by about 0.5° from stance to stance, so the posture
#: is known to about 0.1° after them (0.2 m over 100 m walked).
POSTURE_STANCES = F32(32.0)
#: Largest difference [rad] along the step between the foot's walking and standing angles taken
#: as posture: 5°; the shared walks' is about 1° (the heel's rocking, the shoe); more is ground.
MAX_POSTURE = F32(5.0 * math.pi / 180.0)
