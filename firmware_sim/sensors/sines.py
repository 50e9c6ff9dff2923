"""Sums of sinusoids and their first two derivatives, row by row: the stance sway's inner loop.

:func:`sum_of_sines` gives, for times *u* (rows) and per row a block of frequencies, phases and
amplitudes (one block per stance, ``j[row]`` its index), Σ a·sin(ω u + φ) and its first two
derivatives in u — the :class:`~firmware_sim.sensors.stance_sway.StanceSway` of every walking
stance of a simulated walk, a few million sines per walk and most of its simulation's time.

:func:`reference_sum_of_sines` is the definition, in numpy. Compiled (:mod:`.compiled`: numba, the
optional ``fast`` extra, cached on disk) the same numbers come about twice as fast, bit for bit:
each sine and cosine is the C library's (as numpy's are), each product and sum the same IEEE
operation in the same order (numpy sums the last axis pairwise: ``_pairwise``), and the
compiled loop takes a stance's rows one component after the other, so the C library's sine meets
arguments that grow steadily from one call to the next (about twice as fast as the same arguments
in numpy's order, whose branches it mispredicts). Without numba, or with ``OPENSHOE_PURE=1``, the
reference runs.
"""

from __future__ import annotations

import math

import numpy as np

from .compiled import compiled

__all__ = ["reference_sum_of_sines", "sum_of_sines", "warm_up"]

Sums = tuple[np.ndarray, np.ndarray, np.ndarray]

#: Rows of :func:`reference_sum_of_sines` evaluated at a time: its (rows, 3, components) temporaries
#: then stay in the cache (each row's sums are the same, row by row, whatever the chunk).
_SINES_CHUNK = 2048
#: Rows of one stance the compiled loop evaluates at a time: its (components, rows) buffers stay
#: in the first-level cache.
_ROWS = 128
#: numpy sums up to this many numbers in eight interleaved partial sums (its ``PW_BLOCKSIZE``);
#: ``_pairwise`` does the same, so a stance of more components takes the reference.
_PAIRWISE_BLOCK = 128
#: The fewest sines (rows × components) worth the compiled loop: a shorter walk's (a walk of about
#: 20 s) take the reference, a few tens of milliseconds, and a process with an empty cache of
#: numba's compiles nothing for it (the compile takes seconds: a new user's first short walk).
_COMPILED_FROM = 200_000


def reference_sum_of_sines(freq: np.ndarray, phase: np.ndarray, amp: np.ndarray, j: np.ndarray,
                           u: np.ndarray, second: bool = True) -> Sums:
    """Σ a·sin(ω u + φ) over the last axis and its first two derivatives in u, (rows, axes) each,
    row r with block j[r]'s (blocks, axes, components) *freq*, *phase* and *amp* (the second
    derivative empty, (0, axes), unless *second*)."""
    amp_freq = amp * freq
    amp_freq2 = amp_freq * freq
    out = tuple(np.empty((len(u) if m < 2 or second else 0, freq.shape[1])) for m in range(3))
    for a in range(0, len(u), _SINES_CHUNK):
        b = a + _SINES_CHUNK
        jj = j[a:b]
        arg = freq[jj] * u[a:b, None, None] + phase[jj]
        sin = np.sin(arg)
        out[0][a:b] = np.sum(amp[jj] * sin, axis=2)
        out[1][a:b] = np.sum(amp_freq[jj] * np.cos(arg), axis=2)
        if second:
            out[2][a:b] = -np.sum(amp_freq2[jj] * sin, axis=2)
    return out  # type: ignore[return-value]


def _pairwise(v: np.ndarray, row: int, n: int) -> float:
    """Σ v[:n, row] as numpy's ``sum`` adds n ≤ 128 numbers: 0 plus eight partial sums, each
    taking every eighth number, added as a tree, then the last n mod 8 numbers one by one
    (fewer than 8: one by one from 0)."""
    if n < 8:
        res = 0.0
        for i in range(n):
            res += v[i, row]
        return 0.0 + res
    r0, r1, r2, r3 = v[0, row], v[1, row], v[2, row], v[3, row]
    r4, r5, r6, r7 = v[4, row], v[5, row], v[6, row], v[7, row]
    i = 8
    while i < n - n % 8:
        r0 += v[i, row]
        r1 += v[i + 1, row]
        r2 += v[i + 2, row]
        r3 += v[i + 3, row]
        r4 += v[i + 4, row]
        r5 += v[i + 5, row]
        r6 += v[i + 6, row]
        r7 += v[i + 7, row]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        res += v[i, row]
        i += 1
    return 0.0 + res


def _sines_loop(freq, phase, amp, j, u, s0, s1, s2):  # type: ignore[no-untyped-def]
    """:func:`reference_sum_of_sines` into *s0*, *s1*, *s2* (*s2* with no rows: not computed): per
    run of rows of one block (at most ``_ROWS``), per axis and component the sines of its rows,
    then each row's sums."""
    second = len(s2) > 0
    n, axes, k = len(u), freq.shape[1], freq.shape[2]
    v0 = np.empty((k, _ROWS))
    v1 = np.empty((k, _ROWS))
    v2 = np.empty((k, _ROWS))
    lo = 0
    while lo < n:
        b = j[lo]
        hi = lo + 1
        while hi < n and hi - lo < _ROWS and j[hi] == b:
            hi += 1
        for a in range(axes):
            for c in range(k):
                w, p, am = freq[b, a, c], phase[b, a, c], amp[b, a, c]
                af = am * w  # the reference's amp_freq and amp_freq2
                af2 = af * w
                for q in range(hi - lo):
                    arg = w * u[lo + q] + p
                    sin = math.sin(arg)
                    v0[c, q] = am * sin
                    v1[c, q] = af * math.cos(arg)
                    if second:
                        v2[c, q] = af2 * sin
            for q in range(hi - lo):
                s0[lo + q, a] = _pairwise(v0, q, k)
                s1[lo + q, a] = _pairwise(v1, q, k)
                if second:
                    s2[lo + q, a] = -_pairwise(v2, q, k)
        lo = hi


def sum_of_sines(freq: np.ndarray, phase: np.ndarray, amp: np.ndarray, j: np.ndarray, u: np.ndarray,
                 second: bool = True) -> Sums:
    """:func:`reference_sum_of_sines`, bit for bit, compiled when numba is there."""
    worth = freq.shape[2] <= _PAIRWISE_BLOCK and len(u) * freq.shape[2] >= _COMPILED_FROM
    loop = compiled(_sines_loop, _pairwise) if worth else None
    if loop is None:
        return reference_sum_of_sines(freq, phase, amp, j, u, second)
    freq, phase, amp = (np.ascontiguousarray(x, dtype=np.float64) for x in (freq, phase, amp))
    out = tuple(np.empty((len(u) if m < 2 or second else 0, freq.shape[1])) for m in range(3))
    loop(freq, phase, amp, np.ascontiguousarray(j, dtype=np.int64), np.ascontiguousarray(u, dtype=np.float64),
         *out)
    return out  # type: ignore[return-value]


def warm_up() -> bool:
    """Load the compiled loop from numba's cache, or compile it, now; whether it is compiled."""
    loop = compiled(_sines_loop, _pairwise)
    if loop is not None:
        z = np.zeros((1, 3, 1))
        loop(z, z, z, np.zeros(1, dtype=np.int64), np.zeros(1), *(np.empty((1, 3)) for _ in range(3)))
    return loop is not None
