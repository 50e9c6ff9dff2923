"""A GPS receiver read live: its fixes queued on a fusion tracker, on the module's clock.

A receiver (a serial device, a pty, any pyserial URL) talks NMEA in its own time, and the
:class:`~hostlib.fusion.tracker.FusionTracker` applies a fix at the first step at or after the fix's
*module* time. The host shares no clock with the module; what it knows is when each step packet
arrived. So a fix received at host time h is put at module time

    t = t_step + (h − h_step)

with t_step the module time of the latest step (its T_INT_K, ``tracker.step_times[-1]``) and
h_step the host time it arrived (:class:`FixClock`). The mapping is renewed with every step, so the
two clocks never run apart for longer than a step. It puts a fix early by the step packet's way to
the host (about 80 ms from ``openshoe-emu serve`` over its Bluetooth link model: a tenth of a metre
at walking speed), and takes the module's clock to run at the host's rate, as a real module's does
(a module served at ``--speed`` s ≠ 1 runs s times as fast: its fixes then land up to a step off).
Before the first step there is nothing to map to: the fixes are held and queued when it arrives
(their times then fall before it, so they apply at the next step). Times never go backwards: a fix
is never put before the one before.

**A module on each foot** (:class:`~hostlib.fusion.feet.TwoFeetTracker`): each module has a clock of its
own (T_INT_K counts from its power-on), so each has its own :class:`FixClock`, renewed by that
module's steps. A fix goes to each foot's own tracker on that foot's clock, and to the joint filter
at the latest of its times on the two clocks (those of the feet that stepped yet): the joint filter
times itself by the latest module time of the steps it fused, which is the clock that runs ahead.
With one clock for both modules (the emulator's) the two times agree but for the step packets' way
to the host. A foot that has not stepped yet holds its own tracker's fixes until it does.

The first fix is the walk's geographic origin (as a log's first fix is, :mod:`hostlib.run.aid_setup`): the
fixes are north and east of it (:func:`~hostlib.aids.gps.local_positions`). Garbled lines and epochs
without a fix are skipped and counted (:class:`~hostlib.aids.gps.NmeaStats`).

* :class:`FixClock` — the mapping, with an injectable host clock;
* :class:`LiveFixes` — lines in, fixes queued on a tracker; no I/O;
* :class:`GpsStream` — a thread reading a pyserial port line by line into a :class:`LiveFixes`;
  a receiver that vanishes is reported once, and the walk goes on without it.

Threads: a :class:`~hostlib.link.device.Device`'s reader thread sums the steps — and applies the queued
fixes — holding the device's session lock (:attr:`Device.session_lock
<hostlib.link.device.Device.session_lock>`). The GPS thread queues a fix holding that same lock (with
two feet, both devices' locks, in the feet's order: then neither foot is in the middle of a step,
nor the joint filter, which each foot's step reaches under that foot's lock), so ``add_fix`` never
runs while ``add_step`` does. :meth:`LiveFixes.stepped` runs in the device's thread (a step
callback, outside the session lock). :class:`LiveFixes` keeps its own state under a lock of its
own, taken before the trackers' locks, in every thread.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable, Sequence
from contextlib import AbstractContextManager, ExitStack
from typing import Any

import numpy as np
import serial

from ..aids.gps import GpsFix, NmeaReader, NmeaStats, fix_place, local_positions
from ..fusion.feet import FOOT_SIDES, TwoFeetTracker
from ..fusion.tracker import FusionTracker
from ..link.connection import open_port

__all__ = ["GPS_BAUDRATE", "FixClock", "GpsStream", "LiveFixes"]

#: Baud rate of a GPS receiver on a UART (NMEA receivers' common one; USB and URLs ignore it).
GPS_BAUDRATE = 9600
#: A line longer than this without a line end is not NMEA (a sentence is at most 82 characters).
MAX_LINE = 256

_READ_ERRORS = (serial.SerialException, OSError, TypeError, AttributeError, ValueError)


class FixClock:
    """Host time → module time, anchored at the latest step (module docstring).

    *clock*: the host's clock [s] (default :func:`time.monotonic`; a test gives its own)."""

    def __init__(self, clock: Callable[[], float] = time.monotonic):
        self.clock = clock
        #: (module time, host time) [s] of the latest step with a module time; None before one
        self.anchor: tuple[float, float] | None = None
        self._last = -math.inf

    def step(self, module_s: float, host_s: float | None = None) -> None:
        """A step of module time *module_s* arrived at host time *host_s* (default: now). A step
        without a module time (NaN: its packet had no T_INT_K) leaves the anchor as it was."""
        if math.isfinite(module_s):
            self.anchor = (float(module_s), self.clock() if host_s is None else float(host_s))

    def module_time(self, host_s: float) -> float | None:
        """The module time of what arrived at host time *host_s*: ``t_step + (h − h_step)``, never
        before the time given last; None before the first step."""
        if self.anchor is None:
            return None
        t_step, h_step = self.anchor
        t = max(t_step + (host_s - h_step), self._last)
        self._last = t
        return t


