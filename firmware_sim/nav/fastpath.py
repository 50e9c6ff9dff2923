"""The compiled path of the INS sequences: the same bytes and states as the processing functions, faster.

The processing functions (:mod:`~firmware_sim.nav.inertial`, :mod:`~firmware_sim.nav.frontend`,
:mod:`~firmware_sim.nav.ins`, :mod:`~firmware_sim.mcu.sequence_control`) are the reference. When
a module runs one of the sequences the compiled path knows, with those functions registered —
the alignment of both INS modes, the tracking of step-wise dead reckoning (0x34) with or without
HEIGHT_COMPENSATION in slot 10, the full-rate ZUPT-aided INS (0x33) — its numeric slots run as
compiled kernels (:mod:`~firmware_sim.nav.driver`), operation for operation as the reference:
the wire bytes and every state are identical (tests/nav/test_fastpath.py, test_kernels.py and
tests/e2e/test_wire_golden.py check it).

:class:`FastNav` binds that to one module:

* :meth:`FastNav.sequence_tick` — the process sequence of one loop: READ_INERTIAL and the slots
  that act on the module (STATE_OUTPUT_IF, RESTORE_PROC_SEQU_IF) in Python, the numeric slots
  compiled (a HEIGHT_COMPENSATION after STATE_OUTPUT_IF runs after it in the loop in which a
  step ends, as in the slots' order; in the other loops the step output does nothing, and the
  driver runs it compiled).
* :meth:`FastNav.run_quiet` — whole loops while nothing but the sequence happens (nothing
  received, no output due, a waiting packet not due for a resend, no byte in flight reaching
  the µC or the host; :meth:`FastNav.quiet_ticks`), up to the loop in which a step ends or the
  alignment completes, reading the sensor block directly; the clock, interrupt counter, GP_DT
  and PS_DT advance exactly as loop by loop.

Selection: the loop built ahead of time there (:mod:`~firmware_sim.nav.aot`: no numba imported at
all) or numba importable, and ``OPENSHOE_PURE`` not 1 (:func:`available`); ``ModuleConfig.compiled``
forces either path. numba is the optional ``fast`` extra; without it (and without a built loop)
everything runs in pure Python, unchanged.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from firmware_sim import numba_use
from firmware_sim.mcu import sequence_control as utility
from firmware_sim.mcu.imu_bus import imu_block
from protocol.ids import (
    IMU_MAG_BASE,
    IMU_RAW_BASE,
    IMU_TEMP_BASE,
    NR_IMUS,
    NR_SLOTS,
    PS_DT_BASE,
    ProcId,
    StateId,
)

from . import aot, frontend, inertial, ins
from .loop_kinds import (
    ALIGNMENT,
    FULL_RATE_INS,
    HEIGHT_AFTER_OUTPUT,
    NO_SAMPLES,
    TRACKING,
    TRACKING_HEIGHT,
    finish_alignment,
)

if TYPE_CHECKING:  # pragma: no cover
    from firmware_sim.mcu.module import Module

__all__ = ["ALIGNMENT_SLOTS", "COMPILED_PATH", "FULL_RATE_INS_SLOTS", "TRACKING_HEIGHT_SLOTS",
           "TRACKING_SLOTS", "FastNav", "QuietRun", "ahead_of_time", "available", "disable", "group_loop",
           "group_releases_gil", "numba_version", "pure_requested", "reason_unavailable"]

P = ProcId
_FRONT_END = (P.READ_INERTIAL, P.FRONTEND_PREPROC, P.FRONTEND_STATDET, P.FRONTEND_BIASEST,
              P.FRONTEND_CONVCOMP)
#: The running slots of step-wise dead reckoning after the initial alignment.
TRACKING_SLOTS = [int(p) for p in _FRONT_END + (P.STEPWISE_SYSTEM_RESET, P.MECHANIZATION, P.TIME_UPDATE,
                                                 P.ZUPT_UPDATE, P.STATE_OUTPUT_IF)] + [0] * 2
#: The tracking slots with HEIGHT_COMPENSATION in slot 10, after STATE_OUTPUT_IF (a host's
#: RUN_PROC(0x25, 10) once tracking runs: protocol.extensions.height_compensation_on).
TRACKING_HEIGHT_SLOTS = TRACKING_SLOTS[:10] + [int(P.HEIGHT_COMPENSATION), 0]
#: The running slots of the full-rate ZUPT-aided INS after the initial alignment.
FULL_RATE_INS_SLOTS = [int(p) for p in _FRONT_END + (P.MECHANIZATION, P.TIME_UPDATE, P.ZUPT_UPDATE)] + [0] * 4
#: The running slots of both INS modes until the initial alignment is done.
ALIGNMENT_SLOTS = [int(p) for p in _FRONT_END + (P.FRONTEND_INITIAL_ALIGNMENT,)] + [0] * 5 + [
    int(P.RESTORE_PROC_SEQU_IF)]
#: The reference functions the compiled loop stands for (a re-registered id turns it off).
_REFERENCE = {
    P.READ_INERTIAL: inertial.read_inertial,
    P.FRONTEND_PREPROC: frontend.frontend_preproc,
    P.FRONTEND_STATDET: frontend.frontend_statdet,
    P.FRONTEND_BIASEST: frontend.frontend_biasest,
    P.FRONTEND_CONVCOMP: frontend.frontend_convcomp,
    P.STEPWISE_SYSTEM_RESET: ins.ins_stepwise_system_reset,
    P.MECHANIZATION: ins.ins_mechanization,
    P.TIME_UPDATE: ins.ins_time_update,
    P.ZUPT_UPDATE: ins.ins_zupt_update,
    P.HEIGHT_COMPENSATION: ins.ins_height_compensation,
    P.STATE_OUTPUT_IF: utility.state_output_if,
    P.FRONTEND_INITIAL_ALIGNMENT: ins.frontend_initial_alignment,
    P.RESTORE_PROC_SEQU_IF: utility.restore_proc_sequ_if,
}
#: States the compiled loops write (a conditional output watching one of them ends a quiet run).
_WRITTEN = frozenset(
    {StateId.IMU_TS, StateId.U_NEW, StateId.U_K, StateId.U_INT_K, StateId.T_INT_K, StateId.DT, StateId.T1S2F,
     StateId.T2S2F, StateId.ZUPT, StateId.ZARU, StateId.POSITION, StateId.VELOCITY, StateId.QUATERNION,
     StateId.P, StateId.INIT_DONE, StateId.DX, StateId.DP, StateId.STEP_COUNTER, StateId.FILTER_RESET_FLAG,
     StateId.SWING_TIME, StateId.THETA_INIT, StateId.THETA_GROUND, StateId.INTERRUPT_COUNTER, StateId.GP_DT}
    | {base + i for base in (IMU_RAW_BASE, IMU_TEMP_BASE, IMU_MAG_BASE) for i in range(NR_IMUS)}
    | set(range(PS_DT_BASE, PS_DT_BASE + NR_SLOTS)))
_U32 = 0xFFFFFFFF

#: Per function table (by id, the table kept alive beside): the known sequences whose every slot is
#: the reference function in it (a table is immutable: checked once, not in every loop).
_CHECKED: dict[int, tuple[Any, dict[int, bool]]] = {}


def _references(functions: Any, seq: KnownSequence) -> bool:
    """Whether every occupied slot of *seq* is its reference function in the table *functions*."""
    entry = _CHECKED.get(id(functions))
    if entry is None or entry[0] is not functions:
        entry = _CHECKED[id(functions)] = (functions, {})
    known = entry[1].get(seq.kind)
    if known is None:
        known = entry[1][seq.kind] = all(
            (pf := functions.get(pid)) is not None and pf.fn is _REFERENCE[pid] for pid in seq.slots if pid)
    return known


pure_requested = numba_use.pure_requested
_disabled = ""  #: why the compiled path was switched off in this process ("" = it was not)


def _jit() -> Any:
    from . import jit  # numba, when the loop was not built ahead of time

    return jit


def numba_version() -> str | None:
    return _jit().numba_version()  # type: ignore[no-any-return]


def _loop() -> tuple[Callable[..., int], bool]:
    """The compiled loop — built ahead of time, else numba's — and whether it is compiled (numba's
    loop is plain Python without numba)."""
    built = aot.run_loops()
    if built is not None:
        return built, True
    from .driver import run_loops

    return run_loops, _jit().COMPILING


def group_loop() -> Callable[..., int] | None:
    """The compiled loop of K modules in one call (:func:`~firmware_sim.nav.driver.run_group`), built
    ahead of time or numba's; None when the loop is not compiled (plain Python)."""
    built = aot.run_group()
    if built is not None:
        return built
    if aot.run_loops() is not None or not _jit().COMPILING:
        return None  # a loop built before the group existed, or no numba: module by module
    from .driver import run_group

    return run_group  # type: ignore[no-any-return]


