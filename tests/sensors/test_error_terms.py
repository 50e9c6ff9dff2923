"""Each error term of a chip does what its configuration says, and only that.

g-sensitivity, misalignment, bias instability (Gauss–Markov), the board's
ringing after heel strikes and the calibration residuals, each switched on
alone on top of the error-free configuration where the registers can show it.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from firmware_sim.board import MIMU22BT
from firmware_sim.sensors.config import DEFAULT_CONFIG, DEG, G0, IDEAL_CONFIG
from firmware_sim.sensors.impacts import ringing
from firmware_sim.sensors.imu_array import make_source, module_rng
from firmware_sim.sensors.mpu9150 import ChipErrors, gauss_markov, small_rotation
from firmware_sim.sensors.registers import lsb_to_accel, lsb_to_gyro

ACC_LSB = 1 / 2048  # g
GYRO_LSB = math.radians(1 / 16.4)  # rad/s per LSB (16.4 LSB per °/s)
STEPS = "stand:2+walk:3"


def draw_chips(config, module: int = 1, n: int = 4) -> list[ChipErrors]:
    rng = module_rng(module)
    return [ChipErrors.draw(rng, config) for _ in range(n)]


def unmount(chip_values: np.ndarray) -> np.ndarray:
    """(n, 4, 3) chip axes → board axes with the ideal calibration (mountingᵀ)."""
    return np.einsum("kji,nkj->nki", MIMU22BT.mounting.astype(float), chip_values)


def rotation_vector(R: np.ndarray) -> np.ndarray:
    """The rotation vector of a small rotation matrix (log map)."""
    angle = math.acos(max(-1.0, min(1.0, (np.trace(R) - 1.0) / 2.0)))
    axis = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    return axis * (0.5 / np.sinc(angle / np.pi)) if angle > 0 else np.zeros(3)


# --- g-sensitivity ----------------------------------------------------------------------------------


def test_g_sensitivity_draws_stay_within_their_bound_and_fill_it():
    bound = DEFAULT_CONFIG.gyro.g_sensitivity_rad_s_per_g
    g = np.array([c.gyro_g_matrix for m in range(10) for c in draw_chips(DEFAULT_CONFIG, module=m)])
    assert np.all(np.abs(g) <= bound)
    assert np.abs(g).max() > 0.9 * bound
    assert abs(g.mean()) < 0.1 * bound  # symmetric about zero


def test_a_standing_module_with_g_sensitivity_reads_a_constant_rate_from_gravity():
    # the default ±0.03 °/s/g is below half a gyro LSB at 1 g; a larger bound makes it visible
    gyro = replace(IDEAL_CONFIG.gyro, g_sensitivity_rad_s_per_g=5.0 * DEG)
    cfg = replace(IDEAL_CONFIG, g_sensitivity=True, gyro=gyro)
    src = make_source("stand:1", seed=2, config=cfg)
    f_chip, w_chip = src.chip_motion()
    assert not np.any(w_chip)
    rate = lsb_to_gyro(src.imu[..., 3:])
    assert np.all(src.imu[..., 3:] == src.imu[0, :, 3:])  # constant
    for k, chip in enumerate(src.chips):
        assert np.all(np.abs(chip.gyro_g_matrix) <= gyro.g_sensitivity_rad_s_per_g)
        expected = chip.gyro_g_matrix @ (f_chip[0, k] / G0)
        assert np.all(np.abs(rate[:, k] - expected) <= GYRO_LSB / 2 + 1e-12)
        # bound: 1 g on one axis, each element at most the bound
        assert np.all(np.abs(rate[0, k]) <= gyro.g_sensitivity_rad_s_per_g * 1.01 + GYRO_LSB / 2)
    assert np.abs(src.imu[..., 3:]).max() > 10  # many LSB: the term is really there


def test_a_walking_module_with_g_sensitivity_reads_rate_plus_g_times_specific_force():
    gyro = replace(IDEAL_CONFIG.gyro, g_sensitivity_rad_s_per_g=2.0 * DEG)
    cfg = replace(IDEAL_CONFIG, g_sensitivity=True, gyro=gyro)
    src = make_source(STEPS, seed=2, config=cfg)
    f_chip, w_chip = src.chip_motion()
    rate = lsb_to_gyro(src.imu[..., 3:])
    for k, chip in enumerate(src.chips):
        expected = w_chip[:, k] + (f_chip[:, k] / G0) @ chip.gyro_g_matrix.T
        assert np.all(np.abs(rate[:, k] - expected) <= GYRO_LSB / 2 + 1e-9)
    # the accelerometers are untouched by it
    plain = make_source(STEPS, seed=2, config=IDEAL_CONFIG)
    assert np.array_equal(src.imu[..., :3], plain.imu[..., :3])
    assert not np.array_equal(src.imu[..., 3:], plain.imu[..., 3:])


# --- misalignment -----------------------------------------------------------------------------------


def test_misalignment_alone_turns_each_chip_by_a_small_rotation_within_its_bound():
    cfg = replace(IDEAL_CONFIG, misalignment=True)
    bound = cfg.array.misalignment_rad
    angles = []
    for module in range(5):
        for chip in draw_chips(cfg, module=module):
            M = chip.acc_matrix
            np.testing.assert_allclose(M @ M.T, np.eye(3), atol=1e-14)
            assert np.linalg.det(M) == pytest.approx(1.0, abs=1e-14)
            assert np.array_equal(chip.gyro_matrix, M)  # one package: gyro and accelerometer turn together
            v = rotation_vector(M)
            np.testing.assert_allclose(small_rotation(v), M, atol=1e-15)
            assert np.all(np.abs(v) <= bound * (1 + 1e-9))
            angles.append(np.linalg.norm(v))
    assert max(angles) <= math.sqrt(3) * bound and max(angles) > 0.5 * bound


def test_without_misalignment_the_chips_sit_exactly_as_mounted():
    for chip in draw_chips(IDEAL_CONFIG) + draw_chips(replace(IDEAL_CONFIG, offsets=True, noise=True)):
        assert np.array_equal(chip.acc_matrix, np.eye(3))
        assert np.array_equal(chip.gyro_matrix, np.eye(3))


def test_a_misaligned_chip_sees_gravity_tilted_by_its_rotation():
    cfg = replace(IDEAL_CONFIG, misalignment=True)
    src = make_source("stand:1", seed=0, module=3, config=cfg)
    f_chip, _ = src.chip_motion()
    acc = lsb_to_accel(src.imu[0, :, :3])
    tilted = 0
    for k, chip in enumerate(src.chips):
        expected = chip.acc_matrix @ (f_chip[0, k] / G0)
        assert np.all(np.abs(acc[k] - expected) <= ACC_LSB / 2 + 1e-12)
        tilted += np.abs(acc[k] - f_chip[0, k] / G0).max() > ACC_LSB
    assert tilted >= 2  # 0.1° of 1 g is a few LSB


# --- bias instability (first-order Gauss–Markov) ----------------------------------------------------


def test_gauss_markov_is_stationary_with_the_configured_sd_and_correlation():
    rate, tau, sigma = 1000.0, 0.01, 2.5
    x = gauss_markov(np.random.default_rng(1), (4000, 400), sigma, tau, rate)
    assert x.shape == (4000, 400)
    assert x.std() == pytest.approx(sigma, rel=0.03)
    assert x[0].std() == pytest.approx(sigma, rel=0.1)  # stationary from the first sample
    assert x[-1].std() == pytest.approx(sigma, rel=0.1)
    phi = math.exp(-1.0 / (tau * rate))
    for lag in (1, 5, 20):
        r = np.mean(x[lag:] * x[:-lag]) / np.mean(x * x)
        assert r == pytest.approx(phi**lag, abs=0.01)


def test_gauss_markov_is_the_first_order_recursion():
    rate, tau, sigma = 100.0, 0.5, 1.0
    w = np.random.default_rng(3).standard_normal((300, 2))
    x = gauss_markov(np.random.default_rng(3), (300, 2), sigma, tau, rate)
    phi = math.exp(-1.0 / (tau * rate))
    expected = np.empty_like(w)
    expected[0] = sigma * w[0]
    for k in range(1, len(w)):
        expected[k] = phi * expected[k - 1] + sigma * math.sqrt(1 - phi * phi) * w[k]
    np.testing.assert_allclose(x, expected, rtol=1e-10, atol=1e-12)


def test_gauss_markov_of_zero_sd_is_zero_but_draws_as_many_numbers():
    rng, twin = np.random.default_rng(9), np.random.default_rng(9)
    x = gauss_markov(rng, (500, 4, 3), 0.0, 100.0, 1000.0)
    assert x.shape == (500, 4, 3) and not np.any(x)
    twin.standard_normal((500, 4, 3))
    assert rng.standard_normal() == twin.standard_normal()


# --- the board's ringing after heel strikes ---------------------------------------------------------

IMPACTS = replace(IDEAL_CONFIG, impacts=True)


def test_ringing_starts_at_each_strike_and_dies_out_within_eight_decay_times():
    t = np.arange(3000) / 1000.0
    strikes = np.array([0.5, 1.2, 2.0])
    acc, gyro = ringing(np.random.default_rng(4), t, strikes, IMPACTS)
    imp = IMPACTS.impact
    span = 8 * imp.decay_s
    quiet = np.ones(len(t), dtype=bool)
    for s in strikes:
        quiet &= ~((t >= s) & (t < s + span))
    assert not np.any(acc[quiet]) and not np.any(gyro[quiet])
    assert not np.any(acc[t < strikes[0]])
    for s in strikes:
        near = (t >= s) & (t < s + 0.010)  # the first ringing period and a bit
        peak_acc = np.linalg.norm(acc[near], axis=1).max()
        peak_gyro = np.linalg.norm(gyro[near], axis=1).max()
        # amplitude 0.5–1 of the peak, the envelope ≥ e^(−1/3) in the first half period
        assert 0.3 * imp.accel_g <= peak_acc <= imp.accel_g
        assert 0.3 * imp.gyro_rad_s <= peak_gyro <= imp.gyro_rad_s
        during = (t >= s) & (t < s + span)
        assert np.linalg.norm(acc[during], axis=1).max() <= imp.accel_g
        # one direction per strike: every sample is a multiple of the same vector
        block = acc[during]
        assert np.linalg.matrix_rank(block, tol=1e-9 * imp.accel_g) == 1
        # it decays: the last period is far below the first
        late = (t >= s + span - 0.010) & (t < s + span)
        assert np.linalg.norm(acc[late], axis=1).max() < 0.01 * peak_acc


def test_ringing_off_is_zero_and_draws_as_many_numbers():
    t = np.arange(2000) / 1000.0
    strikes = np.array([0.3, 0.9, 1.5])
    on_rng, off_rng = np.random.default_rng(6), np.random.default_rng(6)
    on = ringing(on_rng, t, strikes, IMPACTS)
    off = ringing(off_rng, t, strikes, IDEAL_CONFIG)
    assert np.any(on[0]) and np.any(on[1])
    assert not np.any(off[0]) and not np.any(off[1])
    assert on_rng.standard_normal() == off_rng.standard_normal()


def test_a_module_rings_after_each_heel_strike_and_not_when_switched_on():
    plain = make_source(STEPS, seed=3, config=IDEAL_CONFIG)
    rung = make_source(STEPS, seed=3, config=IMPACTS)
    t, strikes = rung.truth.t, rung.truth.stance_start[1:]
    assert rung.truth.stance_start[0] == 0.0 and len(strikes) >= 2
    diff = np.any(rung.imu != plain.imu, axis=(1, 2))
    window = np.zeros(len(t), dtype=bool)
    for s in strikes:
        window |= (t >= s) & (t < s + 0.1)
        after = (t >= s) & (t < s + 0.01)
        # up to 1 g: hundreds of LSB
        assert np.abs(rung.imu[after, :, :3].astype(int) - plain.imu[after, :, :3]).max() > 300
    assert np.any(diff)
    assert not np.any(diff[~window])
    # the whole board rings alike: every chip feels the same ringing, in board axes
    ring = unmount(lsb_to_accel(rung.imu[..., :3]) - lsb_to_accel(plain.imu[..., :3]))
    assert np.abs(ring - ring[:, :1]).max() <= 2 * ACC_LSB + 1e-12


def test_noise_and_drift_on_do_not_change_the_ringing():
    noisy = replace(IMPACTS, noise=True, drift=True)
    rung = make_source(STEPS, seed=3, config=IMPACTS)
    both = make_source(STEPS, seed=3, config=noisy)
    # what differs is white noise (≈ 18 LSB rms on the accelerometers), never a ringing of another strike
    diff = both.imu[..., :3].astype(int) - rung.imu[..., :3]
    sd = noisy.accel.noise_density_g * math.sqrt(500.0) * 2048
    assert diff.std() == pytest.approx(sd, rel=0.1)
    assert np.abs(diff).max() < 7 * sd


# --- calibration residuals --------------------------------------------------------------------------


def test_the_offset_residual_scales_the_datasheet_offsets_and_nothing_else():
    raw = draw_chips(replace(DEFAULT_CONFIG, offset_residual=1.0), module=5)
    calibrated = draw_chips(replace(DEFAULT_CONFIG, offset_residual=0.02), module=5)
    for r, c in zip(raw, calibrated, strict=True):
        np.testing.assert_allclose(r.acc_offset_g, 50.0 * c.acc_offset_g, rtol=1e-12)
        np.testing.assert_allclose(r.gyro_offset, 50.0 * c.gyro_offset, rtol=1e-12)
        for f in ("acc_matrix", "gyro_matrix", "gyro_g_matrix", "acc_offset_tempco_g", "gyro_offset_tempco"):
            assert np.array_equal(getattr(r, f), getattr(c, f)), f
    offsets = np.array([r.acc_offset_g for r in raw])
    bound = np.array(DEFAULT_CONFIG.accel.offset_bound_g)
    assert np.all(np.abs(offsets) <= bound) and np.abs(offsets / bound).max() > 0.5
    gyro = np.array([r.gyro_offset for r in raw])
    assert np.all(np.abs(gyro) <= DEFAULT_CONFIG.gyro.offset_bound_rad_s)


def test_the_scale_residual_scales_sensitivity_and_cross_axis_errors():
    base = replace(DEFAULT_CONFIG, misalignment=False)
    raw = draw_chips(replace(base, scale_residual=1.0), module=6)
    calibrated = draw_chips(replace(base, scale_residual=0.15), module=6)
    for r, c in zip(raw, calibrated, strict=True):
        np.testing.assert_allclose(r.acc_matrix - np.eye(3), (c.acc_matrix - np.eye(3)) / 0.15, rtol=1e-9)
        np.testing.assert_allclose(r.gyro_matrix - np.eye(3), (c.gyro_matrix - np.eye(3)) / 0.15, rtol=1e-9)
        assert np.array_equal(r.acc_offset_g, c.acc_offset_g)
        e = r.acc_matrix - np.eye(3)
        assert np.all(np.abs(np.diag(e)) <= DEFAULT_CONFIG.accel.sensitivity_tol)
        assert np.all(np.abs(e[~np.eye(3, dtype=bool)]) <= DEFAULT_CONFIG.accel.cross_axis)