class _Route:
    """One filter the fixes are queued on (its *add_fix*), with a :class:`FixClock` for each module
    whose steps it sums (module → clock) and the fixes it holds until one of them stepped."""

    def __init__(self, add_fix: Callable[[float, np.ndarray], None], modules: Sequence[str | None],
                 clock: Callable[[], float]):
        self.add_fix = add_fix
        self.clocks = {module: FixClock(clock) for module in modules}
        self.held: list[tuple[float, np.ndarray]] = []  # (host time, north-east) not yet queued

    def queue(self) -> int:
        """Queue the held fixes, each at the latest of its module times on the clocks anchored yet;
        returns how many (none before a step)."""
        anchored = [c for c in self.clocks.values() if c.anchor is not None]
        if not anchored:
            return 0
        for h, north_east in self.held:
            times = [c.module_time(h) for c in anchored]
            self.add_fix(max(t for t in times if t is not None), north_east)
        n = len(self.held)
        self.held.clear()
        return n


class LiveFixes:
    """A receiver's lines in, fixes queued on a tracker on the module's clock (module docstring):
    a :class:`~hostlib.fusion.tracker.FusionTracker` (one module), or a
    :class:`~hostlib.fusion.feet.TwoFeetTracker` (a module on each foot, each with its clock).

    Until :meth:`attach` gives it the tracker, and until the first step, fixes are held.
    """

    def __init__(self, clock: Callable[[], float] = time.monotonic):
        self.clock = clock
        self.reader = NmeaReader()
        self.origin: tuple[float, float, float] | None = None  #: the first fix: lat, lon, alt
        self.first_fix: GpsFix | None = None
        self.queued = 0  #: fixes queued on the tracker (with two feet: on the joint filter)
        self._pending: list[tuple[float, np.ndarray]] = []  # fixes received before attach
        self._routes: list[_Route] = []  # the tracker's own filter first
        self._steps: dict[str | None, Callable[[], Sequence[float]]] = {}  # module → its steps' times
        self._tracker_locks: tuple[AbstractContextManager[Any], ...] = ()
        self._lock = threading.Lock()

    @property
    def stats(self) -> NmeaStats:
        """What the receiver said: lines, fixes, garbled lines, epochs without a fix."""
        return self.reader.stats

    @property
    def held(self) -> int:
        """Fixes received and not yet queued on every filter (no tracker, or a module with no step
        yet)."""
        return max((len(r.held) for r in self._routes), default=len(self._pending))

    def attach(self, tracker: FusionTracker | TwoFeetTracker, *locks: AbstractContextManager[Any]) -> None:
        """Queue fixes on *tracker*, holding *locks* (those its steps are summed under: one per
        module, taken in the order given) meanwhile."""
        with self._lock:
            if isinstance(tracker, TwoFeetTracker):
                feet = [_Route(tracker.foot(side).add_fix, (side,), self.clock) for side in FOOT_SIDES]
                self._routes = [_Route(tracker.add_body_fix, FOOT_SIDES, self.clock), *feet]
                self._steps = {side: (lambda side=side: tracker.foot(side).step_times) for side in FOOT_SIDES}
            else:
                self._routes = [_Route(tracker.add_fix, (None,), self.clock)]
                self._steps = {None: lambda: tracker.step_times}
            for route in self._routes:
                route.held = list(self._pending)
            self._pending.clear()
            self._tracker_locks = locks

    def line(self, text: str | bytes, host_s: float | None = None) -> GpsFix | None:
        """A line from the receiver, arrived at host time *host_s* (default: now); its fix, if any."""
        h = self.clock() if host_s is None else float(host_s)
        fix = self.reader.feed(text)
        if fix is None:
            return None
        with self._lock:
            if self.origin is None:
                self.origin, self.first_fix = fix_place(fix), fix
            north_east = local_positions([fix], self.origin)[0, :2]
            for held in [r.held for r in self._routes] or [self._pending]:
                held.append((h, north_east))
            self._queue_held()
        return fix

    def stepped(self, host_s: float | None = None, module: str | None = None) -> None:
        """A step of *module* (the foot's side; None: the only module) was summed — call it in the
        thread that sums them, after each step: it anchors that module's clock, and the held fixes
        are queued."""
        with self._lock:
            steps = self._steps.get(module)
            times = () if steps is None else steps()
            if len(times) == 0:
                return
            h = self.clock() if host_s is None else float(host_s)
            for route in self._routes:
                if module in route.clocks:
                    route.clocks[module].step(times[-1], h)
            self._queue_held()

    def _queue_held(self) -> None:
        """Queue the held fixes on each filter that can place them (under _lock)."""
        if not any(r.held for r in self._routes):
            return
        with ExitStack() as locks:
            for lock in self._tracker_locks:
                locks.enter_context(lock)
            for k, route in enumerate(self._routes):
                n = route.queue()
                if k == 0:
                    self.queued += n


