"""A board's vectors as each of its chips' int16 registers (:func:`chip_registers`): how a recording
of one sensor is served as the replicated chips of a board (:class:`~.replay.ReplaySource`)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .truth import is_signed_permutation, rotate

__all__ = ["chip_registers"]


def _half_sample_ahead(v: np.ndarray) -> np.ndarray:
    """*v* (n, …) half a sample later in time: the mean of each sample and the next (the last kept)."""
    out = v.copy()
    out[:-1] = 0.5 * (v[:-1] + v[1:])
    return out


def _to_chips(mount: np.ndarray, v: np.ndarray, *factors: np.ndarray) -> np.ndarray:
    """(n, chips, 3): each board vector *v[n]* in each chip's axes, ``mount[k] @ v[n]``.

    *mount* may be a product of *factors* (``einsum("ij,kjl,nl->nki", *factors, v)``). When every
    matrix is a signed permutation, :func:`~.truth.rotate` picks and negates the values, which
    gives the einsum's values exactly, many times faster.
    """
    factors = factors or (mount,)
    if not all(is_signed_permutation(m) for m in factors):
        spec = "kij,nj->nki" if len(factors) == 1 else "ij,kjl,nl->nki"
        return np.einsum(spec, *factors, v)
    return np.stack([rotate(m, v) for m in mount], axis=1)


def chip_registers(mount: np.ndarray, v: np.ndarray, counts: Callable[[np.ndarray], np.ndarray],
                    full_scale: tuple[int, int], *factors: np.ndarray, ahead: bool = False) -> np.ndarray:
    """(n, chips, 3) int16: the registers of each chip for the board vectors *v* (n, 3) —
    ``clip(rint(counts(mount[k] @ v[n])), *full_scale)``, served half a sample ahead when *ahead*
    (``_half_sample_ahead`` of the chips' vectors); *mount* and *factors* as in ``_to_chips``.

    When every matrix is a signed permutation, the board's vectors are converted once and then
    picked and negated for each chip: negating commutes exactly with the mean of two samples, the
    scaling and the rounding (to nearest, ties to even), so the registers are the same numbers
    as the chips' vectors converted one by one; only the saturation, whose range is not
    symmetric, comes after the pick.
    """
    if all(is_signed_permutation(m) for m in factors or (mount,)):
        cols = np.argmax(mount != 0, axis=2)  # (chips, 3): the board axis of each chip axis …
        signs = np.take_along_axis(mount, cols[..., None], axis=2)[..., 0]  # … and its sign
        board = np.rint(counts(_half_sample_ahead(v) if ahead else v))
        chips = board[:, cols.ravel()] * signs.ravel()
        chips = chips.reshape(len(v), *cols.shape)
    else:
        chips = _to_chips(mount, v, *factors)
        chips = np.rint(counts(_half_sample_ahead(chips) if ahead else chips))
    return np.clip(chips, *full_scale, out=chips).astype(np.int16)