def group_releases_gil() -> bool:
    """Whether a lockstep splits the calls of :func:`group_loop` with a helper thread: numba's loop
    (it releases the GIL), and the one built ahead of time (which releases it too) in a process
    that asked for it (:func:`~firmware_sim.nav.aot.share_cores`: a batch of many replays)."""
    group = group_loop()
    return group is not None and (group is not aot.run_group() or aot.shares_cores())


def ahead_of_time() -> bool:
    """Whether the compiled loop is the one built ahead of time (:mod:`~firmware_sim.nav.aot`)."""
    return aot.run_loops() is not None


def available() -> bool:
    """Whether the compiled path can be used (the loop built ahead of time, or numba importable;
    OPENSHOE_PURE not 1; not disabled)."""
    return not _disabled and not pure_requested() and (ahead_of_time() or _jit().COMPILING)


def reason_unavailable() -> str:
    return "" if available() else (_disabled or _jit().NUMBA_ERROR)


def disable(reason: str) -> None:
    """Stop offering the compiled path in this process (e.g. its compile failed)."""
    global _disabled
    _disabled = reason or "disabled"


@dataclass(frozen=True)
class KnownSequence:
    """A running sequence the compiled path knows: its slots, and what the driver leaves to Python."""

    kind: int  #: driver.TRACKING, TRACKING_HEIGHT, FULL_RATE_INS or ALIGNMENT
    slots: list[int]  #: the 12 running slots
    #: The slots after the numeric ones, which act on the module: run in Python every loop.
    tail: tuple[int, ...]
    #: The flag state true after a loop that ends a quiet run (a step's end, the alignment's).
    ends_with: int | None
    #: Numeric slots after the tail (HEIGHT_COMPENSATION): compiled in the driver's loop, but in
    #: the loop that ends a run, where the tail acts, run after it (driver.HEIGHT_AFTER_OUTPUT).
    after_tail: tuple[int, ...] = ()


