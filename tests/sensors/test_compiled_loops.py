"""The simulation's compiled loops (the stance sway's sums of sines, the bias instability's and the
DLPF's prefix scan): the same bits as their numpy forms."""

from __future__ import annotations

import numpy as np
import pytest

from firmware_sim.sensors import mpu9150, sines, warm_up_compiled_loops
from firmware_sim.sensors.scenarios import trajectory


def rows_of(starts: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    j = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, None)
    return j, t - starts[j]


def needs_compiled_loops(monkeypatch):
    """The compiled loops, for any size of input (a short walk's take the numpy forms)."""
    if not warm_up_compiled_loops():
        pytest.skip("numba is not installed (or OPENSHOE_PURE=1): the numpy forms run")
    monkeypatch.setattr(sines, "_COMPILED_FROM", 0)
    monkeypatch.setattr(mpu9150, "_SCAN_COMPILED_FROM", 0)


@pytest.mark.parametrize("components", [1, 5, 8, 16, 21, 128])
def test_compiled_sums_are_numpys_bit_for_bit(monkeypatch, components):
    needs_compiled_loops(monkeypatch)
    rng = np.random.default_rng(components)
    blocks = 40
    freq = 2.0 * np.pi * rng.uniform(0.5, 130.0, (blocks, 3, components))
    phase = 2.0 * np.pi * rng.random((blocks, 3, components))
    amp = rng.standard_normal((blocks, 3, components)) * 10.0 ** rng.uniform(-6, 1, (blocks, 3, 1))
    amp[3] = -0.0  # a block whose terms are all −0: numpy's sum gives +0
    starts = np.cumsum(rng.uniform(0.2, 0.9, blocks))
    t = np.concatenate([np.arange(starts[0], starts[-1] + 0.5, 1e-3), rng.uniform(starts[0], 30.0, 999)])
    j, u = rows_of(starts, t)  # in time order, then rows of blocks in no order
    want = sines.reference_sum_of_sines(freq, phase, amp, j, u)
    got = sines.sum_of_sines(freq, phase, amp, j, u)
    for w, g in zip(want, got, strict=True):
        assert w.tobytes() == g.tobytes()
    first = sines.sum_of_sines(freq, phase, amp, j, u, second=False)  # a rate needs no second derivative
    assert [x.tobytes() for x in first[:2]] == [x.tobytes() for x in want[:2]] and first[2].size == 0


def test_a_swaying_walk_is_the_same_with_or_without_the_compiled_sums(monkeypatch):
    walk = trajectory("stand:1+walk:8").with_stance_sway(seed=3)
    t = np.arange(9000) / 1000.0
    monkeypatch.setattr(sines, "_COMPILED_FROM", 0)  # compiled however short, where numba is
    fast = walk.evaluate(t)
    monkeypatch.setattr(sines, "compiled", lambda *loop: None)
    plain = walk.evaluate(t)
    for name in ("pos", "vel", "acc", "euler", "omega_b", "alpha_b", "f_b"):
        assert getattr(fast, name).tobytes() == getattr(plain, name).tobytes(), name


@pytest.mark.parametrize("beta", [0.3, 0.97, 1.0 - 1e-5])
@pytest.mark.parametrize("shape", [(1,), (2, 3), (5000,), (3001, 4, 3)])
def test_the_compiled_scan_is_numpys_bit_for_bit(monkeypatch, beta, shape):
    needs_compiled_loops(monkeypatch)
    x = np.random.default_rng(len(shape)).standard_normal(shape)
    fast = mpu9150._first_order_scan(x.copy(), beta)
    monkeypatch.setattr(mpu9150, "compiled", lambda *loop: None)
    assert fast.tobytes() == mpu9150._first_order_scan(x.copy(), beta).tobytes()
    assert fast.tobytes() == mpu9150._first_order_scan(np.asfortranarray(x), beta).tobytes()  # numpy's
