"""One MPU9150: how its accelerometer and gyro turn true motion into registers.

Per chip, in the chip's raw axes (all numbers from :mod:`.config`):

    a_meas = (I + E_a) M (1 + s_a·ΔT) a_true + b_a + c_a·ΔT + w_a(t) + n_a   [g]
    ω_meas = (I + E_g) M (1 + s_g·ΔT) ω_true + G a_true + b_g + c_g·ΔT + w_g(t) + n_g   [rad/s]

with E a scale/cross-axis matrix (diagonal ±sensitivity tolerance, off-diagonal
±cross-axis) and b the turn-on offset, both scaled by the calibration residuals
of the configuration (the module is calibrated); M the chip's small rotation
from its nominal mounting (misalignment); G the gyro's sensitivity to linear
acceleration; c and s the temperature coefficients of offset and sensitivity,
ΔT the die temperature minus the 25 °C reference; w(t) the in-run bias (a
random walk plus a first-order Gauss–Markov bias instability) and n white
noise of the datasheet noise density (one-sided; per-sample σ =
density·√(f_s/2)), plus the board's ringing after heel strikes
(:mod:`.impacts`). Then the DLPF (:func:`dlpf_filter`), then round to nearest
and saturate to int16.

:class:`ChipErrors` are drawn once per chip from the generator of the module's
identity, always in the same order (so switching one kind of error off does
not change the others).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .compiled import compiled
from .config import G0, SensorConfig
from .truth import Rotation, rotation

__all__ = ["ChipErrors", "dlpf_filter", "dlpf_delays", "dlpf_reach", "gauss_markov", "one_pole_alpha",
           "small_rotation"]


@dataclass(frozen=True, eq=False)
class ChipErrors:
    """The fixed errors of one chip (chip axes)."""

    acc_matrix: np.ndarray  #: (3, 3) I + scale/cross-axis error
    acc_offset_g: np.ndarray  #: (3,)
    acc_offset_tempco_g: np.ndarray  #: (3,) per °C
    acc_sens_tempco: np.ndarray  #: (3,) per °C
    gyro_matrix: np.ndarray  #: (3, 3)
    gyro_offset: np.ndarray  #: (3,) rad/s
    gyro_offset_tempco: np.ndarray  #: (3,) rad/s per °C
    gyro_sens_tempco: np.ndarray  #: (3,) per °C
    temp_offset_c: float  #: this die's temperature offset
    gyro_g_matrix: np.ndarray  #: (3, 3) rad/s per g of specific force (g-sensitivity)

    @classmethod
    def draw(cls, rng: np.random.Generator, config: SensorConfig) -> ChipErrors:
        """Draw one chip's errors; categories switched off in *config* come out zero."""
        a, g = config.accel, config.gyro

        def u(bound, shape=3):
            return rng.uniform(-1.0, 1.0, shape) * np.asarray(bound, dtype=float)

        def matrix(tol, cross):
            return np.diag(u(tol)) + (u(cross, (3, 3)) * (1.0 - np.eye(3)))

        acc_m, acc_b = matrix(a.sensitivity_tol, a.cross_axis), u(a.offset_bound_g)
        acc_tc, acc_stc = u(a.offset_tempco_g_per_c), u(a.sensitivity_tempco_per_c)
        gyr_m, gyr_b = matrix(g.sensitivity_tol, g.cross_axis), u(g.offset_bound_rad_s)
        gyr_tc, gyr_stc = u(g.offset_tempco_rad_s_per_c), u(g.sensitivity_tempco_per_c)
        temp_off = float(u(config.temperature.chip_spread_c, 1)[0])
        g_sens = u(g.g_sensitivity_rad_s_per_g, (3, 3))
        tilt = u(config.array.misalignment_rad)
        on = config.scale_errors
        off = config.offsets
        tc = config.temperature_effects
        acc_m, gyr_m = acc_m * config.scale_residual, gyr_m * config.scale_residual
        acc_b, gyr_b = acc_b * config.offset_residual, gyr_b * config.offset_residual
        acc_matrix = np.eye(3) + (acc_m if on else 0.0)
        gyro_matrix = np.eye(3) + (gyr_m if on else 0.0)
        if config.misalignment:
            mount = small_rotation(tilt)
            acc_matrix, gyro_matrix = acc_matrix @ mount, gyro_matrix @ mount
        return cls(
            acc_matrix=acc_matrix,
            acc_offset_g=acc_b if off else np.zeros(3),
            acc_offset_tempco_g=acc_tc if tc else np.zeros(3),
            acc_sens_tempco=acc_stc if tc else np.zeros(3),
            gyro_matrix=gyro_matrix,
            gyro_offset=gyr_b if off else np.zeros(3),
            gyro_offset_tempco=gyr_tc if tc else np.zeros(3),
            gyro_sens_tempco=gyr_stc if tc else np.zeros(3),
            temp_offset_c=temp_off,
            gyro_g_matrix=g_sens if config.g_sensitivity else np.zeros((3, 3)),
        )

    @cached_property
    def _rotations(self) -> tuple[Rotation, Rotation]:
        """The accelerometer's and the gyro's matrices as :func:`~.truth.rotation`'s (looked at once)."""
        return rotation(self.acc_matrix), rotation(self.gyro_matrix)

    def apply_accel(self, a_true_g: np.ndarray, dtemp: np.ndarray) -> np.ndarray:
        """Deterministic part of the accelerometer model [g] of the true specific force *a_true_g*
        [g] at die temperatures ΔT *dtemp* (n,): (3, n), a row per axis, as *a_true_g*."""
        out = self._rotations[0].rows(a_true_g)
        if np.any(self.acc_sens_tempco):
            out *= 1.0 + dtemp * self.acc_sens_tempco[:, None]
        out += self.acc_offset_g[:, None]
        if np.any(self.acc_offset_tempco_g):
            out += dtemp * self.acc_offset_tempco_g[:, None]
        return out

    def apply_gyro(self, w_true: np.ndarray, dtemp: np.ndarray, a_true_g: np.ndarray) -> np.ndarray:
        """Deterministic part of the gyro model [rad/s] of the true rate *w_true*, (3, n) a row per
        axis as :meth:`apply_accel`'s; *a_true_g* is the chip's specific force [g] (3, n), which
        the gyro feels through its g-sensitivity."""
        out = self._rotations[1].rows(w_true)
        if np.any(self.gyro_sens_tempco):
            out *= 1.0 + dtemp * self.gyro_sens_tempco[:, None]
        if np.any(self.gyro_g_matrix):
            out += self.gyro_g_matrix @ a_true_g  # BLAS's products: the same as (aᵀ Gᵀ)ᵀ's
        out += self.gyro_offset[:, None]
        if np.any(self.gyro_offset_tempco):
            out += dtemp * self.gyro_offset_tempco[:, None]
        return out


