"""Pinned filter outputs that hold on any machine: "with the state not held, the filter is as it was".

A filter's float64 states and covariances go through BLAS (matrix products), and OpenBLAS picks
its kernel by the processor (or by ``OPENBLAS_CORETYPE``): an AVX-512 kernel and a Haswell one
round a product differently in the last bit, and a filter carries that on. A SHA-256 of the bytes
then pins the machine, not the code. On the pinned walks the two kernels differ by at most 9e-10
of a value; a change of the filter's behaviour moves them by far more.

So each array is pinned by one number, its values projected on fixed weights (a golden-angle
cosine: deterministic, of mixed sign, never periodic, so no change cancels by accident), and
compared within :data:`RTOL` of its values' weighted absolute sum.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

#: How far a pinned projection may move, as a share of Σ|a_i w_i|: 10× the two kernels' largest
#: relative difference of one value on the pinned walks.
RTOL = 1e-8
_GOLDEN_ANGLE = 2.399963229728653  # rad


def _weights(n: int) -> np.ndarray:
    return np.cos(_GOLDEN_ANGLE * (np.arange(n) + 1.0))


def _flat(array) -> np.ndarray:
    return np.ravel(np.asarray(array, dtype=np.float64))


def fingerprint(arrays: Sequence) -> list[float]:
    """Each array's values projected on the fixed weights: what :func:`assert_as_pinned` compares."""
    return [float(_flat(a) @ _weights(_flat(a).size)) for a in arrays]


def assert_as_pinned(arrays: Sequence, pinned: Sequence[float]) -> None:
    """Every array's projection within :data:`RTOL` of its pinned value."""
    assert len(arrays) == len(pinned), f"{len(arrays)} arrays, {len(pinned)} pinned"
    for i, (array, value) in enumerate(zip(arrays, pinned, strict=True)):
        flat = _flat(array)
        w = _weights(flat.size)
        tolerance = RTOL * float(np.abs(flat) @ np.abs(w))
        got = float(flat @ w)
        assert abs(got - value) <= tolerance, (f"array {i}: {got!r} is not the pinned {value!r} "
                                               f"(± {tolerance:.3g})")
