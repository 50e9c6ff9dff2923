"""One module of a pacer loop: the module with its endpoints, counters, controls and status."""

from __future__ import annotations

import math
import queue
import time
from collections.abc import Callable, Iterable
from concurrent.futures import Future
from typing import Any, Protocol

from firmware_sim.mcu.module import Module
from firmware_sim.nav.warmup import Announce, to_stderr
from protocol.states import state_spec

from .endpoints import Endpoint, links_of
from .stalls import GcPauses, run_queue_wait_s
from .status import LAG_BOUNDS_MS, LAG_LABELS, PacerStatus
from .waits import TickWaits


def check_speed(speed: float) -> None:
    if speed < 0 or math.isnan(speed):
        raise ValueError(f"speed must be >= 0 (0 = as fast as possible), got {speed}")


def lag_class(late: float, bounds: list[float]) -> int:
    """The lateness class of a frame that started *late* [s] after its deadline, by *bounds* (the
    upper bounds of the classes but the last)."""
    b = 0
    n_bounds = len(bounds)
    while b < n_bounds and late >= bounds[b]:
        b += 1
    return b


class Loop(Protocol):
    """What a module knows of the loop that runs it (a :class:`~.group.MultiPacer`)."""

    running: bool
    t_start: float
    speed: float
    frame_ticks: int
    priority: str
    thread_id: int | None
    gc_pauses: GcPauses

    def start(self, announce: Announce | None = ...) -> object: ...

    def stop(self, timeout: float = ...) -> None: ...

    def run(self, duration_s: float | None = ...) -> None: ...

    def in_use(self) -> bool: ...


