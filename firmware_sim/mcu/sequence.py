"""The process sequence: 12 slots of processing functions, a 12-slot storage,
and the table of processing functions by id (firmware.md §2).

A processing function is ``fn(module) -> None`` declared with
``@processing_function(ProcId.X, cycles=N)``; *N* is its modelled cost in CPU
cycles, written to its slot's PS_DT state when it runs and used to check
whether a sequence fits a tick (:meth:`FunctionTable.budget`). A firmware build
is a :class:`FunctionTable` of such functions, built explicitly and handed to
the module (:class:`~firmware_sim.mcu.firmware.Firmware`): the runtime knows no
function it was not given.

Slots hold ids; 0 is an empty slot. As on the µC, whose slots hold function
pointers looked up from the id, writing an id that has no function in the
table empties the slot (:meth:`ProcessSequence.set_slot`).

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

from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

from protocol.ids import NR_SLOTS, ProcId

if TYPE_CHECKING:  # pragma: no cover
    from .clock import Clock, CostModel
    from .memory import StateMemory

#: ``fn(module)``: a processing function gets the whole module (as :class:`firmware_sim.mcu.context.Mcu`
#: describes it; typed loosely here, where the sequence only passes it on).
ProcessingFn = Callable[[Any], None]


class SequenceOwner(Protocol):
    """What running the sequence needs of the module (it is passed on to the functions whole)."""

    clock: Clock
    memory: StateMemory
    costs: CostModel


@dataclass(frozen=True)
class ProcessingFunction:
    """One processing function: id, callable and modelled cycle cost."""

    proc_id: int
    fn: ProcessingFn
    cycles: int
    name: str

    def __repr__(self) -> str:
        return f"ProcessingFunction(0x{self.proc_id:02X} {self.name}, {self.cycles} cycles)"


def processing_function(proc_id: int, *, cycles: int) -> Callable[[ProcessingFn], ProcessingFn]:
    """Declare ``fn(module)`` as processing function *proc_id* costing *cycles* CPU cycles.

    Only a declaration (the record goes to ``fn.processing_function``): a
    :class:`FunctionTable` built from the functions is what a module runs.
    """
    if not 0 < proc_id < 0x30:
        raise ValueError(f"processing-function id 0x{proc_id:02X} must be in 0x01..0x2F")
    if cycles < 0:
        raise ValueError("cycles must be >= 0")

    def declare(fn: ProcessingFn) -> ProcessingFn:
        try:
            name = ProcId(proc_id).name
        except ValueError:
            name = fn.__name__
        fn.processing_function = ProcessingFunction(proc_id, fn, int(cycles), name)  # type: ignore[attr-defined]
        return fn

    return declare


class FunctionTable(Mapping[int, ProcessingFunction]):
    """The processing functions of one firmware build, by id (the µC's table of function
    pointers). Immutable; :meth:`with_functions` makes an extended copy."""

    def __init__(self, functions: Iterable[ProcessingFunction] = ()):
        table: dict[int, ProcessingFunction] = {}
        for pf in functions:
            if pf.proc_id in table and table[pf.proc_id].fn is not pf.fn:
                raise ValueError(f"processing function 0x{pf.proc_id:02X} is declared twice: "
                                 f"{table[pf.proc_id].fn!r} and {pf.fn!r}")
            table[pf.proc_id] = pf
        self._table = table

    @classmethod
    def of(cls, *fns: ProcessingFn) -> FunctionTable:
        """A table of functions declared with :func:`processing_function`."""
        return cls(_declared(fn) for fn in fns)

    def with_functions(self, *fns: ProcessingFn) -> FunctionTable:
        """A copy with *fns* added; a declared id replaces the table's function of that id."""
        added = {pf.proc_id: pf for pf in (_declared(fn) for fn in fns)}
        return FunctionTable([*(pf for pid, pf in self._table.items() if pid not in added), *added.values()])

    def __getitem__(self, proc_id: int) -> ProcessingFunction:
        return self._table[proc_id]

    def __iter__(self) -> Iterator[int]:
        return iter(self._table)

    def __len__(self) -> int:
        return len(self._table)

    def budget(self, proc_ids: Iterable[int], slot_call: int = 20) -> int:
        """Modelled cycles a sequence of ids takes (ids not in the table count as empty slots).

        Compare with :attr:`~firmware_sim.mcu.clock.Clock.cycles_per_tick` (64 000 at 1 kHz)
        to see whether it fits one tick, together with the loop's own costs.
        """
        return sum(self._table[p].cycles + slot_call for p in proc_ids if p in self._table)

    def cost_table(self) -> list[tuple[int, str, int]]:
        """(id, name, cycles) of every function, by id: the documented cost model."""
        return [(p.proc_id, p.name, p.cycles) for p in sorted(self._table.values(), key=lambda p: p.proc_id)]

    def __repr__(self) -> str:
        return f"FunctionTable({', '.join(f'0x{p:02X}' for p in sorted(self._table))})"


