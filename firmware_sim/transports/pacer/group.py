"""The loop of a pacer: a :class:`MultiPacer` runs many modules in one loop and one thread."""

from __future__ import annotations

import math
import selectors
import threading
import time
from collections.abc import Callable, Iterable
from concurrent.futures import Future
from typing import Any

from firmware_sim.mcu.module import Module
from firmware_sim.nav.warmup import Announce, prepare_module, to_stderr

from .endpoints import Endpoint, links_of
from .endpoints import lookahead_cycles as _lookahead_cycles
from .member import PacedModule
from .status import LAG_BOUNDS_MS, PacerStatus


def _host_clock(c0: int, cycles_per_s: float, phase: float, sched: list[float],
                perf: Callable[[], float]) -> Callable[[], int]:
    """The wall clock in a module's cycles: tick *m* (cycle c0 + m·period) is at sched[0] + m/rate + phase."""
    def now() -> int:
        return c0 + int((perf() - sched[0] - phase) * cycles_per_s)
    return now


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
    per module; 1 = all at the start of the frame). *frame_ticks*: ticks a module runs per
    wake-up (see the module doc). *overrun_s*: a frame later than this (in module time)
    counts an overrun; None = later than a host could see (the module doc; at least one frame).
    """

    def __init__(self, pacers: Iterable[PacedModule], idle_pump_s: float = 0.005,
                 spin_load: float | None = None, phases: int | None = None, frame_ticks: int = 1,
                 overrun_s: float | None = None):
        self.pacers: list[PacedModule] = list(pacers)
        if not self.pacers:
            raise ValueError("a MultiPacer needs at least one module")
        if idle_pump_s < 0:
            raise ValueError(f"idle_pump_s must be >= 0, got {idle_pump_s}")
        if frame_ticks < 1:
            raise ValueError(f"frame_ticks must be >= 1, got {frame_ticks}")
        if overrun_s is not None and not overrun_s >= 0:
            raise ValueError(f"overrun_s must be >= 0, got {overrun_s}")
        first = self.pacers[0]
        for p in self.pacers:
            if p.speed != first.speed and not (math.isinf(p.speed) and math.isinf(first.speed)):
                raise ValueError(f"all modules of a MultiPacer run at one speed: {p.speed} != {first.speed}")
            if p.module.clock.rate_hz != first.module.clock.rate_hz:
                raise ValueError("all modules of a MultiPacer tick at one rate: "
                                 f"{p.module.clock.rate_hz} != {first.module.clock.rate_hz} Hz")
            old = p._group
            if old is not None and old is not self and old.in_use():
                raise ValueError(f"{p!r} already runs in another loop")
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
        pacers = self.pacers
        n_mod = len(pacers)
        advances = [p.module.advance for p in pacers]
        eps: list[Endpoint] = [ep for p in pacers for ep in p.endpoints]
        owner: list[int] = [j for j, p in enumerate(pacers) for _ in p.endpoints]
        pending: list[Callable[[], int] | None] = [None if self.idle_pump_s == 0 else
                                                   getattr(getattr(ep, "port", None), "host_pending", None)
                                                   for ep in eps]
        registered: list[tuple[int, ...]] = [() for _ in eps]
        speed = self.speed
        asap = speed == 0 or math.isinf(speed)
        F = self.frame_ticks
        period = 0.0 if asap else 1.0 / (pacers[0].module.clock.rate_hz * speed)
        frame = F * period
        bounds = [ms / 1000.0 / (1.0 if asap else speed) for ms in LAG_BOUNDS_MS[:-1]]
        n_bounds = len(bounds)
        # real time: each module runs ahead by its lookahead, its links on the host's clock
        # (see the module doc); as fast as possible, the host lives on the module's clock
        ahead = [0.0 if asap else
                 _lookahead_cycles(p.module, p.endpoints) / p.module.clock.cycles_per_tick * period
                 for p in pacers]
        limits = [frame if asap else (self.overrun_s / speed if self.overrun_s is not None
                                      else max(frame, 2 * a + period - frame)) for a in ahead]
        for p, a, lim in zip(pacers, ahead, limits, strict=True):
            p.lookahead_s, p.overrun_limit_s = a, lim
        max_lag = self.max_lag_s
        poll = 0 if self.idle_pump_s == 0 or asap else max(1, math.ceil(self.idle_pump_s / frame - 1e-9))
        spin_busy = None if self.spin_load is None or asap else self.spin_load * frame
        spinning = False
        polled = -1  # the frame whose hosts a spinning loop looked at last
        round_busy = 0.0
        ran = 0  # whole rounds of frames run back to back
        last = [0 for _ in eps]
        done = [0] * n_mod  # ticks each module ran since t0
        # module j's frame f (its ticks f·F+1 … (f+1)·F) is due at t0 + (f + 1)·F·period + phase_j,
        # its tick m at t0 + m·period + phase_j (see the doc)
        phases = max(1, min(self.phases or n_mod, n_mod))
        offs = [(j * phases // n_mod) * frame / phases for j in range(n_mod)]
        due_offs = [o - a for o, a in zip(offs, ahead, strict=True)]  # deadlines, the lookahead early
        ep_lo: list[int] = []
        ep_hi: list[int] = []
        for p in pacers:
            ep_lo.append(ep_hi[-1] if ep_hi else 0)
            ep_hi.append(ep_lo[-1] + len(p.endpoints))
        j = 0  # the next module to run (of frame f)
        # select(2) sleeps to the microsecond; epoll and poll round a timeout up to a millisecond
        sel: selectors.BaseSelector = selectors.SelectSelector()
        stop = self._stop
        perf = time.perf_counter
        t0 = self.t_start = perf()
        end = None if duration_s is None else t0 + duration_s
        f = 0  # the frame being run
        self.running = True
        sched = [t0]  # t0 for the host clocks (moved by rebases)
        clocked: list[Any] = []
        mod_links: list[list[Any]] = [[] for _ in pacers]
        c0s = [0] * n_mod
        cps = [1.0] * n_mod
        # wall time at which module k's links next have bytes reaching a host (inf: none)
        release_at = [math.inf] * n_mod
        if not asap:
            for k, p in enumerate(pacers):
                if ahead[k] <= 0:
                    # never ahead: its links stay on its clock, and a host's bytes reach it at its
                    # next loop, however late that loop runs (the fastest answer to a command)
                    continue
                clk = p.module.clock
                cpt = clk.cycles_per_tick
                c0s[k] = c0 = clk.now_cycles + clk.cycles_until_next_tick() - cpt  # the cycle of tick 0
                cps[k] = cpt / period
                mod_links[k] = links_of(p.endpoints)
                for link in mod_links[k]:
                    link.host_clock = _host_clock(c0, cps[k], offs[k], sched, perf)
                    link.late_tolerance_cycles = F * cpt
                    clocked.append(link)

        def update_release(k: int) -> None:
            best = math.inf
            for link in mod_links[k]:
                t = link.next_host_arrival()
                if t is not None:
                    w = sched[0] + offs[k] + (t - c0s[k]) / cps[k]
                    if w < best:
                        best = w
            release_at[k] = best

        def pump(i: int) -> None:
            ep = eps[i]
            try:
                ep.pump()
            except BaseException as e:
                p = pacers[owner[i]]
                p.error = p.error or e
                raise
            last[i] = f
            fds = getattr(ep, "fds", ())
            old = registered[i]
            if fds != old:
                for fd in old:
                    if fd not in fds:
                        try:
                            sel.unregister(fd)
                        except (KeyError, ValueError, OSError):
                            pass
                ok = []
                for fd in fds:
                    if fd in old:
                        ok.append(fd)
                        continue
                    try:
                        sel.register(fd, selectors.EVENT_READ, i)
                        ok.append(fd)
                    except (KeyError, ValueError, OSError):
                        continue
                registered[i] = tuple(ok)

        def run_to(k: int, target: int) -> float:
            """Run module k until it has run *target* ticks; returns the wall time it took."""
            p = pacers[k]
            adv = advances[k]
            s = perf()
            d = done[k]
            try:
                while d < target:
                    d += adv(target - d)
            except BaseException as e:
                p.error = p.error or e
                raise
            finally:
                p.ticks += d - done[k]
                done[k] = d
            dt = perf() - s
            p._busy += dt
            if dt > p._busy_max:
                p._busy_max = dt
            return dt

        def pump_owned(k: int, force: bool) -> None:
            for i in range(ep_lo[k], ep_hi[k]):
                has = pending[i]
                if force or has is None or has() or f - last[i] >= poll:
                    pump(i)
            if mod_links[k]:
                update_release(k)

        def release_due(now: float) -> None:
            """Hand over the bytes that reach a host by *now* on their link model's clock."""
            if min(release_at) <= now:
                for k in range(n_mod):
                    if release_at[k] <= now:
                        pump_owned(k, True)
                        if release_at[k] <= now:
                            # no endpoint took them (no host on it yet): look again after the
                            # module's next frame instead of spinning on them
                            release_at[k] = math.inf

        try:
            for i in range(len(eps)):
                pump(i)
            while not stop.is_set():
                for p in pacers:
                    p.run_controls()
                now = perf()
                if end is not None and now >= end:
                    break
                release_due(now)
                if asap:
                    for k in range(n_mod):
                        run_to(k, done[k] + self.asap_pump_ticks)
                    f += 1
                    for i in range(len(eps)):
                        pump(i)
                    continue
                # run every module whose frame is due, in turn
                stepped = False
                while True:
                    # bytes due at a host go first: they have no slack, a frame has its lookahead
                    release_due(now)
                    deadline = t0 + (f + 1) * frame + due_offs[j]
                    if now < deadline:
                        break
                    if now - deadline > max_lag:
                        for p in pacers:
                            p.rebases += 1
                        t0 = sched[0] = now - (f + 1) * frame - due_offs[j]
                        deadline = now
                    p = pacers[j]
                    late = now - deadline
                    if late > limits[j]:
                        p.overruns += 1
                    if late > p._lag_max:
                        p._lag_max = late
                    b = 0
                    while b < n_bounds and late >= bounds[b]:
                        b += 1
                    p._lag_counts[b] += 1
                    p._lag = late
                    round_busy += run_to(j, (f + 1) * F)
                    # what the frame sent leaves now, not a frame later
                    pump_owned(j, False)
                    now = perf()
                    stepped = True
                    j += 1
                    if j == n_mod:
                        j = 0
                        f += 1
                        # spin through the idle time if the frames take most of the period (see the doc)
                        spinning = spin_busy is not None and round_busy > spin_busy
                        round_busy = 0.0
                        ran += 1
                        if ran >= 8:
                            ran = 0
                            break  # look at the hosts now and then while catching up
                if not stepped:
                    ran = 0
                wait = min(t0 + (f + 1) * frame + due_offs[j], min(release_at)) - perf()
                if spinning and wait > 0:
                    # busy-wait without system calls (a kernel entry leaves the next step with
                    # cold caches and branch predictors); look at the hosts once per frame
                    target = perf() + wait
                    if f != polled:
                        polled = f
                        if sel.get_map():
                            for key, _ in sel.select(0):
                                pump(key.data)
                    while perf() < target:
                        pass
                    continue
                ready = sel.select(max(wait, 0.0)) if sel.get_map() else None
                if ready:
                    now = perf()
                    for key, _ in ready:
                        i = key.data
                        pump(i)
                        if mod_links[owner[i]]:
                            update_release(owner[i])
                        if F > 1:
                            # a host wrote: its module catches up with the wall clock now (the
                            # ticks already due), so the command is not held to the frame's end
                            k = owner[i]
                            due = min(int((now - t0 - due_offs[k]) / period), (f + (1 if k >= j else 2)) * F)
                            if due > done[k]:
                                run_to(k, due)
                                pump_owned(k, True)
                elif ready is None and wait > 0:
                    stop.wait(wait)
        except BaseException as e:  # surfaced through status/error, never silently lost
            self.error = e
            if not any(p.error is not None for p in pacers):
                for p in pacers:
                    p.error = e
            raise
        finally:
            self.running = False
            for link in clocked:
                link.host_clock = None  # back on the module's clock
            sel.close()
            for ep in eps:
                try:
                    ep.close()
                except Exception:  # noqa: BLE001 - closing must go on for the others
                    pass

    def __repr__(self) -> str:
        return (f"MultiPacer({len(self.pacers)} modules, speed={self.speed}, "
                f"overruns={sum(p.overruns for p in self.pacers)}, running={self.running})")
