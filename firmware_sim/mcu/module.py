"""The emulated OpenShoe module: one µC main loop stepped in virtual time (firmware.md §1).

::

    m = Module()                      # USB and Bluetooth on ideal links, 1 kHz
    m.usb.port.host_write(bytes.fromhex("030003"))   # PING
    m.step()                          # one timer tick
    m.usb.port.host_read()            # b'\\xa0\\x03\\x00\\xa3'

:meth:`Module.step` is one pass of the firmware's loop: wait for the timer
tick (interrupt counter + 1) → receive_command (USB, then Bluetooth) →
run_process_sequence → transmit_data (USB, then Bluetooth) → end_of_main_loop
(GP_DT = cycles since the tick). No threads, no wall clock: the same inputs
give the same bytes. Transports and real-time pacing wrap a module from outside.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, TypeVar

from protocol.commands import CommandSet, CommandSpec, command_set
from protocol.ids import Interface, StateId

from .clock import DEFAULT_RATE_HZ, Clock, CostModel
from .command_handlers import execute
from .conditional_output import ConditionalOutput
from .firmware import RUNTIME_ONLY, CompiledPath, CompiledSequence, Firmware
from .imu_bus import SensorSource, still_board
from .interface import ExternalInterface, TraceEntry
from .memory import DEFAULT_MCU_SERIAL, StateMemory
from .port import IdealPort, Port
from .sequence import ProcessSequence

#: The type of a processing function's private state (:meth:`Module.work`): what its factory makes.
T = TypeVar("T")
_U32 = 0xFFFFFFFF
#: The largest number of a simulated module: its serial number has 8 digits.
MAX_MODULE = 99_999_999


def module_serial(module: int | None) -> bytes:
    """The MCU serial number (state 0x04, 15 bytes) of simulated module *module*:
    ``OSEMU-M`` and the number in 8 digits; None (no identity given): the default serial.

    A host tells modules apart by it (``MCU_ID``), e.g. to refuse one module's drift
    calibration for another (:mod:`hostlib.calibration.drift`)."""
    if module is None:
        return DEFAULT_MCU_SERIAL
    if not 0 <= module <= MAX_MODULE:
        raise ValueError(f"a module number is 0..{MAX_MODULE}, got {module}")
    return b"OSEMU-M" + f"{module:08d}".encode()


@dataclass
class ModuleConfig:
    """Build-time and boot-time settings of one emulated module."""

    #: Main-loop (timer) rate [Hz]; 1000 on the module, e.g. 250 for replays of 250 Hz data.
    rate_hz: float = DEFAULT_RATE_HZ
    #: Command numbering: "2015"/"current" or "2014" (protocol.md §10), or a CommandSet.
    command_set: str | CommandSet = "2015"
    #: The µC's serial number (state 0x04), up to 15 bytes.
    mcu_serial: bytes = DEFAULT_MCU_SERIAL
    #: Modelled cycle costs of the loop's fixed parts.
    costs: CostModel = field(default_factory=CostModel)
    #: Record every frame in and out (``module.trace``).
    trace: bool = False
    #: Cycle counter at boot (0 on the module; set near 2^32 to exercise the COUNT wrap).
    start_cycles: int = 0
    #: Front-end configuration (calibration, detector windows) for firmware_sim.nav.frontend; None = default.
    frontend: Any = None
    #: The INS's noise figures for firmware_sim.nav (nav.config.InsNoise): a recording of another
    #: sensor brings its own (nav.profiles); None = the module's own (firmware.md §4).
    ins: Any = None
    #: Initial states written at boot, id → value (e.g. thresholds {0x19: 300000}).
    initial_states: dict[int, Any] = field(default_factory=dict)
    #: Run the firmware's compiled path (Firmware.compiled_path; numba for navigation): None = when
    #: numba is importable and OPENSHOE_PURE is not 1; False = pure Python (the reference);
    #: True = compiled (ImportError without numba). The bytes are the same either way.
    compiled: bool | None = None


def _want_compiled(setting: bool | None, path: CompiledPath | None) -> bool:
    """Whether a module runs its firmware's compiled path (ModuleConfig.compiled)."""
    if setting is False or path is None:
        if setting and path is None:
            raise ImportError("compiled path requested but this firmware has none")
        return False
    if setting and not path.available():
        raise ImportError(f"compiled path requested but unavailable: {path.reason_unavailable()} "
                          "(pip install 'openshoe-emulator[fast]')")
    return path.available()


