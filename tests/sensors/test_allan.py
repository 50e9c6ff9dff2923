"""Noise statistics of the simulated MPU9150s by Allan deviation.

White noise of one-sided density N [unit/√Hz] has the Allan deviation
σ(τ) = N / √(2τ): a slope of −1/2 on a log-log plot at short τ, where the bias
random walk (slope +1/2) does not show yet. The registers are read back through
their LSB conversions, so quantisation is part of what is checked.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from firmware_sim.sensors.config import DEFAULT_CONFIG, IDEAL_CONFIG
from firmware_sim.sensors.imu_array import make_source
from firmware_sim.sensors.registers import lsb_to_accel, lsb_to_gyro

TAUS_S = np.array([0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0])


def allan_deviation(x: np.ndarray, fs: float, taus_s: np.ndarray) -> np.ndarray:
    """Overlapping Allan deviation of each column of *x* (rate samples at *fs*), shape (τ, cols)."""
    theta = np.cumsum(np.vstack([np.zeros((1, x.shape[1])), x]), axis=0) / fs  # integrated rate
    out = []
    for tau in taus_s:
        m = int(round(tau * fs))
        d = theta[2 * m:] - 2 * theta[m:-m] + theta[:-2 * m]
        out.append(np.sqrt(np.mean(d**2, axis=0) / (2 * tau**2)))
    return np.array(out)


@pytest.fixture(scope="module", params=[False, True], ids=["dlpf-off", "dlpf-260Hz"])
def still_noise(request):
    """40 s at rest with white noise and bias drift on (every other error off)."""
    dlpf = DEFAULT_CONFIG.dlpf if request.param else IDEAL_CONFIG.dlpf
    cfg = replace(IDEAL_CONFIG, noise=True, drift=True, dlpf=dlpf)
    src = make_source("stand:40", seed=11, config=cfg)
    acc = lsb_to_accel(src.imu[..., :3]).reshape(len(src), -1)  # g, 4 chips × 3 axes
    gyro = lsb_to_gyro(src.imu[..., 3:]).reshape(len(src), -1)  # rad/s
    return src.rate_hz, acc, gyro


@pytest.mark.parametrize("kind,density", [("acc", 400e-6), ("gyro", math.radians(0.005))])
def test_allan_deviation_has_slope_minus_half_at_short_tau_and_the_configured_level(
        still_noise, kind, density):
    fs, acc, gyro = still_noise
    x = acc if kind == "acc" else gyro
    adev = allan_deviation(x - x.mean(axis=0), fs, TAUS_S)  # per register
    mean_adev = adev.mean(axis=1)  # averaged over the 12 registers
    slope = np.polyfit(np.log(TAUS_S), np.log(mean_adev), 1)[0]
    assert slope == pytest.approx(-0.5, rel=0.10)
    # each register's slope too (a wrong axis would hide in the mean)
    slopes = [np.polyfit(np.log(TAUS_S), np.log(adev[:, k]), 1)[0] for k in range(adev.shape[1])]
    assert all(-0.55 < s < -0.45 for s in slopes), slopes
    # the level: N / √(2τ), within 10 %
    np.testing.assert_allclose(mean_adev, density / np.sqrt(2 * TAUS_S), rtol=0.10)


def test_allan_deviation_of_known_white_noise():
    """The estimator itself: white noise of σ per sample at 1 kHz → σ/√(τ·fs)."""
    rng = np.random.default_rng(0)
    fs, sigma = 1000.0, 0.3
    x = rng.normal(0.0, sigma, (40_000, 4))
    adev = allan_deviation(x, fs, TAUS_S).mean(axis=1)
    np.testing.assert_allclose(adev, sigma / np.sqrt(TAUS_S * fs), rtol=0.05)