def _declared(fn: ProcessingFn) -> ProcessingFunction:
    pf = getattr(fn, "processing_function", None)
    if not isinstance(pf, ProcessingFunction):
        raise TypeError(f"{fn!r} is not declared with @processing_function")
    return pf


class ProcessSequence:
    """The 12 running slots and the 12-slot storage of one module."""

    __slots__ = ("slots", "storage", "runs", "functions", "fast")

    def __init__(self, functions: FunctionTable) -> None:
        #: The firmware's processing functions: ids not in it cannot occupy a slot.
        self.functions = functions
        #: Running slots (ids, 0 = empty). Edit through the methods below.
        self.slots: list[int] = [0] * NR_SLOTS
        #: Stored sequence (STORE_AND_EMPTY / RESTORE).
        self.storage: list[int] = [0] * NR_SLOTS
        #: Times :meth:`run` was called.
        self.runs = 0
        #: A faster run of the sequence with the same states, clock and bytes, installed by the
        #: firmware (``fast(module)``: whether it ran this loop's sequence; when False, or None, the
        #: functions run one by one here), e.g. the navigation's compiled slots
        #: (:mod:`firmware_sim.nav.any_sequence`).
        self.fast: Callable[[Any], bool] | None = None

    # ------------------------------------------------------------------ edits
    def set_slot(self, slot: int, proc_id: int) -> None:
        """Put *proc_id* in *slot*; an id with no registered function empties the slot."""
        if not 0 <= slot < NR_SLOTS:
            raise IndexError(f"slot {slot} out of range 0..{NR_SLOTS - 1}")
        self.slots[slot] = proc_id if proc_id in self.functions else 0

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
        self.storage[:] = [p if p in self.functions else 0 for p in ids]

    # -------------------------------------------------------------------- run
    def run(self, module: SequenceOwner) -> None:
        """run_process_sequence(): call every occupied slot in order, live (see module doc)."""
        fast = self.fast
        if fast is not None and fast(module):
            return
        self.runs += 1
        slots = self.slots  # the live list: edits by a function are seen by later slots
        for j in range(NR_SLOTS):
            if slots[j]:
                self.call_slot(module, j)

    def call_slot(self, module: SequenceOwner, j: int) -> None:
        """Slot *j*'s function (occupied), its cycles spent and written to PS_DT*j*; a slot whose id
        this firmware has no function for is emptied instead."""
        pf = self.functions.get(self.slots[j])
        if pf is None:  # not in this firmware: an empty slot
            self.slots[j] = 0
            return
        pf.fn(module)
        cost = pf.cycles + module.costs.slot_call
        module.clock.now_cycles += cost
        module.memory.ps_dt[j] = cost

    def __repr__(self) -> str:
        def fmt(ids: list[int]) -> str:
            return " ".join(f"{p:02X}" if p else "--" for p in ids)

        return f"ProcessSequence([{fmt(self.slots)}], stored [{fmt(self.storage)}])"
