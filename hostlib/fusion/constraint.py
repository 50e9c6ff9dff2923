"""The inter-foot constraint as a projection over two named pose blocks of the filter core.

The feet's last rests are never farther apart than γ (:mod:`hostlib.fusion.feet`). When the estimate
says they are, :func:`project_separation` moves it onto ``‖p_a − p_b‖ = γ`` with the covariance as
the metric (Simon and Chia 2002), the nearest point of that sphere exactly: with ``D`` the rows of
``p_a − p_b``, ``d = D x`` and ``C = D P Dᵀ``, ``x ← x − μ P Dᵀ (I + μ C)⁻¹ d``, the multiplier
μ ≥ 0 found (bisected on C's eigenvalues) so that ``‖(I + μ C)⁻¹ d‖ = γ``. The covariance stays:
the bound is an inequality the truth keeps well inside, not a measurement of the separation.

With *differential* pairs of blocks (the feet's poses, their modules' errors) only the difference
of each pair's correction is kept, half to each with opposite signs, and every other state stays:
the feet move apart or together and turn towards each other, their midpoint, mean heading and
mean errors do not. ``p_a − p_b`` ends where the full projection puts it, so the bound holds.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from .core import StateFilter

__all__ = ["project_separation"]


def project_separation(core: StateFilter, a: str, b: str, gamma: float,
                       differential: Sequence[tuple[str, str]] = ()) -> bool:
    """Project *core*'s estimate so that the positions of pose blocks *a* and *b* are at most
    *gamma* [m] apart (module docstring; *differential*: the pairs of blocks whose correction is
    kept to its difference); True if it moved it."""
    x, p = core.x, core.P
    ia, ib = core.slice(a), core.slice(b)
    pa, pb = slice(ia.start, ia.start + 3), slice(ib.start, ib.start + 3)
    apart = x[pa] - x[pb]
    if float(np.linalg.norm(apart)) <= gamma:
        return False
    p_d = p[:, pa] - p[:, pb]  # P Dᵀ
    c = p_d[pa] - p_d[pb]
    lam, v = np.linalg.eigh(0.5 * (c + c.T))
    lam = np.clip(lam, 0.0, None)
    w = v.T @ apart
    if float(np.sum(w[lam <= 1e-18] ** 2)) >= gamma ** 2:
        return False  # the violation lies where both feet are known exactly: nothing to move

    def apart_at(mu: float) -> np.ndarray:
        return v @ (w / (1.0 + mu * lam))

    def too_far(mu: float) -> bool:  # ‖apart_at(μ)‖ > γ, the norm as numpy's: √(y·y)
        y = apart_at(mu)
        return math.sqrt(float(y @ y)) > gamma

    lo, hi = 0.0, 1.0 / max(float(lam.max()), 1e-18)
    while too_far(hi):
        lo, hi = hi, 2.0 * hi
    for _ in range(200):  # ‖·‖ falls as μ grows: bisect to the float's resolution
        mid = 0.5 * (lo + hi)
        if mid in (lo, hi):
            break
        lo, hi = (mid, hi) if too_far(mid) else (lo, mid)
    step = -hi * (p_d @ apart_at(hi))
    if differential:
        kept = np.zeros_like(step)
        for block_a, block_b in differential:
            sa, sb = core.slice(block_a), core.slice(block_b)
            half = 0.5 * (step[sa] - step[sb])
            kept[sa], kept[sb] = half, -half
        step = kept
    core.project(x + step)
    return True
