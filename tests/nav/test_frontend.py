"""The integer front end (firmware.md §3): calibration, detector sums and statistics, no overflow."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from firmware_sim.board import MIMU22BT, Q14_ONE
from firmware_sim.nav import config as cfg
from firmware_sim.nav import frontend as fe
from protocol.ids import NR_IMUS

G_LSB = 2048  # raw accelerometer LSB per g


def board_to_raw(v_board: np.ndarray) -> np.ndarray:
    """A board-frame acc+gyro register triple as the four chips' raw registers (int16 (4, 6))."""
    raw = np.zeros((NR_IMUS, 6), dtype=np.int16)
    for i in range(NR_IMUS):
        raw[i, 0:3] = MIMU22BT.mounting[i] @ v_board[0:3]
        raw[i, 3:6] = MIMU22BT.mounting[i] @ v_board[3:6]
    return raw


def exact_preproc(raw: np.ndarray, cal: np.ndarray, bias: np.ndarray) -> list[int]:
    """Unbounded-integer reference of PREPROC (no wrap)."""
    out = []
    for s in range(2):
        for r in range(3):
            tot = sum(int(cal[k, s, r, c]) * int(raw[k, 3 * s + c]) for k in range(NR_IMUS) for c in range(3))
            out.append((tot >> 2) - int(bias[3 * s + r]))
    return out


# --------------------------------------------------------------------------------- PREPROC


def test_preproc_default_calibration_undoes_the_chip_mounting():
    v = np.array([-120, 340, -2048, 17, -5, 900], dtype=np.int64)
    u_new = np.zeros(6, np.int32)
    u_k = np.zeros(6, np.float32)
    w = fe.FrontendWork()
    fe.preproc(board_to_raw(v), w.cal, w.bias, u_new, u_k)
    assert list(u_new) == list(v * Q14_ONE)
    assert u_k.dtype == np.float32
    assert u_k[2] == pytest.approx(-9.80665, rel=1e-6)  # −1 g on z (down) at rest
    assert u_k[5] == pytest.approx(math.radians(900 / 16.4), rel=1e-6)


def test_preproc_subtracts_the_static_bias():
    bias = np.array([1, -2, 3, 40000, -5, 6], dtype=np.int32)
    conf = cfg.FrontendConfig(bias=bias)
    w = fe.FrontendWork(conf)
    u_new = np.zeros(6, np.int32)
    fe.preproc(board_to_raw(np.zeros(6)), w.cal, w.bias, u_new, np.zeros(6, np.float32))
    assert list(u_new) == list(-bias)


def _extreme_config() -> cfg.FrontendConfig:
    """The largest calibration and bias a FrontendConfig accepts (row abs sum 1.5, |bias| 2^27)."""
    cal = np.zeros((NR_IMUS, 2, 3, 3), dtype=np.int32)
    cal[..., 0] = Q14_ONE
    cal[..., 1] = -Q14_ONE // 4
    cal[..., 2] = Q14_ONE // 4  # row abs sum 1.5 · 2^14
    bias = np.array([cfg.BIAS_ABS_MAX, -cfg.BIAS_ABS_MAX] * 3, dtype=np.int32)
    return cfg.FrontendConfig(calibration=cal, bias=bias)


@pytest.mark.parametrize("value", [-32768, 32767])
@pytest.mark.parametrize("conf", [cfg.DEFAULT_FRONTEND, _extreme_config()], ids=["default", "extreme"])
def test_preproc_saturated_chips_do_not_overflow(value, conf):
    """Every axis of every chip saturated, any sign pattern: U_NEW is the exact (unwrapped) result."""
    w = fe.FrontendWork(conf)
    for pattern in range(16):
        raw = np.full((NR_IMUS, 6), value, dtype=np.int16)
        for k in range(NR_IMUS):
            if pattern >> k & 1:
                raw[k] = -32768 if value > 0 else 32767
        u_new = np.zeros(6, np.int32)
        fe.preproc(raw, w.cal, w.bias, u_new, np.zeros(6, np.float32))
        exact = exact_preproc(raw, w.cal, w.bias)
        assert [int(x) for x in u_new] == exact
        assert all(abs(x) < 2**30 for x in exact)  # so the >> 16 reduction fits int16


def test_frontend_config_refuses_a_calibration_that_could_overflow():
    cal = cfg.DEFAULT_FRONTEND.calibration.copy()
    cal[0, 0, 0, 1] = Q14_ONE  # row abs sum 2.0
    with pytest.raises(ValueError, match="overflow"):
        cfg.FrontendConfig(calibration=cal)
    with pytest.raises(ValueError, match="bias"):
        cfg.FrontendConfig(bias=np.array([2**28, 0, 0, 0, 0, 0], dtype=np.int32))


# --------------------------------------------------------------------------------- helpers