def small_rotation(angles: np.ndarray) -> np.ndarray:
    """The rotation matrix of the rotation vector *angles* [rad] (Rodrigues), for small tilts."""
    theta = float(np.linalg.norm(angles))
    if theta == 0.0:
        return np.eye(3)
    k = np.asarray(angles, dtype=float) / theta
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + np.sin(theta) * kx + (1.0 - np.cos(theta)) * (kx @ kx)


def gauss_markov(rng: np.random.Generator, shape: tuple[int, ...], sigma: float, correlation_s: float,
                 rate_hz: float, out: np.ndarray | None = None) -> np.ndarray:
    """A first-order Gauss–Markov process along axis 0, stationary with sd *sigma*.

    b[k] = φ·b[k−1] + σ√(1 − φ²)·w[k], φ = exp(−1/(τ·f_s)), b[0] ~ N(0, σ²):
    the bias instability of a MEMS sensor. The recursion runs as the same prefix
    scan as :func:`dlpf_filter`. Draws ``shape`` normals from *rng* even when
    *sigma* is 0, so that the draws after it do not depend on it. Into *out* (float64, of that
    shape) when given.
    """
    x = rng.standard_normal(shape) if out is None else rng.standard_normal(out=out)
    phi = float(np.exp(-1.0 / (correlation_s * rate_hz)))
    first = x[0] * sigma
    x *= sigma * np.sqrt(1.0 - phi * phi)
    x[0] = first
    return _first_order_scan(x, phi)


def _first_order_scan(y: np.ndarray, beta: float) -> np.ndarray:
    """In place: y[k] ← y[k] + β·y[k−1] for every k, in order (y[k] = Σ_j β^j x[k−j]).

    Passes of doubling span d: y[k] += β^d·y[k−d] for every k ≥ d at once, until β^d underflows
    below 1e-18. A pass is numpy's two operations on the whole array, or compiled (:mod:`.compiled`)
    one loop from the last sample down (each y[k − d] read before the pass writes it): the same
    numbers, without the scaled copy's memory."""
    d, bd = 1, beta
    n = len(y)
    worth = y.size >= _SCAN_COMPILED_FROM and y.dtype == np.float64 and y.flags.c_contiguous
    step = compiled(_scan_pass) if worth else None
    rows = y.reshape(n, -1) if step is not None else None
    earlier = np.empty_like(y[1:]) if step is None else None  # β^d·y[k−d] of a numpy pass
    while d < n and bd > 1e-18:
        if step is not None:
            step(rows, d, bd)
        else:
            part = earlier[:n - d]
            np.multiply(y[:-d], bd, out=part)
            y[d:] += part
        d *= 2
        bd *= bd
    return y


