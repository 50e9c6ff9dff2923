"""The loop of a pacer: a :class:`MultiPacer` runs many modules in one loop and one thread."""

from __future__ import annotations

import math
import threading
from collections.abc import Callable, Iterable
from concurrent.futures import Future
from typing import Any

from firmware_sim.mcu.module import Module
from firmware_sim.nav.warmup import Announce, prepare_module, to_stderr

from .endpoints import Endpoint
from .member import PacedModule
from .priority import check_level
from .run_loop import RunLoop
from .stalls import GcPauses
from .status import PacerStatus


def _check_members(pacers: list[PacedModule], group: object) -> None:
    """Modules that can run in one loop: one speed, one tick rate, none in another loop."""
    first = pacers[0]
    for p in pacers:
        if p.speed != first.speed and not (math.isinf(p.speed) and math.isinf(first.speed)):
            raise ValueError(f"all modules of a MultiPacer run at one speed: {p.speed} != {first.speed}")
        if p.module.clock.rate_hz != first.module.clock.rate_hz:
            raise ValueError("all modules of a MultiPacer tick at one rate: "
                             f"{p.module.clock.rate_hz} != {first.module.clock.rate_hz} Hz")
        old = p._group
        if old is not None and old is not group and old.in_use():
            raise ValueError(f"{p!r} already runs in another loop")


class MultiPacer:
    """Runs several modules (each a :class:`~.member.PacedModule`, e.g. a :class:`~.single.Pacer`,
    with its endpoints) in one loop and one thread.

    All modules share one schedule: the same tick rate and speed (and ``max_lag_s``,
    ``asap_pump_ticks`` of the first). Each still counts its own ticks, overruns and
    step time, and takes its own controls (``pacers[i].call(fn)``). *idle_pump_s*: at
    most this long between two pumps of a quiet endpoint (0 = pump every endpoint after
    every tick, as a lone pacer does). *spin_load*: poll instead of sleeping while a
    round of frames takes more than this fraction of a frame (None, the default: always sleep).
    *phases*: how many evenly spaced deadlines the modules are spread over (None = one
    per module; 1 = all at the start of the frame); the modules of one phase are advanced together.
    *frame_ticks*: ticks a module runs per
    wake-up (see the package doc). *overrun_s*: a frame later than this (in module time)
    counts an overrun; None = later than a host could see (the package doc; at least one frame).
    *rt_priority*: run the loop's thread under the real-time policy at this level (1–99) when paced
    to the wall clock (:mod:`.priority`; None, the default: the ordinary priority); :attr:`priority`
    says what it got.
    """

    def __init__(self, pacers: Iterable[PacedModule], idle_pump_s: float = 0.005,
                 spin_load: float | None = None, phases: int | None = None, frame_ticks: int = 1,
                 overrun_s: float | None = None, rt_priority: int | None = None):
        self.pacers: list[PacedModule] = list(pacers)
        if not self.pacers:
            raise ValueError("a MultiPacer needs at least one module")
        if idle_pump_s < 0:
            raise ValueError(f"idle_pump_s must be >= 0, got {idle_pump_s}")
        if frame_ticks < 1:
            raise ValueError(f"frame_ticks must be >= 1, got {frame_ticks}")
        if overrun_s is not None and not overrun_s >= 0:
            raise ValueError(f"overrun_s must be >= 0, got {overrun_s}")
        check_level(rt_priority)
        _check_members(self.pacers, self)
        first = self.pacers[0]
        for p in self.pacers:
            p._group = self
        self.speed = first.speed
        self.max_lag_s = first.max_lag_s
        self.asap_pump_ticks = first.asap_pump_ticks
        self.idle_pump_s = idle_pump_s
        self.spin_load = spin_load
        self.phases = phases
        self.frame_ticks = int(frame_ticks)
        self.overrun_s = overrun_s
        self.rt_priority = rt_priority
        #: the loop thread's scheduling once it runs (:func:`.priority.raise_priority`)
        self.priority = "normal"
        self.thread_id: int | None = None  #: the loop thread's native id while it runs
        self.gc_pauses = GcPauses()  #: the garbage collector's runs while the loop runs
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._prepared = False
        self.running = False
        self.t_start = 0.0
        self.error: BaseException | None = None  #: what stopped the loop

    @classmethod
    def of(cls, modules: Iterable[tuple[Module, Iterable[Endpoint]]], speed: float = 1.0,
           max_lag_s: float = 0.25, idle_pump_s: float = 0.005, frame_ticks: int = 1) -> MultiPacer:
        """A multi-pacer over ``(module, endpoints)`` pairs."""
        return cls([PacedModule(m, eps, speed=speed, max_lag_s=max_lag_s) for m, eps in modules],
                   idle_pump_s=idle_pump_s, frame_ticks=frame_ticks)

    # ------------------------------------------------------------------ control
    def start(self, announce: Announce | None = to_stderr) -> MultiPacer:
        """Prepare the modules (see :meth:`PacedModule.start`), then run the loop in a background
        thread (daemon)."""
        if self._thread is not None:
            raise RuntimeError("pacer already started")
        self.prepare(announce)
        for p in self.pacers:
            p.waits.begin()
        self._thread = threading.Thread(target=self.run, name="openshoe-pacer", daemon=True)
        self._thread.start()
        return self

    def stop(self, timeout: float = 5.0) -> None:
        """Stop the loop, close the endpoints, join the thread."""
        self._stop.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout)
            if self._thread.is_alive():
                raise RuntimeError("pacer thread did not stop")

    def __enter__(self) -> MultiPacer:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def call(self, index: int, fn: Callable[[Module], Any]) -> Future:
        """``fn(module)`` for module *index*, between two ticks (see :meth:`PacedModule.call`)."""
        return self.pacers[index].call(fn)

    def wait_ticks(self, index: int, n: int, timeout: float | None = None) -> bool:
        """Block until module *index* has run *n* more ticks (see :meth:`PacedModule.wait_ticks`)."""
        return self.pacers[index].wait_ticks(n, timeout)

    def wait_until(self, index: int, predicate: Callable[[Module], object],
                   timeout: float | None = None) -> bool:
        """Block until ``predicate(module)`` holds for module *index* (see :meth:`PacedModule.wait_until`)."""
        return self.pacers[index].wait_until(predicate, timeout)

    def status(self) -> list[PacerStatus]:
        """One snapshot per module."""
        return [p.status() for p in self.pacers]

    def prepare(self, announce: Announce | None = to_stderr) -> None:
        """Compile or load the modules' kernels now, before the clock starts (once per loop)."""
        if not self._prepared:
            for p in self.pacers:
                prepare_module(p.module, announce)
            self._prepared = True

    def in_use(self) -> bool:
        """Whether the loop started, or runs other modules too (a module then cannot join another)."""
        return self._thread is not None or len(self.pacers) > 1

    # ------------------------------------------------------------------ the loop
    def run(self, duration_s: float | None = None) -> None:
        """The loop itself (blocks; prepares the modules first, unless :meth:`start` did).
        *duration_s*: stop after that much wall time."""
        self.prepare()
        RunLoop(self, self._stop, duration_s).run()

    def __repr__(self) -> str:
        return (f"MultiPacer({len(self.pacers)} modules, speed={self.speed}, "
                f"overruns={sum(p.overruns for p in self.pacers)}, running={self.running})")
