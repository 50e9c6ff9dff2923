"""The board's ringing after each heel strike.

When the heel lands, sole and board ring: a damped oscillation of the whole
board that every chip feels alike,

    r(t) = A·u·e^(−(t − t_s)/τ)·sin(2πf(t − t_s) + φ)   for t ≥ t_s,

added to the specific force (A = ``accel_g``) and, with its own direction, to
the angular rate (A = ``gyro_rad_s``). Per strike the direction u is uniform on
the sphere, the phase φ uniform, and the amplitude a uniform fraction 0.5–1 of
the configured peak (strikes differ). The smooth impact bump of the gait model
(:mod:`.gait`) is the foot's motion; this is what the motion excites.

Strikes are the starts of the stances after the first (the module is switched
on standing). Every draw comes from the walk's generator, the same number of
draws whether ringing is on or not.
"""

from __future__ import annotations

import numpy as np

from .config import SensorConfig

__all__ = ["ringing"]

#: How many time constants of the envelope are simulated (e^−8 < 0.04 %).
_SPAN_TAUS = 8.0


def _directions(rng: np.random.Generator, n: int) -> np.ndarray:
    v = rng.standard_normal((n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def ringing(rng: np.random.Generator, t: np.ndarray, strikes: np.ndarray,
            config: SensorConfig) -> tuple[np.ndarray, np.ndarray]:
    """The ringing (specific force [g], rate [rad/s]), each (n, 3) in the board frame, at times *t*."""
    imp = config.impact
    strikes = np.asarray(strikes, dtype=float)
    m = len(strikes)
    dir_acc, dir_gyro = _directions(rng, m), _directions(rng, m)
    amp = rng.uniform(0.5, 1.0, (m, 2))
    phase = rng.uniform(0.0, 2.0 * np.pi, (m, 2))
    acc = np.zeros((len(t), 3))
    gyro = np.zeros((len(t), 3))
    if not config.impacts or m == 0:
        return acc, gyro
    span = _SPAN_TAUS * imp.decay_s
    first = np.searchsorted(t, strikes)
    last = np.searchsorted(t, strikes + span)
    for j in range(m):
        k = slice(first[j], last[j])
        dt = t[k] - strikes[j]
        env = np.exp(-dt / imp.decay_s)
        wave = 2.0 * np.pi * imp.frequency_hz * dt
        acc[k] += np.outer(env * np.sin(wave + phase[j, 0]), dir_acc[j]) * (imp.accel_g * amp[j, 0])
        gyro[k] += np.outer(env * np.sin(wave + phase[j, 1]), dir_gyro[j]) * (imp.gyro_rad_s * amp[j, 1])
    return acc, gyro
