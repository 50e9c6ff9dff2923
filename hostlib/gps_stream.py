"""A GPS receiver read live: its fixes queued on a fusion tracker, on the module's clock.

A receiver (a serial device, a pty, any pyserial URL) talks NMEA in its own time, and the
:class:`~hostlib.fusion.FusionTracker` applies a fix at the first step at or after the fix's
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

The first fix is the walk's geographic origin (as a log's first fix is, :mod:`hostlib.aids`): the
fixes are north and east of it (:func:`~hostlib.gps.local_positions`). Garbled lines and epochs
without a fix are skipped and counted (:class:`~hostlib.gps.NmeaStats`).

* :class:`FixClock` — the mapping, with an injectable host clock;
* :class:`LiveFixes` — lines in, fixes queued on a tracker; no I/O;
* :class:`GpsStream` — a thread reading a pyserial port line by line into a :class:`LiveFixes`;
  a receiver that vanishes is reported once, and the walk goes on without it.

Threads: a :class:`~hostlib.device.Device`'s reader thread sums the steps — and applies the queued
fixes — holding the device's session lock (:attr:`Device.session_lock
<hostlib.device.Device.session_lock>`). The GPS thread queues a fix holding that same lock, so
``add_fix`` never runs while ``add_step`` does. :meth:`LiveFixes.stepped` runs in the device's
thread (a step callback). :class:`LiveFixes` keeps its own state under a lock of its own, taken
before the tracker's, in both threads.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from contextlib import AbstractContextManager, nullcontext
from typing import Any

import numpy as np
import serial

from .connection import open_port
from .fusion import FusionTracker
from .gps import GpsFix, NmeaReader, NmeaStats, fix_place, local_positions

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


class LiveFixes:
    """A receiver's lines in, fixes queued on a tracker on the module's clock (module docstring).

    Until :meth:`attach` gives it the tracker, and until the first step, fixes are held.
    """

    def __init__(self, clock: Callable[[], float] = time.monotonic):
        self.times = FixClock(clock)
        self.reader = NmeaReader()
        self.origin: tuple[float, float, float] | None = None  #: the first fix: lat, lon, alt
        self.first_fix: GpsFix | None = None
        self.queued = 0  #: fixes queued on the tracker
        self._held: list[tuple[float, np.ndarray]] = []  # (host time, north-east) not yet queued
        self._tracker: FusionTracker | None = None
        self._tracker_lock: AbstractContextManager[Any] = nullcontext()
        self._lock = threading.Lock()

    @property
    def stats(self) -> NmeaStats:
        """What the receiver said: lines, fixes, garbled lines, epochs without a fix."""
        return self.reader.stats

    @property
    def held(self) -> int:
        """Fixes received and not yet queued (no tracker, or no step yet)."""
        return len(self._held)

    def attach(self, tracker: FusionTracker, lock: AbstractContextManager[Any]) -> None:
        """Queue fixes on *tracker*, holding *lock* (the one its steps are summed under) meanwhile."""
        with self._lock:
            self._tracker, self._tracker_lock = tracker, lock

    def line(self, text: str | bytes, host_s: float | None = None) -> GpsFix | None:
        """A line from the receiver, arrived at host time *host_s* (default: now); its fix, if any."""
        h = self.times.clock() if host_s is None else float(host_s)
        fix = self.reader.feed(text)
        if fix is None:
            return None
        with self._lock:
            if self.origin is None:
                self.origin, self.first_fix = fix_place(fix), fix
            self._held.append((h, local_positions([fix], self.origin)[0, :2]))
            self._queue_held()
        return fix

    def stepped(self, host_s: float | None = None) -> None:
        """A step was summed (call it in the thread that sums them, after each step): it anchors
        the mapping, and the held fixes are queued."""
        with self._lock:
            tracker = self._tracker
            if tracker is None or not tracker.step_times:
                return
            self.times.step(tracker.step_times[-1], host_s)
            self._queue_held()

    def _queue_held(self) -> None:
        """Queue the held fixes, once there is a tracker and a step to map them with (under _lock)."""
        if self._tracker is None or self.times.anchor is None or not self._held:
            return
        with self._tracker_lock:
            for h, north_east in self._held:
                self._tracker.add_fix(self.times.module_time(h), north_east)  # type: ignore[arg-type]
                self.queued += 1
        self._held.clear()


class GpsStream:
    """A thread reading the receiver at *url* (a device path or pyserial URL) into *fixes*.

    *report* hears, once, that the receiver went away (the thread then ends; the walk goes on).
    *open_port*: how the port is opened (default :func:`hostlib.connection.open_port`). Opening
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
