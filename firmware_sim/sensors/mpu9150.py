"""One MPU9150: how its accelerometer and gyro turn true motion into registers.

Per chip, in the chip's raw axes (all numbers from :mod:`.config`):

    a_meas = (I + E_a)(1 + s_a·ΔT) a_true + b_a + c_a·ΔT + w_a(t) + n_a   [g]
    ω_meas = (I + E_g)(1 + s_g·ΔT) ω_true + b_g + c_g·ΔT + w_g(t) + n_g   [rad/s]

with E a scale/cross-axis matrix (diagonal ±sensitivity tolerance, off-diagonal
±cross-axis), b the turn-on offset (E and b scaled by the calibration residual
of the configuration: the module is calibrated), c and s the temperature coefficients of
offset and sensitivity, ΔT the die temperature minus the 25 °C reference,
w(t) a bias random walk (in-run drift) and n white noise of the datasheet
noise density (one-sided; per-sample σ = density·√(f_s/2)). Then the DLPF
(:func:`dlpf_filter`), then round to nearest and saturate to int16.

:class:`ChipErrors` are drawn once per chip from the source's seeded
generator, always in the same order (so switching one kind of error off does
not change the others).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .config import G0, SensorConfig
from .truth import rotate

__all__ = ["ChipErrors", "dlpf_filter", "dlpf_delays", "one_pole_alpha"]


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
        on = config.scale_errors
        off = config.offsets
        tc = config.temperature_effects
        res = config.calibration_residual
        acc_m, acc_b, gyr_m, gyr_b = acc_m * res, acc_b * res, gyr_m * res, gyr_b * res
        return cls(
            acc_matrix=np.eye(3) + (acc_m if on else 0.0),
            acc_offset_g=acc_b if off else np.zeros(3),
            acc_offset_tempco_g=acc_tc if tc else np.zeros(3),
            acc_sens_tempco=acc_stc if tc else np.zeros(3),
            gyro_matrix=np.eye(3) + (gyr_m if on else 0.0),
            gyro_offset=gyr_b if off else np.zeros(3),
            gyro_offset_tempco=gyr_tc if tc else np.zeros(3),
            gyro_sens_tempco=gyr_stc if tc else np.zeros(3),
            temp_offset_c=temp_off,
        )

    def apply_accel(self, a_true_g: np.ndarray, dtemp: np.ndarray) -> np.ndarray:
        """Deterministic part of the accelerometer model, (n, 3) in g."""
        out = rotate(self.acc_matrix, a_true_g)
        if np.any(self.acc_sens_tempco):
            out *= 1.0 + dtemp[:, None] * self.acc_sens_tempco
        out += self.acc_offset_g
        if np.any(self.acc_offset_tempco_g):
            out += dtemp[:, None] * self.acc_offset_tempco_g
        return out

    def apply_gyro(self, w_true: np.ndarray, dtemp: np.ndarray) -> np.ndarray:
        """Deterministic part of the gyro model, (n, 3) in rad/s."""
        out = rotate(self.gyro_matrix, w_true)
        if np.any(self.gyro_sens_tempco):
            out *= 1.0 + dtemp[:, None] * self.gyro_sens_tempco
        out += self.gyro_offset
        if np.any(self.gyro_offset_tempco):
            out += dtemp[:, None] * self.gyro_offset_tempco
        return out


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


def dlpf_filter(x: np.ndarray, bandwidth_hz: float, rate_hz: float) -> np.ndarray:
    """The one-pole low-pass y[k] = y[k−1] + α(x[k] − y[k−1]) along axis 0, started at rest on x[0].

    The recursion y[k] = β·y[k−1] + α·x[k] (β = 1 − α) is evaluated as a
    parallel prefix scan (doubling: after the pass with span d each y[k] holds
    the sum over the last 2d inputs), vectorised over all samples, and stopped
    once β^d underflows below 1e-18 — exact to float64 rounding.
    """
    alpha = one_pole_alpha(bandwidth_hz, rate_hz)
    beta = 1.0 - alpha
    y = x * alpha
    y[0] += beta * x[0]  # the state before the first sample: at rest on x[0]
    d, bd = 1, beta
    n = len(y)
    while d < n and bd > 1e-18:
        y[d:] += bd * y[:-d].copy()
        d *= 2
        bd *= bd
    return y


def specific_force_to_g(f: np.ndarray) -> np.ndarray:
    """m/s² → g (the accelerometer's unit, 1 g = 9.80665 m/s²)."""
    return f / G0