class PacedModule:
    """*module* with its *endpoints*, as one module of a loop paced to the wall clock (× *speed*).

    It keeps its own counters, status and control queue (:meth:`call`), and lets other
    threads wait on its ticks (:meth:`wait_ticks`, :meth:`wait_until`); the loop it
    runs in (:attr:`group`) runs its ticks and pumps its endpoints. A
    :class:`~.single.Pacer` is one with a loop of its own."""

    def __init__(self, module: Module, endpoints: Iterable[Endpoint] = (), speed: float = 1.0,
                 max_lag_s: float = 0.25, asap_pump_ticks: int = 10):
        check_speed(speed)
        self.module = module
        self.endpoints: list[Endpoint] = list(endpoints)
        self.speed = speed
        self.max_lag_s = max_lag_s
        self.asap_pump_ticks = asap_pump_ticks
        self._controls: queue.SimpleQueue[tuple[Callable[[Module], Any], Future]] = queue.SimpleQueue()
        self.ticks = 0
        self.overruns = 0
        self.rebases = 0
        self._lag = 0.0
        self._lag_max = 0.0
        self._lag_counts = [0] * len(LAG_BOUNDS_MS)
        self._busy = 0.0
        self._busy_max = 0.0
        self.lookahead_s = 0.0  #: wall seconds the module runs ahead (set when its loop starts)
        self.overrun_limit_s = 0.0  #: wall seconds of lateness that count an overrun (likewise)
        self.error: BaseException | None = None  #: what stopped the loop, if this module raised it
        #: Float states (navigation numbers) holding an inf or a NaN after the module's last frame.
        self.nonfinite: tuple[int, ...] = ()
        #: Frames after which some navigation number was not finite, and the module time [s] of the first.
        self.nonfinite_frames = 0
        self.nonfinite_first_s: float | None = None
        self.waits = TickWaits()  #: threads waiting on the module's ticks (the loop tests them)
        self._group: Loop | None = None  # set by the loop that takes the module

    @property
    def group(self) -> Loop:
        """The loop this module runs in."""
        if self._group is None:
            raise RuntimeError(f"{self!r} runs in no loop")
        return self._group

    # ------------------------------------------------------------------ control
    def start(self, announce: Announce | None = to_stderr) -> PacedModule:
        """Prepare the module (:func:`~firmware_sim.nav.warmup.prepare_module`: no compile once the
        clock runs; *announce* hears about a slow first start), then run its loop in a
        background thread (daemon)."""
        self.group.start(announce)
        return self

    def stop(self, timeout: float = 5.0) -> None:
        """Stop the loop (with every module in it), close the endpoints, join the thread."""
        self.group.stop(timeout)

    def __enter__(self) -> PacedModule:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def run(self, duration_s: float | None = None) -> None:
        """The loop itself (blocks). *duration_s*: stop after that much wall time."""
        self.group.run(duration_s)

    def call(self, fn: Callable[[Module], Any]) -> Future:
        """Run ``fn(module)`` inside the loop between two ticks (thread-safe); its result
        arrives in the returned future. This is how a control channel changes a running
        module or link (e.g. ``pacer.call(lambda m: m.bt.port.stall(0.5))``)."""
        fut: Future = Future()
        self._controls.put((fn, fut))
        return fut

    # ------------------------------------------------------------------ waiting on ticks
    def wait_ticks(self, n: int, timeout: float | None = None) -> bool:
        """Block until the module has run *n* more ticks (counted from now): True; False after
        *timeout* seconds (None: no limit), or once its loop has stopped. This waits on the
        loop, which wakes the caller after it ran the ticks, not on the clock."""
        if n <= 0:
            return True
        target = self.ticks + n
        return self.waits.wait(lambda: self.ticks >= target, timeout)

    def wait_until(self, predicate: Callable[[Module], object], timeout: float | None = None) -> bool:
        """Block until ``predicate(module)`` is true: True; False after *timeout* seconds (None:
        no limit), or once its loop has stopped. The loop evaluates the predicate in its own
        thread after each run of the module's ticks from now on, so it may read the module
        (and its links and endpoints) as :meth:`call` does; what it raises is raised here."""
        module = self.module
        return self.waits.wait(lambda: predicate(module), timeout)

    # ------------------------------------------------------------------ in the loop's thread
    def run_controls(self) -> bool:
        """Run the calls queued by :meth:`call` (the loop, between two ticks): whether any ran."""
        if self._controls.empty():
            return False
        while True:
            try:
                fn, fut = self._controls.get_nowait()
            except queue.Empty:
                return True
            if fut.set_running_or_notify_cancel():
                try:
                    fut.set_result(fn(self.module))
                except Exception as e:  # noqa: BLE001 - handed to the caller
                    fut.set_exception(e)

    def count_frame_start(self, late: float, limit: float, bounds: list[float]) -> None:
        """A frame started *late* [s] after its deadline: an overrun past *limit*; its
        lateness class by *bounds* (the upper bounds of the classes but the last)."""
        self.count_frame(late, late > limit, lag_class(late, bounds))

    def count_frame(self, late: float, overrun: bool, lag: int) -> None:
        """A frame started *late* [s] after its deadline, an *overrun* or not, in lateness class
        *lag* (:func:`lag_class`: the same for the modules of a phase group, found once)."""
        if overrun:
            self.overruns += 1
        if late > self._lag_max:
            self._lag_max = late
        self._lag_counts[lag] += 1
        self._lag = late

    def after_frame(self, dt: float) -> None:
        """A frame's ticks ran, taking *dt* wall seconds: count them, look at the navigation
        numbers, wake the threads whose wait is over."""
        self.count_busy(dt)
        self.check_numbers()
        self.waits.check()

    def check_numbers(self) -> None:
        """After a frame: note whether the module's navigation numbers (its float states) are all
        finite. A host's SET_STATE can make the firmware's arithmetic give inf or NaN, as the
        µC's would (docs/protocol-extensions.md); the status shows it."""
        bad = self.module.memory.nonfinite_states()
        self.nonfinite = bad
        if bad:
            self.nonfinite_frames += 1
            if self.nonfinite_first_s is None:
                clock = self.module.clock
                self.nonfinite_first_s = clock.now_cycles / clock.cpu_hz

    def count_busy(self, dt: float) -> None:
        """One run of ticks took *dt* wall seconds."""
        self._busy += dt
        if dt > self._busy_max:
            self._busy_max = dt

    # ------------------------------------------------------------------ status
    def status(self) -> PacerStatus:
        """A snapshot (read without stopping the loop; numbers may be one tick apart)."""
        m = self.module
        g = self.group
        ticks = self.ticks
        eps = []
        for ep in self.endpoints:
            st = getattr(ep, "status", None)
            eps.append(st() if callable(st) else {"kind": type(ep).__name__})
        late = [link.counters.direction(d) for link in links_of(self.endpoints)
                for d in ("to_host", "to_module")]
        ms_per_s = 1e3 * (g.speed if g.speed and not math.isinf(g.speed) else 1.0)
        return PacerStatus(
            running=g.running,
            speed=self.speed,
            ticks=ticks,
            virtual_s=m.clock.now_cycles / m.clock.cpu_hz,
            wall_s=(time.perf_counter() - g.t_start) if g.t_start else 0.0,
            loop_us_mean=(self._busy / ticks * 1e6) if ticks else 0.0,
            loop_us_max=self._busy_max * 1e6,
            overruns=self.overruns,
            rebases=self.rebases,
            lag_ms=self._lag * 1e3,
            lag_max_ms=self._lag_max * 1e3,
            lag_frames=dict(zip(LAG_LABELS, self._lag_counts, strict=True)),
            frame_ms=0.0 if g.speed == 0 or math.isinf(g.speed)
            else g.frame_ticks * 1e3 / (m.clock.rate_hz * g.speed),
            lookahead_ms=self.lookahead_s * ms_per_s,
            overrun_limit_ms=self.overrun_limit_s * ms_per_s,
            late_bytes=sum(c.late for c in late),
            late_max_ms=max((c.late_max_cycles for c in late), default=0) * 1e3 / m.clock.cpu_hz,
            nonfinite=[state_spec(sid).name for sid in self.nonfinite],
            nonfinite_frames=self.nonfinite_frames,
            nonfinite_first_s=self.nonfinite_first_s,
            packets={i.name: i.packets_assembled for i in m.interface_list},
            queue={i.name: len(i.queue) for i in m.interface_list},
            endpoints=eps,
            priority=g.priority,
            run_queue_wait_s=run_queue_wait_s(g.thread_id),
            gc_runs=g.gc_pauses.count,
            gc_longest_ms=g.gc_pauses.longest * 1e3,
        )

    def __repr__(self) -> str:
        running = self._group is not None and self._group.running
        return (f"{type(self).__name__}(speed={self.speed}, ticks={self.ticks}, overruns={self.overruns}, "
                f"running={running})")
