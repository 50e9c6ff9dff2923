"""The simulation's compiled loops: numba's, cached on disk, each the same numbers as its numpy form.

A simulated walk spends most of its time in a few loops over its samples (the stance sway's sums of
sines, :mod:`.sines`; the prefix scan of the bias instability and the DLPF, :mod:`.mpu9150`). Each
is written twice: its numpy form, the definition, and a loop of plain Python for numba's nopython
mode that performs the same IEEE operations on the same numbers in the same order (so the same
bits; each loop's tests compare the two). :func:`compiled` gives such a loop compiled — loaded from
numba's cache, or compiled on its first call in a process that finds none (seconds, once) — or
None without numba (the optional ``fast`` extra), with ``OPENSHOE_PURE=1`` or ``NUMBA_DISABLE_JIT``;
its caller then runs the numpy form. :func:`firmware_sim.sensors.warm_up_compiled_loops` readies
every loop of the simulation at once.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import Any

from firmware_sim.numba_use import compiling_wanted, load_cached

__all__ = ["compiled", "wanted"]

#: Each loop's compiled form once found (None: none in this process).
_found: dict[Callable[..., Any], Callable[..., Any] | None] = {}


#: Whether this process compiles (numba not refused by ``OPENSHOE_PURE`` or ``NUMBA_DISABLE_JIT``).
wanted = compiling_wanted


def compiled(loop: Callable[..., Any], *inlined: Callable[..., Any]) -> Callable[..., Any] | None:
    """*loop* compiled (nopython, releasing the GIL, C's float division), the helpers *inlined* that
    it calls by name compiled into it; None when this process does not compile."""
    if loop not in _found:
        _found[loop] = _compile(loop, inlined) if wanted() else None
    return _found[loop]


def _compile(loop: Callable[..., Any], inlined: tuple[Callable[..., Any], ...]) -> Callable[..., Any] | None:
    try:
        import numba
    except ImportError:  # pragma: no cover - depends on the environment
        return None
    options = {"cache": True, "nogil": True, "error_model": "numpy"}
    module = sys.modules[loop.__module__]
    for helper in inlined:  # the loop finds its helpers by name in its module: compiled ones
        setattr(module, helper.__name__, numba.njit(inline="always", **options)(helper))
    dispatcher = numba.njit(**options)(loop)
    cache = dispatcher._cache

    cache.load_overload = lambda sig, target_context: load_cached(cache, sig, target_context)
    return dispatcher  # type: ignore[no-any-return]
