"""Virtual time of the µC: the 64 MHz cycle counter, the timer ticks and overruns.

The real module runs one main loop per timer interrupt (1 kHz by default,
firmware.md §1). Here time is virtual: every loop advances the cycle counter
by the *modelled* cost of what it did (:class:`CostModel`), so GP_DT and the
PS_DT states are deterministic and meaningful, whatever the host machine's speed.

Timing rules (documented choices where the spec is silent):

* At boot the cycle counter is 0 (or ``start_cycles``, which lets tests reach
  the 2^32 wrap quickly) and the timer starts; timer interrupt *k* (k = 1, 2, …)
  fires ``k · cycles_per_tick`` cycles after boot, so the first main loop
  starts one tick after boot.
* Waiting for the tick: if the previous loop ended before the next interrupt,
  the counter jumps to the interrupt. If it ended later (an **overrun**), the
  next loop starts at once; every interrupt that fired meanwhile increments the
  interrupt counter, but only one loop runs (one flag): the extra ones are
  counted in :attr:`Clock.missed_ticks`, not queued.
* :attr:`Clock.now_cycles` is unbounded; the µC's COUNT register is its low
  32 bits (:attr:`Clock.count`), which wraps every ~67 s like the real one.
"""

from __future__ import annotations

from dataclasses import dataclass

from protocol.states import TIMESTAMP_HZ

#: CPU clock of the AT32UC3C2512 [Hz] (the timestamps' rate, declared with the states).
CPU_HZ = TIMESTAMP_HZ
#: Default main-loop (timer) rate [Hz].
DEFAULT_RATE_HZ = 1000.0
_U32 = 0xFFFFFFFF


@dataclass(frozen=True)
class CostModel:
    """Modelled CPU cycles of the loop's fixed parts (the functions' own costs are
    in the processing-function registry, :mod:`firmware_sim.mcu.sequence`).

    The numbers are estimates for a 64 MHz AVR32 (a few cycles per byte copied,
    a few hundred per call into a driver); they are a model, not a measurement,
    and are all configurable through :class:`~firmware_sim.mcu.module.ModuleConfig`.
    """

    #: Wake-up from the timer flag plus end_of_main_loop bookkeeping.
    loop_overhead: int = 150
    #: receive_command(): polling one interface (connected or not).
    rx_poll: int = 40
    #: Per byte taken from a receive ring and run through the parser.
    rx_per_byte: int = 25
    #: Executing one command (lookup, argument split), on top of its bytes.
    command_exec: int = 300
    #: Calling one occupied process-sequence slot (pointer call + PS_DT write).
    slot_call: int = 20
    #: transmit_data(): one connected interface's assembly scan of the output tables.
    tx_scan: int = 400
    #: Per byte copied into a packet (states + header + checksum).
    tx_per_byte: int = 6
    #: Per byte handed to a link's transmit ring.
    tx_write_per_byte: int = 4


class Clock:
    """The µC's time base: cycle counter, timer interrupts, main-loop accounting."""

    def __init__(self, rate_hz: float = DEFAULT_RATE_HZ, cpu_hz: int = CPU_HZ, start_cycles: int = 0):
        period = cpu_hz / rate_hz
        if rate_hz <= 0 or period != int(period) or period < 1:
            raise ValueError(
                f"loop rate {rate_hz} Hz must divide the {cpu_hz} Hz CPU clock into whole cycles"
            )
        self.cpu_hz = cpu_hz
        self.rate_hz = float(rate_hz)
        #: Cycles between two timer interrupts (64 000 at 1 kHz).
        self.cycles_per_tick = int(period)
        #: Unbounded virtual cycle count since boot.
        self.now_cycles = start_cycles
        #: Main loops run so far (the current loop's number is ``ticks - 1``).
        self.ticks = 0
        #: Timer interrupts since boot (≥ ticks: includes those missed in overruns).
        self.interrupts = 0
        #: Loops that started late because the previous one took longer than a tick.
        self.overruns = 0
        #: Timer interrupts that fired during an overrun and got no loop of their own.
        self.missed_ticks = 0
        #: Cycles the last complete loop took (the GP_DT state).
        self.last_loop_cycles = 0
        self._next_interrupt = start_cycles + self.cycles_per_tick
        #: Cycle at which the current loop started (when the timer flag was seen).
        self.loop_start = start_cycles

    @property
    def count(self) -> int:
        """The 32-bit COUNT register (wraps modulo 2^32)."""
        return self.now_cycles & _U32

    @property
    def time_s(self) -> float:
        """Virtual seconds since boot."""
        return self.now_cycles / self.cpu_hz

    @property
    def sample_index(self) -> int:
        """Number of the current main loop (0 for the first), the sensor sample index."""
        return self.ticks - 1

    def wait_for_tick(self) -> None:
        """Block (in virtual time) until the timer flag is set, then start a loop."""
        nxt = self._next_interrupt
        now = self.now_cycles
        if now <= nxt:
            self.now_cycles = nxt
            self.interrupts += 1
            self._next_interrupt = nxt + self.cycles_per_tick
        else:
            period = self.cycles_per_tick
            fired = (now - nxt) // period + 1
            self.interrupts += fired
            self.missed_ticks += fired - 1
            self.overruns += 1
            self._next_interrupt = nxt + fired * period
        self.loop_start = self.now_cycles
        self.ticks += 1

    def spend(self, cycles: int) -> None:
        """Advance virtual time by *cycles* of modelled work."""
        self.now_cycles += cycles

    def end_loop(self) -> int:
        """Close the current loop; returns its duration in cycles (GP_DT)."""
        self.last_loop_cycles = self.now_cycles - self.loop_start
        return self.last_loop_cycles

    def cycles_until_next_tick(self) -> int:
        """Cycles from now to the next timer interrupt (≤ 0 when already overdue)."""
        return self._next_interrupt - self.now_cycles

    def __repr__(self) -> str:
        return (
            f"Clock({self.rate_hz:g} Hz, cycle {self.now_cycles} (COUNT 0x{self.count:08X}), "
            f"{self.ticks} loops, {self.interrupts} interrupts, {self.overruns} overruns)"
        )

    def loops_on_time(self, loops: int, busy_cycles: int) -> int:
        """Account for *loops* main loops at once, each woken on its own timer tick and busy
        *busy_cycles* (at most one tick, so none overruns): the counters as that many rounds of
        :meth:`wait_for_tick`, :meth:`spend` and :meth:`end_loop` leave them, with the last loop
        current and ``now_cycles`` at its end. Returns the cycle at which the last loop woke.

        For a runner that executes whole loops outside the module's step; the clock must not be
        past its next tick (``cycles_until_next_tick() >= 0``).
        """
        late = self.now_cycles > self._next_interrupt
        if loops < 1 or not 0 <= busy_cycles <= self.cycles_per_tick or late:
            raise ValueError(f"cannot run {loops} loops of {busy_cycles} cycles on time from {self!r}")
        last = self._next_interrupt + (loops - 1) * self.cycles_per_tick
        self.ticks += loops
        self.interrupts += loops
        self._next_interrupt = last + self.cycles_per_tick
        self.loop_start = last
        self.now_cycles = last + busy_cycles
        self.last_loop_cycles = busy_cycles
        return last