class Module:
    """One emulated OpenShoe module (µC, firmware, sensors, two external interfaces)."""

    def __init__(self, config: ModuleConfig | None = None, sensors: SensorSource | None = None,
                 usb_port: Port | None = None, bt_port: Port | None = None, *,
                 firmware: Firmware = RUNTIME_ONLY):
        self.config = config = config if config is not None else ModuleConfig()
        #: What this module runs: its processing functions, boot hooks and compiled path.
        self.firmware = firmware
        self.costs = config.costs
        self.clock = Clock(config.rate_hz, start_cycles=config.start_cycles)
        self.memory = StateMemory(config.mcu_serial)
        self.sequence = ProcessSequence(firmware.functions)
        self.sensors: SensorSource = sensors if sensors is not None else still_board(config.rate_hz)
        self.command_set = command_set(config.command_set)
        #: Every frame in and out (TraceEntry) when ModuleConfig.trace is set; any object
        #: with ``append(entry)`` may be assigned instead (a hook), None switches tracing off.
        self.trace: list[TraceEntry] | None = [] if config.trace else None
        #: The conditional output (STATE_IF_SETUP, SETUP_DEBUG_PROC, mode commands).
        self.cond_output = ConditionalOutput()
        #: Flag state RESTORE_PROC_SEQU_IF watches (set by 0x36 and the INS mode commands).
        self.restore_if_flag = 0
        #: Set by READ_INERTIAL when a finite sensor source ran out.
        self.sensors_exhausted = False
        #: Last DLPF_CFG set by SET_IMU_BANDWIDTH.
        self.dlpf_cfg = 0
        self._work: dict[str, Any] = {}
        self.usb = ExternalInterface(self, Interface.USB, usb_port or IdealPort(), self.command_set)
        self.bt = ExternalInterface(self, Interface.BLUETOOTH, bt_port or IdealPort(), self.command_set)
        #: Interfaces by kind; ``interface_list`` in the order the loop serves them.
        self.interfaces = {Interface.USB: self.usb, Interface.BLUETOOTH: self.bt}
        self.interface_list = (self.usb, self.bt)
        self._compiled_path = firmware.compiled_path
        self._compiled = _want_compiled(config.compiled, self._compiled_path)
        self._fast: CompiledSequence | None = None
        self._interrupt_counter = self.memory[StateId.INTERRUPT_COUNTER]
        self._gp_dt = self.memory[StateId.GP_DT]
        for hook in firmware.boot_hooks:
            hook(self)
        for sid, value in config.initial_states.items():
            self.memory[sid][...] = value

    # ------------------------------------------------------------------ loop
    def step(self) -> None:
        """One timer tick: one pass of the main loop."""
        clock = self.clock
        clock.wait_for_tick()
        self._interrupt_counter[...] = clock.interrupts & _U32
        clock.now_cycles += self.costs.loop_overhead
        usb, bt = self.interface_list
        now = clock.now_cycles
        usb.port.advance(now)
        bt.port.advance(now)
        usb.receive()
        bt.receive()
        kind = self._compiled and self._compiled_path.kind(self)
        if kind:
            self._fastnav().sequence_tick(self, kind)
        else:
            self.sequence.run(self)
        usb.transmit()
        bt.transmit()
        self._gp_dt[...] = clock.end_loop() & _U32

    def run(self, ticks: int) -> None:
        """Run *ticks* main loops."""
        if self._compiled:
            while ticks > 0:
                ticks -= self.advance(ticks)
            return
        step = self.step
        for _ in range(ticks):
            step()

    def advance(self, max_ticks: int) -> int:
        """Run between 1 and *max_ticks* main loops, as many as run unobserved; returns how many.

        One loop in pure Python. With the compiled path, a *quiet* stretch (the
        tracking sequence running, ports idle — nothing received or in flight —,
        nothing due for output) runs in one compiled call up to and including the next step
        reset's loop, whose packet is then on the port: a batch driver reads and
        acknowledges after each call and gets the same bytes as loop by loop.
        """
        if max_ticks < 1:
            return 0
        kind = max_ticks > 1 and self._compiled and self._compiled_path.kind(self)
        if kind:
            fast = self._fastnav()
            quiet = fast.quiet_ticks(self, max_ticks)
            if quiet:
                n = fast.run_quiet(self, quiet, kind)
                if n:
                    return n
        self.step()
        return 1

    @property
    def compiled(self) -> bool:
        """Whether this module runs its firmware's compiled path."""
        return self._compiled

    def use_pure_path(self) -> None:
        """Run the pure-Python reference from now on (e.g. the compiled path could not be had).

        The bytes are the same either way; only the speed changes.
        """
        self._compiled = False
        self._fast = None

    def compiled_runner(self) -> CompiledSequence | None:
        """This module's compiled runner (made on first use), None when it runs the pure path; e.g. to
        step it together with other modules in one compiled call (``firmware_sim.nav.lockstep``)."""
        return self._fastnav() if self._compiled else None

    def _fastnav(self) -> CompiledSequence:
        fast = self._fast
        if fast is None:
            fast = self._fast = self._compiled_path.runner(self)  # type: ignore[union-attr]
        return fast

    def run_until(self, predicate: Callable[[Module], bool], max_ticks: int) -> int:
        """Step until *predicate(module)* holds (checked after each loop); returns loops run.

        Raises TimeoutError after *max_ticks* loops without it.
        """
        for n in range(1, max_ticks + 1):
            self.step()
            if predicate(self):
                return n
        raise TimeoutError(f"condition not met within {max_ticks} loops")

    # --------------------------------------------------------------- helpers
    def work(self, key: str, factory: Callable[[], T]) -> T:
        """Private state of a processing function, created once per module by *factory*."""
        w = self._work.get(key)
        if w is None:
            w = self._work[key] = factory()
        return w

    def execute(self, iface: ExternalInterface, spec: CommandSpec, raw: bytes) -> None:
        """Run a complete, checksum-verified command received on *iface* (the command handlers)."""
        execute(self, iface, spec, raw)

    def interface(self, kind: Interface | int) -> ExternalInterface:
        return self.interfaces[Interface(kind)]

    @property
    def overruns(self) -> int:
        return self.clock.overruns

    def budget(self) -> dict[str, int]:
        """Modelled cycles of the running sequence against one tick (does it fit 64 000 at 1 kHz?).

        ``slots`` is the sum of the occupied slots' costs (what PS_DT will show),
        ``fixed`` the loop's own minimum (wake-up, polling both interfaces), ``free``
        what is left of a tick for commands and transmission.
        """
        slots = self.firmware.functions.budget(self.sequence.slots, self.costs.slot_call)
        c = self.costs
        fixed = c.loop_overhead + 2 * c.rx_poll
        tick = self.clock.cycles_per_tick
        return {"tick": tick, "slots": slots, "fixed": fixed, "free": tick - slots - fixed}

    def counters(self) -> dict[str, int]:
        """Everything a host developer may want to watch: loop timing and both interfaces."""
        c = self.clock
        out = {"loops": c.ticks, "interrupts": c.interrupts, "overruns": c.overruns,
               "missed_ticks": c.missed_ticks, "last_loop_cycles": c.last_loop_cycles}
        for iface in self.interface_list:
            for k, v in iface.counters().items():
                out[f"{iface.name.lower()}.{k}"] = v
        return out

    def __repr__(self) -> str:
        return (f"Module({self.command_set.name} numbering, {self.clock!r}, {self.sequence!r}, "
                f"USB {'on' if self.usb.connected else 'off'}, BT {'on' if self.bt.connected else 'off'})")

    def account_loops(self, loops: int, busy_cycles: int) -> int:
        """Book *loops* main loops whose process sequence a compiled runner ran in one go, each
        woken on its own tick and busy *busy_cycles* from its wake-up to the end of its sequence,
        receiving and sending nothing: the clock, the interrupt counter, GP_DT and the sequence's
        run count as that many :meth:`step` calls leave them. Returns the cycle at which the last
        loop woke; that loop is closed too, unless :meth:`finish_loop` is called for it.
        """
        clock = self.clock
        last = clock.loops_on_time(loops, busy_cycles)
        self._interrupt_counter[...] = clock.interrupts & _U32
        self._gp_dt[...] = busy_cycles & _U32
        self.sequence.runs += loops
        return last

    def finish_loop(self) -> None:
        """transmit_data() and end_of_main_loop() of the current loop, as :meth:`step` ends it
        (for a runner that ran the loop's process sequence itself)."""
        usb, bt = self.interface_list
        usb.transmit()
        bt.transmit()
        self._gp_dt[...] = self.clock.end_loop() & _U32
