"""What the compiled navigation kernels are made from, without numba: their sources
(:data:`SOURCES`), the digest that stamps every compiled form of them (:func:`sources_stamp`: numba's
cache entries, :mod:`~firmware_sim.nav.jit`, and the loop built ahead of time,
:mod:`~firmware_sim.nav.aot`), and whether the user asked for the pure-Python path."""

from __future__ import annotations

import functools
import hashlib
from pathlib import Path

import firmware_sim.mcu.memory
import protocol.ids
import protocol.states

__all__ = ["SOURCES", "sources_stamp"]

_HERE = Path(__file__).resolve().parent
#: The sources whose contents stamp every compiled kernel: the navigation package (kernels,
#: reference functions, constants), the ids it sizes its arrays by, and the state table and
#: memory that lay out the state record the kernels read (records.STATE_RECORD: a new state
#: moves the others).
SOURCES = (*sorted(_HERE.glob("*.py")),
           *(Path(m.__file__).resolve() for m in (protocol.ids, protocol.states, firmware_sim.mcu.memory)))




@functools.cache
def sources_stamp() -> bytes:
    """The digest of the contents of :data:`SOURCES` (read once per process)."""
    digest = hashlib.sha256()
    for path in SOURCES:
        digest.update(path.read_bytes())
    return digest.digest()