class GpsStream:
    """A thread reading the receiver at *url* (a device path or pyserial URL) into *fixes*.

    *report* hears, once, that the receiver went away (the thread then ends; the walk goes on).
    *open_port*: how the port is opened (default :func:`hostlib.link.connection.open_port`). Opening
    raises what pyserial raises (an OSError) for a receiver that is not there. A context manager.
    """

    def __init__(self, url: str, fixes: LiveFixes, *, report: Callable[[str], None] = lambda _text: None,
                 baudrate: int = GPS_BAUDRATE, open_port: Callable[..., Any] = open_port):
        self.url = url
        self.fixes = fixes
        self._report = report
        self._port = open_port(url, baudrate=baudrate, read_timeout=0.1)
        self.lost: str | None = None  #: why the receiver went away (None while it talks)
        self._stop = threading.Event()
        self._settled = threading.Event()  # a first fix came, or the receiver went away
        self._thread = threading.Thread(target=self._run, name=f"gps-reader[{url}]", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        pending = b""
        try:
            while not self._stop.is_set():
                try:
                    data = self._port.read(max(1, min(int(self._port.in_waiting or 0), 4096)))
                except _READ_ERRORS as exc:
                    if not self._stop.is_set():
                        self.lost = str(exc) or type(exc).__name__
                        self._report(f"the GPS receiver {self.url} is gone ({self.lost}); tracking goes on "
                                     "without it")
                    return
                pending = self._lines(pending + data)
        finally:
            self._settled.set()

    def _lines(self, data: bytes) -> bytes:
        """Feed the complete lines of *data*; returns the rest (a line still coming)."""
        *lines, rest = data.split(b"\n")
        for line in lines:
            self.fixes.line(line)
        if len(rest) > MAX_LINE:  # no line end in sight: not a receiver's sentence
            self.fixes.line(rest)
            rest = b""
        if self.fixes.first_fix is not None:
            self._settled.set()
        return rest

    def wait_first_fix(self, timeout: float) -> GpsFix | None:
        """The receiver's first fix, waiting up to *timeout* s for it; None if none came (or the
        receiver went away)."""
        self._settled.wait(timeout)
        return self.fixes.first_fix

    def close(self) -> None:
        """Stop the thread and close the port. Idempotent."""
        self._stop.set()
        if self._thread.is_alive() and threading.current_thread() is not self._thread:
            self._thread.join(timeout=5.0)
        try:
            self._port.close()
        except _READ_ERRORS:
            pass

    def __enter__(self) -> GpsStream:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
