"""The process sequence: 12 slots of processing functions, a 12-slot storage,
and the registry of processing functions by id (firmware.md §2).

A processing function is ``fn(module) -> None`` registered with
``@processing_function(ProcId.X, cycles=N)``; *N* is its modelled cost in CPU
cycles, written to its slot's PS_DT state when it runs and used to check
whether a sequence fits a tick (:func:`sequence_budget`).

Slots hold ids; 0 is an empty slot. As on the µC, whose slots hold function
pointers looked up from the id, writing an id that has no registered function
empties the slot (:meth:`ProcessSequence.set_slot`).

**A function that edits the sequence it runs in.** The real loop indexes the
live slot array (``for i in 0..11: if (slot[i]) slot[i]();``), so after a
function replaces the sequence, the loop continues with the *next slot index*
of the *new* sequence in the same cycle; earlier slots of the new sequence run
from the next cycle on. :meth:`ProcessSequence.run` does exactly that. (In the
step-wise mode RESTORE_PROC_SEQU_IF sits in the last slot, so the restored
tracking sequence starts with the next loop.) PS_DT of an empty slot is left
unchanged.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from protocol.ids import NR_SLOTS, ProcId

if TYPE_CHECKING:  # pragma: no cover
    from .module import Module

ProcessingFn = Callable[["Module"], None]


@dataclass(frozen=True)
class ProcessingFunction:
    """One registered processing function: id, callable and modelled cycle cost."""

    proc_id: int
    fn: ProcessingFn
    cycles: int
    name: str

    def __repr__(self) -> str:
        return f"ProcessingFunction(0x{self.proc_id:02X} {self.name}, {self.cycles} cycles)"


#: Every registered processing function by id (filled by the function modules
#: on import; :mod:`firmware_sim.functions` imports them all).
PROCESSING_FUNCTIONS: dict[int, ProcessingFunction] = {}


def processing_function(proc_id: int, *, cycles: int) -> Callable[[ProcessingFn], ProcessingFn]:
    """Register ``fn(module)`` as processing function *proc_id* costing *cycles* CPU cycles."""
    if not 0 < proc_id < 0x30:
        raise ValueError(f"processing-function id 0x{proc_id:02X} must be in 0x01..0x2F")
    if cycles < 0:
        raise ValueError("cycles must be >= 0")

    def register(fn: ProcessingFn) -> ProcessingFn:
        try:
            name = ProcId(proc_id).name
        except ValueError:
            name = fn.__name__
        old = PROCESSING_FUNCTIONS.get(proc_id)
        if old is not None and old.fn is not fn and getattr(old.fn, "__qualname__", None) != fn.__qualname__:
            raise ValueError(f"processing function 0x{proc_id:02X} is already registered as {old.fn!r}")
        PROCESSING_FUNCTIONS[proc_id] = ProcessingFunction(proc_id, fn, int(cycles), name)
        return fn

    return register


#: Power-on hooks ``fn(module)``, run once by every new Module after its memory
#: exists (e.g. a function module writing default thresholds), in registration order.
BOOT_HOOKS: list[ProcessingFn] = []


def on_boot(fn: ProcessingFn) -> ProcessingFn:
    """Register ``fn(module)`` to run when a module boots (before ModuleConfig.initial_states)."""
    if fn not in BOOT_HOOKS:
        BOOT_HOOKS.append(fn)
    return fn


def is_registered(proc_id: int) -> bool:
    return proc_id in PROCESSING_FUNCTIONS


class ProcessSequence:
    """The 12 running slots and the 12-slot storage of one module."""

    __slots__ = ("slots", "storage", "runs")

    def __init__(self) -> None:
        #: Running slots (ids, 0 = empty). Edit through the methods below.
        self.slots: list[int] = [0] * NR_SLOTS
        #: Stored sequence (STORE_AND_EMPTY / RESTORE).
        self.storage: list[int] = [0] * NR_SLOTS
        #: Times :meth:`run` was called.
        self.runs = 0

    # ------------------------------------------------------------------ edits
    def set_slot(self, slot: int, proc_id: int) -> None:
        """Put *proc_id* in *slot*; an id with no registered function empties the slot."""
        if not 0 <= slot < NR_SLOTS:
            raise IndexError(f"slot {slot} out of range 0..{NR_SLOTS - 1}")
        self.slots[slot] = proc_id if proc_id in PROCESSING_FUNCTIONS else 0

    def set_slots(self, proc_ids: Iterable[int], start: int = 0) -> None:
        for k, pid in enumerate(proc_ids):
            self.set_slot(start + k, pid)

    def empty(self) -> None:
        """EMPTY_PROCESS_SEQUENCE / ALL_PROC_OFF."""
        self.slots[:] = [0] * NR_SLOTS

    def store_and_empty(self) -> None:
        """Copy the running slots to the storage and empty them."""
        self.storage[:] = self.slots
        self.slots[:] = [0] * NR_SLOTS

    def restore(self) -> None:
        """Copy the storage back into the running slots (the storage is kept)."""
        self.slots[:] = self.storage

    def set_storage(self, proc_ids: Iterable[int]) -> None:
        """Replace the stored sequence (slots in order; unregistered ids become empty)."""
        ids = list(proc_ids)
        if len(ids) > NR_SLOTS:
            raise ValueError(f"at most {NR_SLOTS} slots, got {len(ids)}")
        ids += [0] * (NR_SLOTS - len(ids))
        self.storage[:] = [p if p in PROCESSING_FUNCTIONS else 0 for p in ids]

    # -------------------------------------------------------------------- run
    def run(self, module: Module) -> None:
        """run_process_sequence(): call every occupied slot in order, live (see module doc)."""
        self.runs += 1
        slots = self.slots  # the live list: edits by a function are seen by later slots
        funcs = PROCESSING_FUNCTIONS
        clock = module.clock
        ps_dt = module.memory.ps_dt
        call = module.costs.slot_call
        for j in range(NR_SLOTS):
            pid = slots[j]
            if pid:
                pf = funcs.get(pid)
                if pf is None:  # unregistered since it was written: an empty slot
                    slots[j] = 0
                    continue
                pf.fn(module)
                cost = pf.cycles + call
                clock.now_cycles += cost
                ps_dt[j] = cost

    def __repr__(self) -> str:
        def fmt(ids: list[int]) -> str:
            return " ".join(f"{p:02X}" if p else "--" for p in ids)

        return f"ProcessSequence([{fmt(self.slots)}], stored [{fmt(self.storage)}])"


def sequence_budget(proc_ids: Iterable[int], slot_call: int = 20) -> int:
    """Modelled cycles a sequence of ids takes (unregistered ids count as empty slots).

    Compare with :attr:`~firmware_sim.clock.Clock.cycles_per_tick` (64 000 at 1 kHz)
    to see whether it fits one tick, together with the loop's own costs.
    """
    total = 0
    for pid in proc_ids:
        pf = PROCESSING_FUNCTIONS.get(pid)
        if pf is not None:
            total += pf.cycles + slot_call
    return total


def cost_table() -> list[tuple[int, str, int]]:
    """(id, name, cycles) of every registered function, by id: the documented cost model."""
    return [(p.proc_id, p.name, p.cycles) for p in sorted(PROCESSING_FUNCTIONS.values(),
                                                         key=lambda p: p.proc_id)]
