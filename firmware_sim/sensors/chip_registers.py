"""A board's vectors as each of its chips' int16 registers (:func:`chip_registers`, and
:func:`chip_register_parts` for several sensors of one chip at once): how a recording of one sensor is
served as the replicated chips of a board (:class:`~.replay.ReplaySource`)."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from .truth import is_signed_permutation, rotate

__all__ = ["RegisterPart", "chip_register_parts", "chip_registers"]

#: One sensor's part of a chip's registers: the board's vectors (n, 3), their counts before rounding,
#: the registers' range, and whether they are served half a sample ahead.
RegisterPart = tuple[np.ndarray, Callable[[np.ndarray], np.ndarray], tuple[int, int], bool]


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


def _signed_columns(part: RegisterPart) -> np.ndarray:
    """(n, 6) int16: the board's registers of one part, its three axes as they are and negated, each
    saturated after its sign (clip(−x) = −clip(x, −high, −low): the range is not symmetric)."""
    v, counts, (low, high), ahead = part
    board = np.rint(counts(_half_sample_ahead(v) if ahead else v))
    columns = np.empty((len(v), 6), dtype=np.int16)
    columns[:, :3] = np.clip(board, low, high)
    columns[:, 3:] = -np.clip(board, -high, -low)
    return columns


def _picks(mount: np.ndarray) -> np.ndarray:
    """(chips, 3): the column of :func:`_signed_columns` each chip axis takes (a signed permutation
    *mount*): its board axis, plus 3 when negated."""
    cols = np.argmax(mount != 0, axis=2)  # the board axis of each chip axis …
    signs = np.take_along_axis(mount, cols[..., None], axis=2)[..., 0]  # … and its sign
    return cols + 3 * (signs < 0)


def chip_registers(mount: np.ndarray, v: np.ndarray, counts: Callable[[np.ndarray], np.ndarray],
                    full_scale: tuple[int, int], *factors: np.ndarray, ahead: bool = False) -> np.ndarray:
    """(n, chips, 3) int16: the registers of each chip for the board vectors *v* (n, 3) —
    ``clip(rint(counts(mount[k] @ v[n])), *full_scale)``, served half a sample ahead when *ahead*
    (``_half_sample_ahead`` of the chips' vectors); *mount* and *factors* as in ``_to_chips``.

    When every matrix is a signed permutation, the board's vectors are converted once and then
    picked and negated for each chip: negating commutes exactly with the mean of two samples, the
    scaling and the rounding (to nearest, ties to even), so the registers are the same numbers
    as the chips' vectors converted one by one; only the saturation, whose range is not
    symmetric, is done for each sign apart (``_signed_columns``).
    """
    if all(is_signed_permutation(m) for m in factors or (mount,)):
        picks = _picks(mount)
        columns = _signed_columns((v, counts, full_scale, ahead))
        return columns[:, picks.ravel()].reshape(len(v), *picks.shape)
    chips = _to_chips(mount, v, *factors)
    chips = np.rint(counts(_half_sample_ahead(chips) if ahead else chips))
    return np.clip(chips, *full_scale, out=chips).astype(np.int16)


def chip_register_parts(mount: np.ndarray, parts: Sequence[RegisterPart]) -> np.ndarray:
    """(n, chips, 3 × parts) int16: :func:`chip_registers` of each part (e.g. the accelerometer's
    and the gyro's vectors), side by side in each chip's registers. For a signed permutation
    *mount* every part's signed columns make one table, from which each chip's registers are
    gathered at once (no copy of each part into its place)."""
    n = len(parts[0][0])
    if not is_signed_permutation(mount):
        return np.concatenate([chip_registers(mount, v, counts, full_scale, ahead=ahead)
                               for v, counts, full_scale, ahead in parts], axis=2)
    picks = _picks(mount)
    table = np.concatenate([_signed_columns(part) for part in parts], axis=1)
    index = np.concatenate([picks + 6 * k for k in range(len(parts))], axis=1)
    return table[:, index.ravel()].reshape(n, *index.shape)
