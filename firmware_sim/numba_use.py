"""numba as every compiled part of the emulator uses it: whether this process compiles at all, and
loading a compiled function from numba's on-disk cache without a compile's set-up.

The navigation kernels (:mod:`firmware_sim.nav.jit`), the simulation's loops
(:mod:`firmware_sim.sensors.compiled`) and the walk reader (:mod:`firmware_sim.sensors.openshoe_scan`)
all ask here, so ``OPENSHOE_PURE=1`` and numba's own
``NUMBA_DISABLE_JIT`` mean the same to every one.
"""

from __future__ import annotations

import os
from typing import Any

__all__ = ["compiling_wanted", "load_cached", "pure_requested"]


def pure_requested() -> bool:
    """Whether the user asked for the pure-Python path (``OPENSHOE_PURE=1``)."""
    return os.environ.get("OPENSHOE_PURE", "") == "1"


def compiling_wanted() -> bool:
    """Whether this process compiles: numba refused neither by ``OPENSHOE_PURE=1`` nor by numba's
    ``NUMBA_DISABLE_JIT``."""
    return not pure_requested() and os.environ.get("NUMBA_DISABLE_JIT", "") in ("", "0")


def load_cached(cache: Any, sig: Any, target_context: Any) -> Any:
    """numba's ``Cache.load_overload`` for a function that needs no object mode: the cached
    compile result of *sig*, or None, with numba's runtime started (the compiled code links
    against it) but not the typing and lowering registries numba's own version refreshes first,
    which only a compile needs (and sets up itself)."""
    from numba.core.runtime import rtsys

    rtsys.initialize(target_context)
    return cache._load_overload(sig, target_context)