SEQUENCES = (
    KnownSequence(TRACKING, TRACKING_SLOTS, (P.STATE_OUTPUT_IF,), StateId.FILTER_RESET_FLAG),
    KnownSequence(TRACKING_HEIGHT, TRACKING_HEIGHT_SLOTS, (P.STATE_OUTPUT_IF,), StateId.FILTER_RESET_FLAG,
                  (P.HEIGHT_COMPENSATION,)),
    KnownSequence(FULL_RATE_INS, FULL_RATE_INS_SLOTS, (), None),
    KnownSequence(ALIGNMENT, ALIGNMENT_SLOTS, (P.RESTORE_PROC_SEQU_IF,), StateId.INIT_DONE),
)


class _Timing:
    """One known sequence's modelled cycles in one module (its function table and cost model)."""

    def __init__(self, seq: KnownSequence, module: Module):
        funcs = module.firmware.functions
        costs = {p: funcs[p].cycles + module.costs.slot_call for p in seq.slots if p}
        self.read = costs[P.READ_INERTIAL]
        self.tail = sum(costs[p] for p in seq.tail)
        #: the numeric slots after the tail
        self.after = sum(costs[p] for p in seq.after_tail)
        self.total = sum(costs.values())
        #: the numeric slots before the tail
        self.numeric = self.total - self.read - self.tail - self.after
        #: PS_DT: the occupied slots and their costs.
        self.ps_slots = np.array([j for j, p in enumerate(seq.slots) if p], dtype=np.intp)
        self.ps_values = np.array([costs[p] for p in seq.slots if p], dtype=np.uint32)


