"""Any process sequence with its numeric slots compiled: what a module runs outside the known sequences.

The compiled path (:mod:`~firmware_sim.nav.fastpath`) runs the sequences of tracking, the alignment
and the full-rate INS; any other sequence a host sets up — a plain IMU mode, the front end alone, a
RUN_MULT_PROC of its own, one that a hostile host scrambled — runs its processing functions one by
one (:meth:`ProcessSequence.run <firmware_sim.mcu.sequence.ProcessSequence.run>`), in Python.
:class:`SequenceRunner` runs such a loop's sequence exactly as ``ProcessSequence.run`` does — slot
by slot, live (a function that edits the sequence is seen by the later slots), each occupied slot's
cycles spent and written to its PS_DT — but every stretch of slots whose functions are the numeric
reference functions (:data:`~firmware_sim.nav.slot_loop.COMPILED_SLOTS`) in one compiled call
(:func:`~firmware_sim.nav.slot_loop.slots_runner`). READ_INERTIAL (the sensor source), the sequence
control 0x01–0x07 (the sequence, the conditional output, the clock) and CONV16 run as functions, in
their places; a slot whose function the firmware replaced does too. The numeric functions read no
clock and edit no sequence, so a stretch run at once, its cycles then spent slot by slot, leaves
every state, PS_DT and the clock as the functions do (tests/nav/test_any_sequence.py).

The firmware image :data:`~firmware_sim.nav.firmware.OPENSHOE` installs it at boot
(:func:`install`); it runs while the module runs its compiled path (``module.compiled``) and the
compiled slots can be had, else the functions run.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from firmware_sim.mcu.sequence import FunctionTable
from protocol.ids import NR_SLOTS, ProcId, StateId

from . import frontend, ins, slot_loop
from .loop_kinds import finish_alignment

if TYPE_CHECKING:  # pragma: no cover
    from firmware_sim.mcu.module import Module

__all__ = ["SequenceRunner", "install"]

P = ProcId
#: The reference function of each compiled slot (a firmware that replaced one runs its own).
_REFERENCE = {
    P.FRONTEND_PREPROC: frontend.frontend_preproc,
    P.FRONTEND_STATDET: frontend.frontend_statdet,
    P.FRONTEND_BIASEST: frontend.frontend_biasest,
    P.FRONTEND_CONVCOMP: frontend.frontend_convcomp,
    P.FRONTEND_INITIAL_ALIGNMENT: ins.frontend_initial_alignment,
    P.MECHANIZATION: ins.ins_mechanization,
    P.TIME_UPDATE: ins.ins_time_update,
    P.ZUPT_UPDATE: ins.ins_zupt_update,
    P.STEPWISE_SYSTEM_RESET: ins.ins_stepwise_system_reset,
    P.HEIGHT_COMPENSATION: ins.ins_height_compensation,
}
assert set(_REFERENCE) == slot_loop.COMPILED_SLOTS


def _compiled_costs(functions: FunctionTable, slot_call: int) -> dict[int, int]:
    """The cycles of each slot the compiled call runs in a module with *functions*: the ids whose
    function is the reference."""
    return {int(pid): pf.cycles + slot_call for pid, ref in _REFERENCE.items()
            if (pf := functions.get(pid)) is not None and pf.fn is ref}


class SequenceRunner:
    """The process sequence of one module's loops, its numeric stretches compiled (the module doc).

    Called as ``runner(module)`` in place of ``ProcessSequence.run``: True when it ran the loop's
    sequence, False when the functions must (the module runs its pure path, or there is no compiled
    runner in this process)."""

    def __init__(self) -> None:
        self._records: tuple[Any, ...] | None = None
        self._work: Any = None
        self._quaternion: Any = None
        self._costs: dict[int, int] = {}
        self._ids = np.zeros(NR_SLOTS, dtype=np.int64)
        self.loops = 0  #: loops whose sequence ran here (for the benchmark)

    def _bind(self, module: Module) -> tuple[Any, ...]:
        """The module's records as the compiled call takes them (made on first use, as the functions
        make them)."""
        work = self._work = ins.ins_work(module)
        self._quaternion = module.memory[StateId.QUATERNION]
        self._costs = _compiled_costs(module.sequence.functions, module.costs.slot_call)
        records = (module.memory.arena, frontend.frontend_work(module).record, work.record,
                   ins.height_work(module).record)
        self._records = tuple(r.view(np.ndarray).view(np.uint8) for r in records)
        return self._records

    def __call__(self, module: Module) -> bool:
        if not module.compiled:
            return False
        run = slot_loop.slots_runner()
        if run is None:
            return False
        records = self._records or self._bind(module)
        seq = module.sequence
        seq.runs += 1
        self.loops += 1
        slots = seq.slots  # the live list: edits by a function are seen by later slots
        clock = module.clock
        ps_dt = module.memory.ps_dt
        costs = self._costs
        ids = self._ids
        j = 0
        while j < NR_SLOTS:
            pid = slots[j]
            if not pid:
                j += 1
                continue
            if pid in costs:
                stop = j + 1
                while stop < NR_SLOTS and (not slots[stop] or slots[stop] in costs):
                    stop += 1
                for i in range(j, stop):
                    ids[i] = slots[i]
                end = run(ids, j, stop, *records)
                finish_alignment(self._work, self._quaternion)
                for i in range(j, end):
                    cost = costs.get(slots[i])
                    if cost is not None:
                        clock.now_cycles += cost
                        ps_dt[i] = cost
                j = end
                continue
            seq.call_slot(module, j)
            j += 1
        return True


def install(module: Module) -> None:
    """Boot hook of the navigation firmware: *module*'s sequence runs through a :class:`SequenceRunner`."""
    module.sequence.fast = SequenceRunner()
