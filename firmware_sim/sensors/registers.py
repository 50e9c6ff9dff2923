"""MPU9150 / AK8975 register encodings: physical units ↔ raw int16 registers.

A register holds round-to-nearest(value / LSB), saturated to its range: int16
(−32768..32767) for the accelerometer and the gyro, ±4095 for the AK8975. The
scale factors come from :mod:`firmware_sim.sensors.config`.
"""

from __future__ import annotations

import numpy as np

from .config import DEFAULT_CONFIG, DEG, SensorConfig

INT16_MIN = -32768
INT16_MAX = 32767


def saturate_int16(lsb: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """Round to nearest (ties to even, as numpy) and clip to int16, like the registers.

    With *out* (int16, of *lsb*'s shape) the registers are written there, and *lsb* (float64) is
    rounded and clipped in place on the way: no array of *lsb*'s size is made."""
    if out is not None:
        np.rint(lsb, out=lsb)
        np.clip(lsb, INT16_MIN, INT16_MAX, out=lsb)
        out[...] = lsb  # the same conversion as astype's
        return out
    rounded = np.rint(lsb)
    within = rounded if isinstance(rounded, np.ndarray) else None  # clipped in place: no more memory
    return np.clip(rounded, INT16_MIN, INT16_MAX, out=within).astype(np.int16)


def accel_counts(acc_g: np.ndarray, config: SensorConfig = DEFAULT_CONFIG, out: np.ndarray | None = None
                 ) -> np.ndarray:
    """Specific force [g] in accelerometer LSB, before rounding and saturation (into *out*, which
    may be *acc_g*, when given)."""
    return np.multiply(np.asarray(acc_g, dtype=np.float64), config.accel.lsb_per_g, out=out)


def accel_to_lsb(acc_g: np.ndarray, config: SensorConfig = DEFAULT_CONFIG) -> np.ndarray:
    """Specific force [g] → accelerometer registers (int16)."""
    return saturate_int16(accel_counts(acc_g, config))


def gyro_counts(rate_rad_s: np.ndarray, config: SensorConfig = DEFAULT_CONFIG, out: np.ndarray | None = None
                ) -> np.ndarray:
    """Angular rate [rad/s] in gyro LSB, before rounding and saturation (into *out*, which may be
    *rate_rad_s*, when given)."""
    return np.multiply(np.asarray(rate_rad_s, dtype=np.float64), config.gyro.lsb_per_dps / DEG, out=out)


def gyro_to_lsb(rate_rad_s: np.ndarray, config: SensorConfig = DEFAULT_CONFIG) -> np.ndarray:
    """Angular rate [rad/s] → gyro registers (int16)."""
    return saturate_int16(gyro_counts(rate_rad_s, config))


def lsb_to_accel(lsb: np.ndarray, config: SensorConfig = DEFAULT_CONFIG) -> np.ndarray:
    """Accelerometer registers → specific force [g]."""
    return np.asarray(lsb, dtype=np.float64) / config.accel.lsb_per_g


def lsb_to_gyro(lsb: np.ndarray, config: SensorConfig = DEFAULT_CONFIG) -> np.ndarray:
    """Gyro registers → angular rate [rad/s]."""
    return np.asarray(lsb, dtype=np.float64) * (DEG / config.gyro.lsb_per_dps)


def temp_to_lsb(temp_c: np.ndarray | float, config: SensorConfig = DEFAULT_CONFIG) -> np.ndarray:
    """Die temperature [°C] → temperature register (T = raw/340 + 35)."""
    t = config.temperature
    return saturate_int16((np.asarray(temp_c, dtype=np.float64) - t.offset_c) * t.lsb_per_c)


def lsb_to_temp(lsb: np.ndarray, config: SensorConfig = DEFAULT_CONFIG) -> np.ndarray:
    """Temperature register → die temperature [°C]."""
    t = config.temperature
    return np.asarray(lsb, dtype=np.float64) / t.lsb_per_c + t.offset_c


def mag_counts(field_ut: np.ndarray, config: SensorConfig = DEFAULT_CONFIG) -> np.ndarray:
    """Magnetic field [µT] in AK8975 LSB, before rounding and saturation."""
    return np.asarray(field_ut, dtype=np.float64) / config.mag.ut_per_lsb


def mag_to_lsb(field_ut: np.ndarray, config: SensorConfig = DEFAULT_CONFIG) -> np.ndarray:
    """Magnetic field [µT] → AK8975 registers (int16 holding ±4095)."""
    full_scale = config.mag.full_scale_lsb
    return np.clip(np.rint(mag_counts(field_ut, config)), -full_scale, full_scale).astype(np.int16)


def lsb_to_mag(lsb: np.ndarray, config: SensorConfig = DEFAULT_CONFIG) -> np.ndarray:
    """AK8975 registers → magnetic field [µT]."""
    return np.asarray(lsb, dtype=np.float64) * config.mag.ut_per_lsb
