"""A walk's history kept compactly: :class:`Rows`, rows of one shape and dtype appended one at a time
into one numpy array that doubles when full.

A host keeps a row per step for the whole walk (a live page opened late shows all of it, the CSV
at the end writes every pose). As Python objects — a list of small arrays, each a header of about
100 bytes around its 32 or 128 bytes of numbers — a long walk's history weighs several times its
numbers and scatters them over the heap. Kept here, a row costs its numbers' bytes, and reading the
history is one copy of a contiguous block.

An array of :data:`OWN_MAPPING_BYTES` or more has a memory mapping of its own: the room not filled
yet is pages never touched (not resident), and the array it outgrew goes back to the system when it
is let go — on the heap, each outgrown array would leave a hole the next, larger one does not fit
in, and a long walk's host would grow by its history again in holes.
"""

from __future__ import annotations

import mmap
from collections.abc import Sequence

import numpy as np

__all__ = ["OWN_MAPPING_BYTES", "Rows"]

#: From this size on an array of rows has a memory mapping of its own (module docstring).
OWN_MAPPING_BYTES = 1 << 16


def _empty(rows: int, shape: tuple[int, ...], dtype: np.dtype) -> np.ndarray:
    """An uninitialised (rows, *shape) array: on the heap while small, else in a mapping of its own."""
    nbytes = rows * int(np.prod(shape, dtype=np.int64)) * dtype.itemsize
    if nbytes < OWN_MAPPING_BYTES:
        return np.empty((rows, *shape), dtype=dtype)
    return np.frombuffer(mmap.mmap(-1, nbytes), dtype=dtype).reshape(rows, *shape)


class Rows:
    """Rows of shape *shape* and *dtype*, appended at the end (:meth:`append`), the last one
    replaceable (:meth:`set_last`), all of them readable as one array (:meth:`view`, :meth:`copy`)."""

    def __init__(self, shape: Sequence[int] = (), dtype: type | np.dtype = np.float64, capacity: int = 64):
        self.shape = tuple(int(s) for s in shape)
        self._data = _empty(max(int(capacity), 1), self.shape, np.dtype(dtype))
        self._n = 0

    @classmethod
    def of(cls, rows: np.ndarray, dtype: type | np.dtype | None = None) -> Rows:
        """Rows holding a copy of the array *rows* (its first axis the rows)."""
        rows = np.asarray(rows, dtype=dtype)
        out = cls(rows.shape[1:], rows.dtype, capacity=len(rows))
        out._data[:len(rows)] = rows
        out._n = len(rows)
        return out

    def append(self, row) -> None:
        """Add *row* (copied) at the end."""
        if self._n == len(self._data):
            grown = _empty(2 * len(self._data), self.shape, self._data.dtype)
            grown[:self._n] = self._data
            self._data = grown
        self._data[self._n] = row
        self._n += 1

    def set_last(self, row) -> None:
        """Replace the last row with *row* (copied)."""
        if self._n == 0:
            raise IndexError("no row to replace")
        self._data[self._n - 1] = row

    def view(self) -> np.ndarray:
        """The rows as an array, not copied and read-only (appends after it do not show in it)."""
        v = self._data[:self._n]
        v.flags.writeable = False
        return v

    def writable(self) -> np.ndarray:
        """The rows as an array, not copied: writing to it changes them (e.g. turning a track)."""
        return self._data[:self._n]

    def copy(self) -> np.ndarray:
        """The rows as a new array."""
        return self._data[:self._n].copy()

    def __getitem__(self, k):
        return self.view()[k]

    def __len__(self) -> int:
        return self._n

    @property
    def nbytes(self) -> int:
        """The bytes the rows' array takes (filled or not)."""
        return self._data.nbytes

    @property
    def mapped(self) -> bool:
        """Whether the array has a memory mapping of its own (module docstring)."""
        return self._data.base is not None

    @property
    def resident_nbytes(self) -> int:
        """The bytes the rows take in memory: the filled rows' in a mapping of its own (the pages
        not filled yet are never touched), the whole array's on the heap."""
        return self._data[:self._n].nbytes if self.mapped else self._data.nbytes

    def __repr__(self) -> str:
        return f"Rows({self._n} of {self.shape} {self._data.dtype})"