@given(st.integers(min_value=0, max_value=2**62))
def test_isqrt64_is_the_integer_square_root(x):
    assert fe.isqrt64(x) == math.isqrt(x)


def _reference_window_stats(u_hist: list[np.ndarray]) -> tuple[int, int, list[int]]:
    """Brute-force T1, T2 and U_INT_K from the last N U_NEW samples (unbounded ints)."""
    n, m = cfg.N, cfg.M
    red = [[int(x) >> cfg.RED_SHIFT_F for x in u[0:3]] + [int(x) >> cfg.RED_SHIFT_G for x in u[3:6]]
           for u in u_hist[-n:]]
    k = n - 1 - n // 2  # judged sample, index in the window (newest is n − 1)
    zupt_win = red[k - m // 2 + 1: k + m // 2 + 1]
    a = [sum(s[i] for s in zupt_win) for i in range(3)]
    c = sum(s[0] ** 2 + s[1] ** 2 + s[2] ** 2 for s in zupt_win)
    d = sum(s[3] ** 2 + s[4] ** 2 + s[5] ** 2 for s in zupt_win)
    g = cfg.G_RED
    t1 = (c >> cfg.LOG2_M) - ((2 * g * math.isqrt(sum(x * x for x in a))) >> cfg.LOG2_M) + g * g \
        + ((cfg.SR_Q * (d >> cfg.LOG2_M)) >> cfg.SR_SHIFT)
    aa = [sum(s[i] for s in red) for i in range(6)]
    cc = sum(s[0] ** 2 + s[1] ** 2 + s[2] ** 2 for s in red)
    dd = sum(s[3] ** 2 + s[4] ** 2 + s[5] ** 2 for s in red)
    var_f = (cc >> cfg.LOG2_N) - (sum(x * x for x in aa[0:3]) >> 2 * cfg.LOG2_N)
    var_g = (dd >> cfg.LOG2_N) - (sum(x * x for x in aa[3:6]) >> 2 * cfg.LOG2_N)
    t2 = var_f + ((cfg.SR_Q * var_g) >> cfg.SR_SHIFT)
    return max(t1, 0), max(t2, 0), [int(x) for x in u_hist[-n:][k]]


def _run_statdet(samples: list[np.ndarray], th_zupt=cfg.TH_ZUPT_DEFAULT, th_zaru=cfg.TH_ZARU_DEFAULT):
    w = fe.FrontendWork()
    u_int_k = np.zeros(6, np.int32)
    out = np.zeros(5, np.uint32)
    results = []
    for n, u in enumerate(samples):
        fe.statdet(np.asarray(u, dtype=np.int32), (n * 64000) & 0xFFFFFFFF, w.buf32, w.buf16, w.norm, w.ts,
                   w.newest, w.zaru_ab, w.zaru_cd, w.zupt_a, w.zupt_cd, th_zupt, th_zaru, u_int_k, out)
        results.append((int(out[0]), int(out[1]), bool(out[2]), bool(out[3]), u_int_k.copy(), int(out[4])))
    return w, results


_SAT = 32768 * Q14_ONE  # |U_NEW| of a saturated axis with the default calibration

u_new_values = st.lists(st.integers(min_value=-_SAT, max_value=_SAT - Q14_ONE), min_size=6, max_size=6)


@settings(max_examples=30, deadline=None)
@given(st.lists(u_new_values, min_size=cfg.N, max_size=3 * cfg.N))
def test_running_sums_equal_brute_force_statistics(seq):
    """Add-newest/subtract-oldest sums give exactly the windows' statistics, for any input."""
    samples = [np.array(s, dtype=np.int64) for s in seq]
    _, results = _run_statdet(samples)
    for n in range(cfg.N - 1, len(samples)):
        t1, t2, mid = _reference_window_stats(samples[: n + 1])
        assert t1 < 2**32 and t2 < 2**32
        assert results[n][0] == t1
        assert results[n][1] == t2
        assert list(results[n][4]) == mid


def test_saturated_motion_never_wraps_into_a_false_zupt():
    """Every axis saturated, worst-case alternating signs: statistics exact, huge, and no ZUPT/ZARU."""
    hi, lo = 32767 * Q14_ONE, -32768 * Q14_ONE
    patterns = [np.full(6, hi), np.full(6, lo), np.array([hi, lo] * 3), np.array([lo, hi] * 3)]
    samples = [patterns[(n // 3) % 4] if n % 2 else patterns[n % 4] for n in range(6 * cfg.N)]
    th_max = 2**32 - 1  # even the largest possible thresholds
    _, results = _run_statdet(samples, th_zupt=cfg.TH_ZUPT_DEFAULT, th_zaru=th_max)
    for n in range(cfg.N - 1, len(samples)):
        t1, t2, _ = _reference_window_stats(samples[: n + 1])
        assert results[n][0] == t1 and results[n][1] == t2
        assert t1 > 2**20  # saturated motion is far from stationary
        assert not results[n][2] and not results[n][3]
    # and the largest statistics any input can produce stay below 2^32 (no wrap to small)
    _, res_const = _run_statdet([np.full(6, lo)] * (2 * cfg.N))
    assert max(r[0] for r in results + res_const) < 2**32


def test_still_board_is_zupt_and_zaru_and_the_output_lags_n_over_2():
    still = (np.array([0, 0, -G_LSB, 0, 0, 0]) * Q14_ONE).astype(np.int64)
    samples = [still + np.array([n, 0, 0, 0, 0, 0]) for n in range(3 * cfg.N)]  # tiny ramp to tag samples
    _, results = _run_statdet(samples)
    assert not results[cfg.N // 2][2]  # buffer not yet full: zeros are far from g
    for n in range(cfg.N, len(samples)):
        t1, t2, zupt, zaru, mid, ts = results[n]
        assert zupt and zaru
        assert int(mid[0]) == n - cfg.N // 2  # the judged sample is N/2 behind the newest
        assert ts == (n - cfg.N // 2) * 64000


def test_t1_is_the_shoe_statistic_times_sigma_a_squared():
    """On a moving window the integer T1 matches the float SHOE formula (within truncation)."""
    rng = np.random.default_rng(3)
    f = np.array([0.1, -0.2, -1.0]) * G_LSB * Q14_ONE + rng.normal(0, 40 * Q14_ONE * 64, (3 * cfg.N, 3))
    w = rng.normal(0, 30 * Q14_ONE * 16, (3 * cfg.N, 3))
    samples = [np.concatenate([f[n], w[n]]).astype(np.int64) for n in range(3 * cfg.N)]
    _, results = _run_statdet(samples)
    n = len(samples) - 1
    red = np.array([[int(x) >> 16 for x in s] for s in samples[-cfg.N:]], dtype=float)
    k = cfg.N - 1 - cfg.N // 2
    win = red[k - cfg.M // 2 + 1: k + cfg.M // 2 + 1]
    fbar = win[:, 0:3].mean(axis=0)
    shoe = np.mean(np.sum((win[:, 0:3] - cfg.G_RED * fbar / np.linalg.norm(fbar)) ** 2, axis=1)) \
        + cfg.SR_Q / 2**cfg.SR_SHIFT * np.mean(np.sum(win[:, 3:6] ** 2, axis=1))
    # truncations: C/M, SR·D/M (1 each), the integer √ (≤ 2g/M), float rounding
    assert results[n][0] == pytest.approx(shoe, abs=2 * cfg.G_RED / cfg.M + 3 + 1e-9 * shoe)


# --------------------------------------------------------------------------------- float parts


def test_convcomp_dt_wraps_modulo_2_32_and_bias_is_removed():
    u_int = (np.array([0, 0, -G_LSB, 164, 0, 0]) * Q14_ONE).astype(np.int32)
    t_prev = np.array([0xFFFFFF00], np.uint32)
    u_k = np.zeros(6, np.float32)
    dt = np.zeros((), np.float32)
    bias = np.array([0.01, 0, 0], np.float32)
    fe.convcomp(u_int, (0xFFFFFF00 + 64000) & 0xFFFFFFFF, bias, t_prev, u_k, dt)
    assert dt.dtype == np.float32 and float(dt) == pytest.approx(1e-3, rel=1e-6)
    assert u_k[3] == pytest.approx(math.radians(10.0) - 0.01, rel=1e-5)
    assert u_k.dtype == np.float32


def test_biasest_converges_to_a_constant_gyro_offset_only_while_zaru():
    w = fe.FrontendWork()
    offset = (np.array([0, 0, 0, 16, -33, 8]) * Q14_ONE).astype(np.int32)  # ≈ 1, −2, 0.5 °/s
    fe.biasest(offset, False, w.gyro_bias, w.bias_p, w.bias_q)
    assert not w.gyro_bias.any()
    for _ in range(200):
        fe.biasest(offset, True, w.gyro_bias, w.bias_p, w.bias_q)
    expect = np.radians(offset[3:6] / Q14_ONE / 16.4)
    np.testing.assert_allclose(w.gyro_bias, expect, rtol=1e-3)
    assert w.gyro_bias.dtype == np.float32 and w.bias_p.dtype == np.float32


def test_conv16_is_register_units_saturated():
    u16 = np.zeros(6, np.int16)
    fe.conv16(np.array([9.80665, -200.0, 0, math.radians(1.0), 0, 100.0], np.float32), u16)
    assert list(u16[:2]) == [2047, -32768] or list(u16[:2]) == [2048, -32768]
    assert u16[3] == 16 and u16[5] == 32767
