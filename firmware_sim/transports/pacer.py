"""Real-time pacing: run a module's ticks against the wall clock and pump transports.

One loop (in one thread) owns the module and every endpoint, so nothing needs a
lock except the control queue (:meth:`Pacer.call`) and the status snapshot.
Each tick is run at or after its wall-clock deadline ``t0 + n / (rate · speed)``
— never before, so the module is never ahead of real time. A tick that starts
more than one tick period late counts as an *overrun* (the host machine was
too slow); the ticks still all run (virtual time never skips), back to back,
until the loop has caught up. If it falls more than ``max_lag_s`` behind, the
schedule is moved forward (counted in ``rebases``) instead of racing to catch
up. ``speed`` = 1 is real time, 10 is ten times faster, 0 (or ``inf``) as fast
as the CPU allows (endpoints are then pumped every ``asap_pump_ticks`` ticks).

Endpoints (TCP server, pty, in-process queues) implement ``pump()`` (move bytes
between the host and their port, connect/disconnect the port as hosts come
and go; non-blocking), optional ``fds`` (file descriptors worth waking up for)
and ``close()``.
"""

from __future__ import annotations

import math
import queue
import selectors
import threading
import time
from collections.abc import Callable, Iterable
from concurrent.futures import Future
from dataclasses import asdict, dataclass, field
from typing import Any, Protocol

from ..module import Module


class Endpoint(Protocol):
    """A host-facing transport the pacer pumps once per loop iteration."""

    def pump(self) -> None: ...

    def close(self) -> None: ...


@dataclass
class PacerStatus:
    """A snapshot of the real-time loop, for a live status line."""

    running: bool
    speed: float
    ticks: int  #: module ticks run by this pacer
    virtual_s: float  #: the module's clock
    wall_s: float  #: wall time since start
    loop_us_mean: float  #: mean wall time of one tick (module.step)
    loop_us_max: float
    overruns: int  #: ticks that started more than one tick period late
    rebases: int  #: times the schedule was moved forward after falling far behind
    lag_ms: float  #: how far the last tick ran behind its deadline
    packets: dict[str, int] = field(default_factory=dict)  #: packets assembled per interface
    queue: dict[str, int] = field(default_factory=dict)  #: frames in each interface's queue
    endpoints: list[dict[str, Any]] = field(default_factory=list)

    def line(self) -> str:
        """One status line, e.g. for a terminal."""
        ratio = self.virtual_s / self.wall_s if self.wall_s > 0 else 0.0
        pk = " ".join(f"{k}:{v}" for k, v in self.packets.items())
        q = " ".join(f"{k}:{v}" for k, v in self.queue.items())
        hosts = " ".join(f"{e.get('kind', '?')}={'on' if e.get('paired') else 'off'}" for e in self.endpoints)
        return (f"t={self.virtual_s:9.3f}s x{ratio:5.2f} "
                f"loop {self.loop_us_mean:6.1f}/{self.loop_us_max:6.1f} us "
                f"overruns {self.overruns} lag {self.lag_ms:5.1f} ms | packets {pk} | queue {q} | {hosts}")

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