#: The fewest numbers whose scan is worth the compiled pass (a walk of about 80 s at 1 kHz: four
#: chips' three axes); fewer take numpy's, and a process with an empty cache of numba's compiles
#: nothing for them.
_SCAN_COMPILED_FROM = 1_000_000


def warm_up_scan() -> bool:
    """Load the scan's compiled pass from numba's cache, or compile it, now; whether it is compiled."""
    step = compiled(_scan_pass)
    if step is not None:
        step(np.zeros((2, 1)), 1, 0.5)
    return step is not None


def _scan_pass(y, d, bd):  # type: ignore[no-untyped-def]
    """One pass of :func:`_first_order_scan` on rows *y* (n, m): y[k] += bd·y[k − d], k from the
    last row down to d."""
    n, m = y.shape
    for k in range(n - 1, d - 1, -1):
        for c in range(m):
            y[k, c] += bd * y[k - d, c]


def _scan_reach(beta: float) -> int:
    """How many earlier inputs one output of :func:`_first_order_scan` (β) is computed from, in
    a record long enough for every pass: the sum of the passes' spans (1 + 2 + … + the last)."""
    d, bd = 1, beta
    while bd > 1e-18:
        d *= 2
        bd *= bd
    return d - 1


def white_sigma(density: float, rate_hz: float) -> float:
    """Per-sample σ of white noise with one-sided density *density* [unit/√Hz] at *rate_hz*."""
    return density * np.sqrt(rate_hz / 2.0)


def one_pole_alpha(bandwidth_hz: float, rate_hz: float) -> float:
    """Gain of y += α(x − y), the discrete one-pole with −3 dB corner ≈ *bandwidth_hz*."""
    return float(1.0 - np.exp(-2.0 * np.pi * bandwidth_hz / rate_hz))


def dlpf_delays(config: SensorConfig, cfg: int, rate_hz: float) -> tuple[float, float]:
    """Pure delays [s] (accelerometer, gyro) that, added to the one-pole, give the datasheet delay.

    The discrete one-pole delays low frequencies by (1 − α)/α samples; the rest
    of the datasheet delay is applied exactly, by evaluating the motion earlier.
    """
    d = config.dlpf
    if not d.enabled:
        return 0.0, 0.0
    if d.delays_only:
        return d.accel_delay_s[cfg], d.gyro_delay_s[cfg]
    out = []
    for bw, delay in ((d.accel_bandwidth_hz[cfg], d.accel_delay_s[cfg]), (d.gyro_bandwidth_hz[cfg],
                                                                          d.gyro_delay_s[cfg])):
        alpha = one_pole_alpha(bw, rate_hz)
        out.append(max(0.0, delay - (1.0 - alpha) / alpha / rate_hz))
    return out[0], out[1]


def dlpf_filter(x: np.ndarray, bandwidth_hz: float, rate_hz: float, from_rest: bool = True,
                out: np.ndarray | None = None) -> np.ndarray:
    """The one-pole low-pass y[k] = y[k−1] + α(x[k] − y[k−1]) along axis 0, started at rest on x[0].

    The recursion y[k] = β·y[k−1] + α·x[k] (β = 1 − α) is evaluated as a
    parallel prefix scan (doubling: after the pass with span d each y[k] holds
    the sum over the last 2d inputs), vectorised over all samples, and stopped
    once β^d underflows below 1e-18 — exact to float64 rounding.

    Each output is the same float64 computation on the :func:`dlpf_reach` inputs before it and
    its own, wherever it sits in *x*. So a part of a long record, filtered with that many inputs
    ahead of it and *from_rest* False (the record's first sample is not in the part), gives
    bit for bit the outputs the whole record gives there, from the lead-in's end on.

    Into *out* (float64, *x*'s shape; it may be *x*) when given.
    """
    alpha = one_pole_alpha(bandwidth_hz, rate_hz)
    beta = 1.0 - alpha
    rest = beta * x[0]  # the state before the first sample: at rest on x[0] (before out overwrites it)
    y = np.multiply(x, alpha, out=out)
    if from_rest:
        y[0] += rest
    return _first_order_scan(y, beta)


def dlpf_reach(bandwidth_hz: float, rate_hz: float) -> int:
    """How many earlier samples one output of :func:`dlpf_filter` depends on (its lead-in): 2047
    at 5 Hz and 1 kHz, 31 at 260 Hz. Older samples would weigh less than 1e-18 of theirs: the
    scan leaves them out."""
    return _scan_reach(1.0 - one_pole_alpha(bandwidth_hz, rate_hz))


def specific_force_to_g(f: np.ndarray) -> np.ndarray:
    """m/s² → g (the accelerometer's unit, 1 g = 9.80665 m/s²)."""
    return f / G0