class FastNav:
    """The compiled INS sequences bound to one module's state memory and work records."""

    def __init__(self, module: Module):
        self._ins_work = ins.ins_work(module)
        self._quaternion = module.memory[StateId.QUATERNION]
        records = (module.memory.arena, frontend.frontend_work(module).record, self._ins_work.record,
                   inertial.inertial_work(module).record, ins.height_work(module).record)
        self._run, compiled = _loop()
        self._ahead = self._run is aot.run_loops()
        # the records' bytes (driver.run_loops); in plain Python a recarray, for their fields by name
        as_bytes = (lambda r: r.view(np.ndarray).view(np.uint8)) if compiled else (
            lambda r: r.view(np.ndarray).view(np.uint8).view(np.recarray))
        self._records = tuple(as_bytes(r) for r in records)
        #: The records' addresses, for the loop of K modules (:func:`group_loop`).
        self.addresses = tuple(r.ctypes.data for r in self._records)
        self._sequences = {seq.kind: seq for seq in SEQUENCES}
        self._timings: dict[int, _Timing] = {}
        #: Loops run compiled, loop by loop and in quiet runs (for the benchmark).
        self.ticks_single = 0
        self.ticks_quiet = 0

    def load(self) -> None:
        """Have the compiled loop ready for the arguments this module calls it with — loaded from
        numba's cache, or compiled — without running a loop (:mod:`firmware_sim.nav.warmup`); the
        loop built ahead of time is ready as it is."""
        if not self._ahead:
            _jit().load(self._run, ALIGNMENT, 1, NO_SAMPLES, 0, 0, 0, *self._records)
        group = group_loop()
        if group is not None and group is not aot.run_group():
            one = np.ones(1, dtype=np.int64)
            rows = np.zeros((1, 3), dtype=np.int64), np.zeros((1, 6), dtype=np.int64)
            _jit().load(group, one, one, *rows, one)

    # -------------------------------------------------------------- eligibility
    @staticmethod
    def kind(module: Module) -> int:
        """Which known sequence runs (TRACKING, TRACKING_HEIGHT, FULL_RATE_INS or ALIGNMENT) with the
        reference functions registered, else 0 (the pure-Python sequence runs)."""
        slots = module.sequence.slots
        for seq in SEQUENCES:
            if seq.slots == slots:
                return seq.kind if _references(module.firmware.functions, seq) else 0
        return 0

    def _timing(self, module: Module, kind: int) -> _Timing:
        timing = self._timings.get(kind)
        if timing is None:
            timing = self._timings[kind] = _Timing(self._sequences[kind], module)
        return timing

    @classmethod
    def sequence_matches(cls, module: Module) -> bool:
        """The running slots are the tracking sequence and every id is the reference function."""
        return cls.kind(module) == TRACKING

    # ------------------------------------------------------------ one loop's sequence
    def sequence_tick(self, module: Module, kind: int = TRACKING) -> None:
        """run_process_sequence() of one loop of a known sequence, the numeric slots compiled."""
        seq, timing = self._sequences[kind], self._timing(module, kind)
        module.sequence.runs += 1
        clock = module.clock
        # slot 0 in Python: any sensor source, exhaustion, temperature and magnetometer
        inertial.read_inertial(module)
        clock.spend(timing.read)
        self._run(kind, 1, NO_SAMPLES, 0, 0, 0, *self._records)
        if kind == ALIGNMENT:
            finish_alignment(self._ins_work, self._quaternion)
        clock.spend(timing.numeric)
        for pid in seq.tail:
            _REFERENCE[pid](module)
        clock.spend(timing.tail)
        self._after_tail(module, seq)
        clock.spend(timing.after)
        module.memory.ps_dt[timing.ps_slots] = timing.ps_values
        self.ticks_single += 1

    def _after_tail(self, module: Module, seq: KnownSequence) -> None:
        """The numeric slots after the tail, in a loop that ends a run (a step's end): the driver
        returned before them, so that they run after the tail, as the slots' order has it."""
        if seq.after_tail and seq.ends_with is not None and module.memory.flag(seq.ends_with):
            self._run(HEIGHT_AFTER_OUTPUT, 1, NO_SAMPLES, 0, 0, 0, *self._records)

    # ------------------------------------------------------------------ quiet runs
    def quiet_ticks(self, module: Module, max_ticks: int, kind: int | None = None) -> int:
        """How many of the next loops (at most *max_ticks*) run with nothing but the sequence
        happening (see the module doc); 0 = the next loop is not quiet.

        Nothing may be received, pending or due for output, and a lossless packet waiting for
        its ACK must not be due for a resend. The ports bound the run
        (:meth:`~firmware_sim.mcu.port.IdealPort.quiet_until`): a link model with bytes in flight
        is quiet until the first of them could reach the µC or the host, and a scheduled
        disconnect or reconnect ends the run before it; the loop of such an event then runs
        loop by loop as usual. *kind*: :meth:`kind`, when the caller has it."""
        kind = self.kind(module) if kind is None else kind
        src = module.sensors
        if not kind or module.sensors_exhausted or not (hasattr(src, "imu_block") or hasattr(src, "imu")):
            return 0  # (whether it has a block now, run_quiet asks)
        clock = module.clock
        c = module.costs
        wait = clock.cycles_until_next_tick()
        busy = c.loop_overhead + 2 * c.rx_poll + self._timing(module, kind).total
        if wait < 0 or busy > clock.cycles_per_tick:
            return 0
        n = self._quiet_interfaces(module, max_ticks, clock.now_cycles + wait + c.loop_overhead)
        if n and not self._quiet_sequence(module, kind):
            return 0
        return n

    @staticmethod
    def _quiet_interfaces(module: Module, n: int, first_poll: int) -> int:
        """At most *n*: the loops before an interface has something to do (*first_poll*: the
        cycle at which the first loop advances the ports)."""
        period = module.clock.cycles_per_tick
        for iface in module.interface_list:
            if not iface.is_idle():
                return 0
            port = iface.port
            queue = iface.queue
            if queue.frames and port.connected:
                # a lossless packet waiting for its ACK: every loop counts the resend delay
                # down, and the loop that resends it is not quiet
                if not iface.lossless or queue.frames[0].single or queue.delay_counter == 0:
                    return 0
                n = min(n, queue.resend_cycles - queue.delay_counter)
            quiet_until = getattr(port, "quiet_until", None)
            if quiet_until is None:
                return 0
            until = quiet_until()
            if until is not None:
                # loop i advances its ports at first_poll + i·period: all before `until`
                n = min(n, (until - first_poll - 1) // period + 1)
                if n < 1:
                    return 0
        return n

    @staticmethod
    def _quiet_sequence(module: Module, kind: int) -> bool:
        """Whether the sequence's own Python slots stay silent until the run's end: no conditional
        output that could fire, no restore but the alignment's."""
        memory = module.memory
        if kind in (TRACKING, TRACKING_HEIGHT):
            cond = module.cond_output
            return not (cond.from_mask and cond.flag_id != StateId.FILTER_RESET_FLAG
                        and (cond.flag_id in _WRITTEN or memory.flag(cond.flag_id)))
        if kind == ALIGNMENT:
            return module.restore_if_flag == StateId.INIT_DONE and not memory.flag(StateId.INIT_DONE)
        return True

    def run_quiet(self, module: Module, max_ticks: int, kind: int = TRACKING) -> int:
        """Run up to *max_ticks* quiet loops of a known sequence (*kind*); returns loops run.

        A tracking run stops after a step reset's loop, an alignment run after the loop that
        completes the alignment (the sequence then switches); that loop's Python slots and
        transmit_data() run here. The caller checked :meth:`quiet_ticks` and :meth:`kind`.
        """
        run = self.quiet_run(module, max_ticks, kind)
        if run is None:
            return 0
        return self.finish_quiet(module, run, self.run_loops(run))

    def run_loops(self, run: QuietRun) -> int:
        """The compiled loop of *run* on this module's records (nothing booked); the loops run."""
        return self._run(run.kind, len(run.imu), run.imu, run.first, run.period, run.ts_offset,
                         *self._records)

    def quiet_run(self, module: Module, max_ticks: int, kind: int) -> QuietRun | None:
        """What the compiled loop needs for :meth:`run_quiet`'s loops (None: the source has no register
        block from here; run loop by loop)."""
        clock = module.clock
        start = clock.ticks  # sample index of the first loop
        imu = imu_block(module.sensors, start, max_ticks)
        if imu is None:
            return None
        # the loop takes C-ordered registers (its one signature; the one built ahead of time reads
        # them so): a source's view in another order is copied
        c = module.costs
        first = clock.now_cycles + clock.cycles_until_next_tick()
        return QuietRun(kind, start, np.ascontiguousarray(imu), first, clock.cycles_per_tick,
                        c.loop_overhead + 2 * c.rx_poll)

    def finish_quiet(self, module: Module, run: QuietRun, done: int) -> int:
        """After the compiled loop ran *done* loops of *run*: book them on the module (clock, PS_DT,
        the last sample's temperature and magnetometer, the ports, the ending loop's Python slots);
        returns *done*."""
        kind = run.kind
        seq, timing = self._sequences[kind], self._timing(module, kind)
        if kind == ALIGNMENT:
            finish_alignment(self._ins_work, self._quaternion)
        c = module.costs
        first, period = run.first, run.period
        last = module.account_loops(done, run.ts_offset + timing.total)
        memory = module.memory
        memory.ps_dt[timing.ps_slots] = timing.ps_values
        sample = module.sensors.read(run.start + done - 1)  # temperature, magnetometer of the last read
        if sample is not None:
            memory.imu_temp[:NR_IMUS] = sample.temp
            memory.imu_mag[:NR_IMUS] = sample.mag
        ended = seq.ends_with is not None and memory.flag(seq.ends_with)
        for iface in module.interface_list:
            port = iface.port
            if not port.idle():
                # bytes in flight: the link moves tick by tick, as between loops (same chunks)
                for i in range(done - 1):
                    port.advance(first + i * period + c.loop_overhead)
            port.advance(last + c.loop_overhead)
            # each loop's transmit_data() counted the resend delay (the last loop's runs below
            # when it ends the run)
            iface.count_idle_transmissions(done - 1 if ended else done)
        if ended:
            for pid in seq.tail:
                _REFERENCE[pid](module)
            self._after_tail(module, seq)
            module.finish_loop()
        self.ticks_quiet += done
        return done


class QuietRun(NamedTuple):
    """One module's quiet loops as the compiled loop takes them (:meth:`FastNav.quiet_run`; a named
    tuple: made for every module's frame, in a third of a frozen dataclass's time)."""

    kind: int
    start: int  #: the sample index of the first loop
    imu: np.ndarray  #: the loops' registers, C order (loops × NR_IMUS × 6 int16)
    first: int  #: the cycle at which the first loop wakes
    period: int  #: cycles per tick
    ts_offset: int  #: cycles from a wake-up to READ_INERTIAL's time stamp


class _CompiledPath:
    """The compiled path as the runtime sees it (:class:`firmware_sim.mcu.firmware.CompiledPath`)."""

    @staticmethod
    def available() -> bool:
        return available()

    @staticmethod
    def reason_unavailable() -> str:
        return reason_unavailable()

    @staticmethod
    def kind(module: Module) -> int:
        return FastNav.kind(module)

    @staticmethod
    def runner(module: Module) -> FastNav:
        return FastNav(module)


#: Handed to the runtime by the tracking firmware (:data:`firmware_sim.nav.firmware.OPENSHOE`).
COMPILED_PATH = _CompiledPath()