class Pacer:
    """Runs *module* paced to the wall clock (× *speed*), pumping *endpoints*."""

    def __init__(self, module: Module, endpoints: Iterable[Endpoint] = (), speed: float = 1.0,
                 max_lag_s: float = 0.25, asap_pump_ticks: int = 10):
        if speed < 0 or math.isnan(speed):
            raise ValueError(f"speed must be >= 0 (0 = as fast as possible), got {speed}")
        self.module = module
        self.endpoints: list[Endpoint] = list(endpoints)
        self.speed = speed
        self.max_lag_s = max_lag_s
        self.asap_pump_ticks = asap_pump_ticks
        self._controls: queue.SimpleQueue[tuple[Callable[[Module], Any], Future]] = queue.SimpleQueue()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.ticks = 0
        self.overruns = 0
        self.rebases = 0
        self._lag = 0.0
        self._busy = 0.0
        self._busy_max = 0.0
        self._t_start = 0.0
        self._running = False
        self.error: BaseException | None = None

    # ------------------------------------------------------------------ control
    def start(self) -> Pacer:
        """Run the loop in a background thread (daemon)."""
        if self._thread is not None:
            raise RuntimeError("pacer already started")
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

    def __enter__(self) -> Pacer:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def call(self, fn: Callable[[Module], Any]) -> Future:
        """Run ``fn(module)`` inside the loop between two ticks (thread-safe); its result
        arrives in the returned future. This is how a control channel changes a running
        module or link (e.g. ``pacer.call(lambda m: m.bt.port.stall(0.5))``)."""
        fut: Future = Future()
        self._controls.put((fn, fut))
        return fut

    # ------------------------------------------------------------------ the loop
    def run(self, duration_s: float | None = None) -> None:
        """The loop itself (blocks). *duration_s*: stop after that much wall time."""
        step = self.module.step
        asap = self.speed == 0 or math.isinf(self.speed)
        period = 0.0 if asap else 1.0 / (self.module.clock.rate_hz * self.speed)
        sel = selectors.DefaultSelector()
        registered: set[int] = set()
        t0 = self._t_start = time.perf_counter()
        end = None if duration_s is None else t0 + duration_s
        n = 0  # ticks since t0
        self._running = True
        try:
            while not self._stop.is_set():
                self._run_controls()
                for ep in self.endpoints:
                    ep.pump()
                now = time.perf_counter()
                if end is not None and now >= end:
                    break
                if period == 0.0:
                    for _ in range(self.asap_pump_ticks):
                        s = time.perf_counter()
                        step()
                        self._account(time.perf_counter() - s)
                    continue
                # run every tick whose deadline has passed
                while True:
                    deadline = t0 + (n + 1) * period
                    if now < deadline:
                        break
                    late = now - deadline
                    if late > self.max_lag_s:
                        self.rebases += 1
                        t0 = now - (n + 1) * period
                        late = 0.0
                    elif late > period:
                        self.overruns += 1
                    self._lag = late
                    s = time.perf_counter()
                    step()
                    n += 1
                    now = time.perf_counter()
                    self._account(now - s)
                    if n % 8 == 0:
                        break  # pump the endpoints now and then while catching up
                # sleep until the next deadline, waking early for host bytes
                wait = t0 + (n + 1) * period - time.perf_counter()
                if wait > 0:
                    for ep in self.endpoints:  # what the ticks sent leaves now, not a tick later
                        ep.pump()
                    wait = t0 + (n + 1) * period - time.perf_counter()
                if wait > 0:
                    self._update_fds(sel, registered)
                    if registered:
                        sel.select(wait)
                    else:
                        self._stop.wait(wait)
        except BaseException as e:  # surfaced through status/error, never silently lost
            self.error = e
            raise
        finally:
            self._running = False
            sel.close()
            for ep in self.endpoints:
                try:
                    ep.close()
                except Exception:  # noqa: BLE001 - closing must go on for the others
                    pass

    def _account(self, dt: float) -> None:
        self.ticks += 1
        self._busy += dt
        if dt > self._busy_max:
            self._busy_max = dt

    def _run_controls(self) -> None:
        while True:
            try:
                fn, fut = self._controls.get_nowait()
            except queue.Empty:
                return
            if fut.set_running_or_notify_cancel():
                try:
                    fut.set_result(fn(self.module))
                except Exception as e:  # noqa: BLE001 - handed to the caller
                    fut.set_exception(e)

    def _update_fds(self, sel: selectors.BaseSelector, registered: set[int]) -> None:
        want: set[int] = set()
        for ep in self.endpoints:
            want.update(getattr(ep, "fds", ()))
        for fd in registered - want:
            try:
                sel.unregister(fd)
            except (KeyError, ValueError, OSError):
                pass
        for fd in want - registered:
            try:
                sel.register(fd, selectors.EVENT_READ)
            except (KeyError, ValueError, OSError):
                continue
        registered.clear()
        registered.update(k.fd for k in sel.get_map().values())

    # ------------------------------------------------------------------ status
    def status(self) -> PacerStatus:
        """A snapshot (read without stopping the loop; numbers may be one tick apart)."""
        m = self.module
        ticks = self.ticks
        eps = []
        for ep in self.endpoints:
            st = getattr(ep, "status", None)
            eps.append(st() if callable(st) else {"kind": type(ep).__name__})
        return PacerStatus(
            running=self._running,
            speed=self.speed,
            ticks=ticks,
            virtual_s=m.clock.now_cycles / m.clock.cpu_hz,
            wall_s=(time.perf_counter() - self._t_start) if self._t_start else 0.0,
            loop_us_mean=(self._busy / ticks * 1e6) if ticks else 0.0,
            loop_us_max=self._busy_max * 1e6,
            overruns=self.overruns,
            rebases=self.rebases,
            lag_ms=self._lag * 1e3,
            packets={i.name: i.packets_assembled for i in m.interface_list},
            queue={i.name: len(i.queue) for i in m.interface_list},
            endpoints=eps,
        )

    def __repr__(self) -> str:
        return (f"Pacer(speed={self.speed}, ticks={self.ticks}, overruns={self.overruns}, "
                f"running={self._running})")
