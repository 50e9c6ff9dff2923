"""The simulated 4-IMU array: registers a firmware can trust, errors as configured, determinism."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from firmware_sim.board import MIMU22BT
from firmware_sim.mcu.imu_bus import SensorSource
from firmware_sim.sensors.config import DEFAULT_CONFIG, G0, IDEAL_CONFIG, SensorConfig
from firmware_sim.sensors.imu_array import SimulatedSource, list_scenarios, make_source
from firmware_sim.sensors.magnetic import earth_field_ned
from firmware_sim.sensors.mpu9150 import dlpf_filter, one_pole_alpha
from firmware_sim.sensors.registers import lsb_to_accel, lsb_to_gyro, lsb_to_mag, lsb_to_temp

ACC_LSB = 1 / 2048  # g
GYRO_LSB = math.radians(1 / 16.4)  # rad/s


def unmount(chip_values: np.ndarray) -> np.ndarray:
    """(n, 4, 3) chip axes → board axes with the ideal calibration (mountingᵀ)."""
    return np.einsum("kji,nkj->nki", MIMU22BT.mounting.astype(float), chip_values)


@pytest.fixture(scope="module")
def ideal_mixed():
    return make_source("stand:1+walk:6+turn:90+stairs_up:2+run:6+stand:1", config=IDEAL_CONFIG)


def test_simulated_source_is_a_sensor_source_of_int16_registers(ideal_mixed):
    src = ideal_mixed
    assert isinstance(src, SensorSource) and src.rate_hz == 1000.0
    s = src.read(0)
    assert s.imu.dtype == np.int16 and s.imu.shape == (4, 6)
    assert s.temp.shape == (4,) and s.mag.shape == (4, 3)
    assert src.read(len(src) - 1) is not None and src.read(len(src)) is None
    assert np.shares_memory(src.read(5).imu, src.imu)  # views, no per-sample copies
    assert "default" in list_scenarios()


def test_with_errors_off_the_registers_are_the_quantised_motion_of_each_chip(ideal_mixed):
    src = ideal_mixed
    f_chip, w_chip = src.chip_motion()
    acc = lsb_to_accel(src.imu[..., :3])
    gyro = lsb_to_gyro(src.imu[..., 3:])
    ok = np.abs(f_chip / G0) < 15.9  # the run's heel strikes saturate
    assert np.all(np.abs(acc - f_chip / G0)[ok] <= ACC_LSB / 2 + 1e-12)
    assert np.all(np.abs(gyro - w_chip) <= GYRO_LSB / 2 + 1e-12)
    # the lever arms cancel in the four-chip mean: it is the board-centre motion
    board = unmount(f_chip).mean(axis=1)
    assert np.abs(board - src.truth.f_b).max() < 1e-9
    # and a chip off-centre does feel the rotation
    assert np.abs(unmount(f_chip)[:, 0] - src.truth.f_b).max() > 0.5


def test_the_four_chips_agree_once_calibrated_when_still(ideal_mixed):
    s = ideal_mixed.read(0)
    board = unmount(s.imu[None, :, :3].astype(float))[0]
    assert np.all(board == board[0])
    assert board[0, 2] == round(-9.81 / G0 * 2048)  # z down: −1 g


def test_same_seed_same_registers_and_a_different_seed_different_noise():
    a = make_source("stand:2+walk:3", seed=7)
    b = make_source("stand:2+walk:3", seed=7)
    c = make_source("stand:2+walk:3", seed=8)
    for name in ("imu", "temp", "mag"):
        assert np.array_equal(getattr(a, name), getattr(b, name))
    assert not np.array_equal(a.imu, c.imu)
    diff = a.imu.astype(int) - c.imu.astype(int)
    assert diff.std(axis=0).min() > 0.5  # every register's noise differs sample by sample


def _psd(x: np.ndarray, fs: float, nper: int = 1024) -> tuple[np.ndarray, np.ndarray]:
    """One-sided PSD (Welch, Hann window, no overlap) of the columns of x, averaged."""
    n = (len(x) // nper) * nper
    seg = x[:n].reshape(-1, nper, x.shape[1])
    seg = seg - seg.mean(axis=1, keepdims=True)
    w = np.hanning(nper)
    spec = np.abs(np.fft.rfft(seg * w[None, :, None], axis=1)) ** 2
    psd = 2.0 * spec.mean(axis=(0, 2)) / (fs * np.sum(w**2))
    return np.fft.rfftfreq(nper, 1 / fs), psd


def test_noise_has_the_datasheet_densities():
    cfg = replace(IDEAL_CONFIG, noise=True, dlpf=DEFAULT_CONFIG.dlpf)
    src = make_source("stand:40", seed=3, config=cfg)
    acc = lsb_to_accel(src.imu[..., :3]).reshape(len(src), -1)
    gyro = lsb_to_gyro(src.imu[..., 3:]).reshape(len(src), -1)
    f, pa = _psd(acc, src.rate_hz)
    _, pg = _psd(gyro, src.rate_hz)
    band = (f >= 2) & (f <= 40)
    acc_density = math.sqrt(pa[band].mean())  # g/√Hz
    gyro_density = math.degrees(math.sqrt(pg[band].mean()))  # °/s/√Hz
    assert acc_density == pytest.approx(400e-6, rel=0.10)
    assert gyro_density == pytest.approx(0.005, rel=0.10)


def test_running_heel_strikes_clip_at_16_g_and_walking_does_not():
    run = make_source("run:20", config=IDEAL_CONFIG)
    acc = run.imu[..., :3]
    assert run.clipped > 0
    assert acc.max() == 32767 or acc.min() == -32768
    walk = make_source("walk:20", config=IDEAL_CONFIG)
    assert walk.clipped == 0


def test_offsets_and_scale_errors_stay_within_the_datasheet_bounds():
    raw_chips = replace(IDEAL_CONFIG, offsets=True, scale_errors=True, offset_residual=1.0,
                        scale_residual=1.0)
    src = make_source("stand:1", seed=11, config=raw_chips)
    for chip in src.chips:
        assert np.all(np.abs(chip.acc_offset_g) <= [0.080, 0.080, 0.150])
        assert np.all(np.abs(chip.gyro_offset) <= math.radians(20))
        assert np.all(np.abs(np.diag(chip.acc_matrix) - 1) <= 0.03)
        off = chip.gyro_matrix - np.diag(np.diag(chip.gyro_matrix))
        assert np.all(np.abs(off) <= 0.02)
    still = lsb_to_gyro(src.imu[:, 0, 3:]).mean(axis=0)
    assert still == pytest.approx(src.chips[0].gyro_offset, abs=GYRO_LSB)


def test_a_calibrated_module_keeps_small_residual_offsets():
    src = make_source("stand:1", seed=11)
    for chip in src.chips:
        assert np.all(np.abs(chip.gyro_offset) <= math.radians(20) * 0.02)
        assert np.all(np.abs(chip.acc_offset_g) <= 0.150 * 0.02)


def test_default_errors_are_on_and_each_chip_differs():
    src = make_source("stand:1", seed=1)
    s = src.read(0)
    board = unmount(s.imu[None, :, :3].astype(float))[0]
    assert len({tuple(r) for r in board}) == 4
    assert DEFAULT_CONFIG.noise and not SensorConfig.ideal().noise
    assert DEFAULT_CONFIG.without_errors().dlpf.enabled is False


def test_temperature_register_warms_up_from_ambient():
    cfg = replace(DEFAULT_CONFIG, temperature=replace(DEFAULT_CONFIG.temperature, warmup_tau_s=2.0))
    src = make_source("stand:6", seed=2, config=cfg)
    temp = lsb_to_temp(src.temp)
    assert temp[0] == pytest.approx(22.0, abs=0.6)  # ambient ± the chips' spread
    assert np.all(temp[-1] - temp[0] == pytest.approx(8.0 * (1 - math.exp(-3)), abs=0.01))


def test_a_module_switched_on_earlier_starts_the_run_warm():
    warm = replace(DEFAULT_CONFIG.temperature, warmup_tau_s=2.0, powered_s=4.0)
    temp = lsb_to_temp(make_source("stand:6", seed=2, config=replace(DEFAULT_CONFIG, temperature=warm)).temp)
    cold = lsb_to_temp(make_source("stand:6", seed=2, config=DEFAULT_CONFIG).temp)
    # 4 s = 2τ before the run: 1 − e⁻² of the 8 °C already reached, the rest still to come
    assert np.all(temp[0] - cold[0] == pytest.approx(8.0 * (1 - math.exp(-2)), abs=0.01))
    assert np.all(temp[-1] - temp[0] == pytest.approx(8.0 * (math.exp(-2) - math.exp(-5)), abs=0.01))
    settled = DEFAULT_CONFIG.warm().temperature
    assert settled.powered_s == 5 * settled.warmup_tau_s == DEFAULT_CONFIG.temperature.settled_s
    assert DEFAULT_CONFIG.warm().gyro == DEFAULT_CONFIG.gyro and DEFAULT_CONFIG.temperature.powered_s == 0.0


def test_set_dlpf_smooths_the_registers_and_refuses_bad_settings():
    src = make_source("stand:3", seed=4)
    rough = np.abs(np.diff(src.imu[..., 3:].astype(float), axis=0)).mean()
    before = src.imu.copy()
    src.set_dlpf(6)
    assert src.dlpf_cfg == 6
    smooth = np.abs(np.diff(src.imu[..., 3:].astype(float), axis=0)).mean()
    assert smooth < rough / 3
    src.set_dlpf(0)
    assert np.array_equal(src.imu, before)  # same draws, same registers
    with pytest.raises(ValueError):
        src.set_dlpf(7)


@settings(max_examples=25, deadline=None)
@given(bw=st.sampled_from([260.0, 184.0, 94.0, 44.0, 21.0, 10.0, 5.0]),
       x=st.lists(st.floats(-100, 100), min_size=1, max_size=300))
def test_the_dlpf_scan_is_the_one_pole_recursion(bw, x):
    x = np.array(x)[:, None]
    a = one_pole_alpha(bw, 1000.0)
    y, ref = x[0, 0], []
    for v in x[:, 0]:
        y += a * (v - y)
        ref.append(y)
    assert np.allclose(dlpf_filter(x.copy(), bw, 1000.0)[:, 0], ref, atol=1e-9)


def test_with_disturbances_off_the_magnetometer_is_a_compass():
    src = make_source("stand:1+turn:90+stand:1", config=IDEAL_CONFIG)
    axes = np.array(IDEAL_CONFIG.mag.axes, dtype=float)
    mag_chip = lsb_to_mag(src.mag[:, 0])  # chip 0 is upright: chip axes = board axes
    board = mag_chip @ axes  # axes is a signed permutation: its inverse is its transpose
    earth = earth_field_ned(IDEAL_CONFIG)
    for k in (0, len(src) - 1):
        expect = src.truth.R[k].T @ earth
        assert np.abs(board[k] - expect).max() <= 0.3 / 2 + 1e-9
    heading = np.arctan2(-board[-1, 1], board[-1, 0]) + math.radians(IDEAL_CONFIG.mag.declination_deg)
    assert math.degrees(heading) == pytest.approx(90.0, abs=0.5)


def test_shoe_iron_and_buildings_disturb_the_compass_by_tens_of_degrees():
    src = make_source("stand:1+walk:60", seed=5, config=replace(IDEAL_CONFIG, mag_disturbance=True))
    axes = np.array(IDEAL_CONFIG.mag.axes, dtype=float)
    board = lsb_to_mag(src.mag[:, 0]) @ axes
    heading = np.degrees(np.arctan2(-board[:, 1], board[:, 0])) + IDEAL_CONFIG.mag.declination_deg
    still = src.truth.stance
    err = (heading[still] - np.degrees(src.truth.euler[still, 2]) + 180) % 360 - 180
    assert 10.0 < np.abs(err).max() < 90.0
    assert np.abs(err).std() > 3.0  # varies along the walk, not just a constant offset


def test_a_simulated_source_accepts_a_trajectory_and_keeps_its_truth():
    from firmware_sim.sensors.scenarios import trajectory

    tr = trajectory("walk:3")
    src = SimulatedSource(tr, config=IDEAL_CONFIG, rate_hz=500.0)
    assert src.rate_hz == 500.0 and len(src) == len(src.truth) == int(tr.duration * 500) + 1
    assert "trajectory" in repr(src)


def test_ideal_with_delays_keeps_the_gyro_one_millisecond_behind_for_the_firmware():
    from firmware_sim.sensors.registers import gyro_to_lsb

    src = make_source("stand:1+walk:3", config=SensorConfig.ideal(keep_delays=True))
    _, w_late = src.chip_motion(0.0, 0.98e-3)
    assert np.array_equal(src.imu[..., 3:], gyro_to_lsb(w_late))
    _, w_now = src.chip_motion()
    assert not np.array_equal(src.imu[..., 3:], gyro_to_lsb(w_now))
