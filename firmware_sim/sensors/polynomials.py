"""The polynomials a foot's motion is made of: on τ ∈ [0, 1], with derivatives that vanish at the ends.

A swing (:mod:`~firmware_sim.sensors.gait`) goes from one pose to the next along the smoothstep
:func:`smoothstep` and adds bumps of the form τ^a (1−τ)^b (:func:`poly_from_roots`); a walking
stance's sway (:mod:`~firmware_sim.sensors.stance_sway`) is tapered in and out by a smoothstep.
Coefficients are numpy's (lowest order first).
"""

from __future__ import annotations

import numpy as np
from numpy.polynomial import polynomial as P

__all__ = ["poly_from_roots", "normalised", "smoothstep", "max_abs", "eval3"]


def poly_from_roots(zero_order: int, one_order: int) -> np.ndarray:
    """Coefficients of τ^a (1−τ)^b."""
    return P.polymul(np.r_[np.zeros(zero_order), 1.0], P.polypow([1.0, -1.0], one_order))


def normalised(c: np.ndarray) -> np.ndarray:
    """The polynomial *c* scaled so that its largest |value| on [0, 1] is 1."""
    tau = np.linspace(0.0, 1.0, 20001)
    return c / np.max(np.abs(P.polyval(tau, c)))


def smoothstep(order: int, shoulder: float = 0.0) -> np.ndarray:
    """0 → 1 on [0, 1], first *order* derivatives zero at both ends: ∫ τ^k (1−τ)^k (1 + c(2τ−1)²).

    The shoulder term c flattens the speed profile (peak/mean speed 2.07 for
    k = 5, c = 4, against 2.71 for c = 0), closer to a real swing.
    """
    shape = [1.0 + shoulder, -4.0 * shoulder, 4.0 * shoulder]  # 1 + c(2τ−1)²
    c = P.polyint(P.polymul(poly_from_roots(order, order), shape))
    return c / P.polyval(1.0, c)


def max_abs(c: np.ndarray) -> float:
    """The largest |value| of the polynomial *c* on [0, 1]."""
    return float(np.max(np.abs(P.polyval(np.linspace(0.0, 1.0, 20001), c))))


def eval3(c: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Value, first and second derivative of the polynomial c at x."""
    c1 = P.polyder(c)
    return _polyval(x, c), _polyval(x, c1), _polyval(x, P.polyder(c1))


def _polyval(x: np.ndarray, c: np.ndarray) -> np.ndarray:
    """numpy's ``polyval(x, c)`` of 1-d coefficients, bit for bit (its Horner steps, c[-1] + x·0
    then cᵢ + (…)·x), each step in place rather than in two new arrays."""
    out = c[-1] + x * 0
    for k in range(2, len(c) + 1):
        out *= x
        out += c[-k]
    return out
