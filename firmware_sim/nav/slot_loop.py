"""The numeric processing functions of any sequence, compiled: slot by slot, in the slots' order.

The compiled loop (:mod:`~firmware_sim.nav.driver`) runs the four sequences it knows as a whole. A
module may run any other sequence — a host's plain IMU mode (READ_INERTIAL, PREPROC), the front end
alone (0x32), a RUN_MULT_PROC of its own — which the processing functions then run in Python, at
some hundred µs a loop. ``slot_kernels.run_slots`` runs a stretch of such a sequence's slots compiled instead:
each slot's kernel on the module's records (the state memory and the works of the front end, the
INS, READ_INERTIAL and HEIGHT_COMPENSATION, as their bytes), reading and writing the states exactly
as its processing function does around the same kernels (:mod:`~firmware_sim.nav.frontend_kernels`,
:mod:`~firmware_sim.nav.ins_kernels`, the driver's per-slot kernels). The slots it runs are those of
:data:`COMPILED_SLOTS`; the others (READ_INERTIAL, which reads the sensor source, the sequence
control 0x01–0x07, CONV16) stay with the caller (:mod:`~firmware_sim.nav.any_sequence`).

INITIAL_ALIGNMENT ends a stretch when it completes the alignment: as in the compiled loop, the
attitude is then due from the caller (:func:`~firmware_sim.nav.loop_kinds.finish_alignment`), before
any later slot reads QUATERNION.

Built ahead of time like the compiled loop (:mod:`~firmware_sim.nav.aot`, :mod:`firmware_sim.prebuilt`):
:func:`slots_runner` is the built function when there is one for the present sources, else numba's,
else None (no numba: the caller runs the processing functions).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from firmware_sim import prebuilt
from firmware_sim.numba_use import pure_requested
from protocol.ids import ProcId

from .kernel_sources import sources_stamp

__all__ = ["COMPILED_SLOTS", "RUN_SLOTS_SIGNATURE", "build", "kernel_run_slots", "load", "module_path",
           "slots_runner"]

P = ProcId
#: The processing functions ``slot_kernels.run_slots`` runs (by id).
COMPILED_SLOTS = frozenset(int(p) for p in (
    P.FRONTEND_PREPROC, P.FRONTEND_STATDET, P.FRONTEND_BIASEST, P.FRONTEND_CONVCOMP,
    P.FRONTEND_INITIAL_ALIGNMENT, P.MECHANIZATION, P.TIME_UPDATE, P.ZUPT_UPDATE, P.STEPWISE_SYSTEM_RESET,
    P.HEIGHT_COMPENSATION))
#: The argument types every caller gives ``slot_kernels.run_slots`` (the built one takes exactly these).
RUN_SLOTS_SIGNATURE = "int64(int64[::1], int64, int64, uint8[::1], uint8[::1], uint8[::1], uint8[::1])"

_HERE = Path(__file__).resolve().parent
_found: list[tuple[Callable[..., int] | None, bool]] = []  #: the runner once looked for, and whether built


def kernel_run_slots() -> Callable[..., int]:
    """The kernel (numba's dispatcher; plain Python without numba)."""
    from . import slot_kernels

    return slot_kernels.run_slots  # type: ignore[no-any-return]


def _name() -> str:
    return f"openshoe_slots_{sources_stamp().hex()[:24]}"


def module_path() -> Path:
    """Where the module built from the present sources is (or would be)."""
    return prebuilt.module_path(_HERE, _name())


def slots_runner() -> Callable[..., int] | None:
    """The compiled ``slot_kernels.run_slots``: built ahead of time, else numba's; None without either (or
    with ``OPENSHOE_PURE=1``). Looked for once per process."""
    if not _found:
        run = None if pure_requested() else prebuilt.load(module_path(), "run_slots")
        ahead = run is not None
        if run is None and not pure_requested():
            from . import jit

            run = kernel_run_slots() if jit.COMPILING else None
        _found.append((run, ahead))
    return _found[0][0]


def load() -> None:
    """Have numba's kernel ready for its one signature (loaded from the cache, or compiled), when
    it is numba's; nothing for the built one."""
    run = slots_runner()
    if run is not None and not _found[0][1]:
        from . import jit

        one = np.zeros(1, dtype=np.uint8)
        jit.load(run, np.zeros(1, dtype=np.int64), 0, 0, one, one, one, one)


def build() -> bool:
    """Build ``slot_kernels.run_slots`` ahead of time for the present sources unless it is there, unwanted
    (``OPENSHOE_AOT=0``, ``OPENSHOE_PURE=1``) or failed before; whether it is there now. Needs numba
    (its ``pycc``) and a C compiler."""
    if not prebuilt.enabled() or pure_requested():
        return module_path().is_file()
    if module_path().is_file():
        return True
    built = prebuilt.build_once(module_path(), _compile)
    if built and _found and not _found[0][1]:  # numba's was found before this build: take the built one
        _found.clear()
    return built


def _compile(folder: Path) -> None:
    from numba.pycc import CC

    run: Any = kernel_run_slots()
    cc: Any = CC(_name())
    cc.output_dir = str(folder)
    cc.verbose = False
    cc.export("run_slots", RUN_SLOTS_SIGNATURE)(getattr(run, "py_func", run))
    cc.compile()
