"""A first-order Gauss–Markov state of the host's filter: the local compass deviation d over the
distance walked (:mod:`hostlib.fusion.deviation`), the receiver's bias b over time
(:mod:`hostlib.fusion.gps_bias`).

Over a span s (metres or seconds) of a process with correlation scale L and stationary variance σ²,
the state decays by φ = exp(−|s|/L) and its variance gains q = (1 − φ²) σ²
(:func:`transition`); :func:`decay` applies that to the filter's state and covariance.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np

__all__ = ["decay", "require_positive", "transition"]


def require_positive(model: object, names: Iterable[str]) -> None:
    """Refuse a *model* whose fields *names* are not each a finite number > 0 (ValueError)."""
    for name in names:
        value = getattr(model, name)
        if not (math.isfinite(value) and value > 0.0):
            raise ValueError(f"{name} must be a finite number > 0, got {value}")


def transition(span: float, scale: float, variance: float) -> tuple[float, float]:
    """(φ, q) over *span* (either sign) of a process of correlation *scale* and stationary
    *variance*: x ← φ x, var x ← φ² var x + q."""
    s = abs(float(span))
    return math.exp(-s / scale), -math.expm1(-2.0 * s / scale) * variance


def decay(x: np.ndarray, p: np.ndarray, indices: Iterable[int], phi: float, q: float) -> None:
    """Carry the states *indices* of *x* (covariance *p*) through one :func:`transition`, in place:
    each state times φ, its covariances with the rest φ times theirs, its variance φ² times its own
    plus q."""
    for i in indices:
        x[i] *= phi
        p[i, :] *= phi
        p[:, i] *= phi
        p[i, i] += q
