"""Checks shared by the aid states' property tests: a covariance stays symmetric and positive
semi-definite, and a two-feet filter stays so through a random walk of steps, stands, gaps and
missing compass readings."""

from __future__ import annotations

import numpy as np

from hostlib.fusion.feet import FOOT_SIDES, FootStep, TwoFeetTracker


def assert_symmetric_psd(p: np.ndarray) -> None:
    """*p* is symmetric and positive semi-definite, to rounding relative to its largest element."""
    scale = max(1.0, np.abs(p).max())
    np.testing.assert_allclose(p, p.T, rtol=0, atol=1e-12 * scale)
    assert np.linalg.eigvalsh(0.5 * (p + p.T)).min() >= -1e-9 * scale


def walk_two_feet_at_random(feet: TwoFeetTracker, rng: np.random.Generator, steps: int = 80) -> None:
    """*steps* alternating steps into *feet*, a fifth of them standing, a tenth without a compass
    reading, 3 % after a gap; the joint covariance is checked after every one."""
    for n in range(steps):
        side = FOOT_SIDES[n % 2]
        length_m = 0.0 if rng.random() < 0.2 else rng.uniform(0.2, 1.6)
        dx = np.array([length_m, 0.05 * rng.standard_normal(), 0.01 * rng.standard_normal(),
                       0.1 * rng.standard_normal()])
        reading = None if rng.random() < 0.1 else rng.uniform(-3, 3)
        feet.take(FootStep(side, dx, np.diag(rng.uniform(1e-6, 1e-2, 4)), 0.5 * (n + 1),
                           after_gap=rng.random() < 0.03, compass=reading))
        assert_symmetric_psd(feet.filter.P)
