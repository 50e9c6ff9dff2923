"""Whether a step's numbers can be summed: every number finite, its covariance dP symmetric and
positive semi-definite (:func:`step_problem`). A step that fails is counted and left out by the
tracker (:class:`hostlib.track.steps.StepTracker`): a NaN would poison every later pose, a negative
variance every later covariance."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["COVARIANCE_TOLERANCE", "step_problem"]


#: How far below zero a step covariance's smallest eigenvalue may lie, as a share of its largest:
#: the module computes dP in float32 (ε 6e-8) and sends its upper triangle, so a real dP is
#: symmetric and positive semi-definite to a few ε; a sign error or a corrupted number is far out.
COVARIANCE_TOLERANCE = 1e-5


def step_problem(dx: np.ndarray, dp: np.ndarray) -> str | None:
    """What makes a step *dx* (4,) with covariance *dp* (4×4) impossible to sum, or None: a number
    that is not finite (a NaN poisons every later pose), or a *dp* that is not symmetric positive
    semi-definite (a negative variance)."""
    if _plainly_summable(dx, dp):
        return None  # what nearly every step is: the tests below only say what is wrong
    if not np.isfinite(dx).all():
        return f"dx {np.array2string(dx, precision=4)} is not finite"
    if not np.isfinite(dp).all():
        return "dP holds a number that is not finite"
    if not (np.abs(dp - dp.T) <= COVARIANCE_TOLERANCE * np.abs(dp.T)).all():  # np.allclose's test, atol 0
        return "dP is not symmetric"
    eig = np.linalg.eigvalsh(0.5 * (dp + dp.T))
    if eig[0] < -COVARIANCE_TOLERANCE * max(abs(eig[-1]), abs(eig[0])):
        return f"dP is not positive semi-definite (eigenvalue {eig[0]:.3g})"
    return None


_PAIRS = [(i, j) for i in range(4) for j in range(i + 1, 4)]  #: dP's elements above the diagonal


def _plainly_summable(dx: np.ndarray, dp: np.ndarray) -> bool:
    """True when *dx* and *dp* pass :func:`step_problem`'s tests for sure, in a tenth of their time:
    every number finite, *dp* symmetric by the same test, and its symmetric part with an LDLᵀ
    factorisation of positive pivots (so positive definite: the eigenvalue test passes). False
    sends the caller to the tests themselves (a wrong number, a semi-definite dP, or rounding at
    the edge)."""
    rows = dp.tolist()
    if not math.isfinite(sum(dx.tolist()) + sum(map(sum, rows))):  # a sum is finite only if each is
        return False
    tol = COVARIANCE_TOLERANCE
    for i, j in _PAIRS:
        a, b = rows[i][j], rows[j][i]
        if not (abs(a - b) <= tol * abs(b) and abs(b - a) <= tol * abs(a)):
            return False
    (a00, a01, a02, a03), (a10, a11, a12, a13), (a20, a21, a22, a23), (a30, a31, a32, a33) = rows
    b01, b02, b03 = 0.5 * (a01 + a10), 0.5 * (a02 + a20), 0.5 * (a03 + a30)
    b12, b13, b23 = 0.5 * (a12 + a21), 0.5 * (a13 + a31), 0.5 * (a23 + a32)
    if not a00 > 0.0:
        return False
    l10, l20, l30 = b01 / a00, b02 / a00, b03 / a00
    d1 = a11 - l10 * b01
    if not d1 > 0.0:
        return False
    c21, c31 = b12 - l20 * b01, b13 - l30 * b01
    l21, l31 = c21 / d1, c31 / d1
    d2 = a22 - l20 * b02 - l21 * c21
    if not d2 > 0.0:
        return False
    c32 = b23 - l30 * b02 - l31 * c21
    return a33 - l30 * b03 - l31 * c31 - (c32 / d2) * c32 > 0.0
