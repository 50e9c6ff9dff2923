"""``openshoe-emu serve --gps-pty PATH``: a simulated GPS receiver on the served walker, on its own pty.

The receiver is the batch ``--gps`` one (:class:`firmware_sim.sensors.gps.Receiver`: the same error
model, the same draws for the same seed, the same GGA and RMC sentences from
:func:`~firmware_sim.sensors.gps.nmea_lines`), but its epochs come as the served module's clock
reaches them:

* **On the module's clock.** Epoch k is at module time T = k / rate (1 Hz: 0, 1, 2 … s after
  power-on), and its sentences are written when the module's clock reaches T: the endpoint is
  pumped by the module's pacer, after the module's frame, like the module's own endpoints. The
  UTC in the sentences is :data:`~firmware_sim.sensors.gps.DEFAULT_START` + T.
* **Where the walker is.** A served scenario starts at the module's first sensor read, when a host
  starts tracking (:class:`~firmware_sim.sensors.playback.StartOnFirstRead`), and the walker
  stands at its end after it. So the receiver at module time T is where the walk's truth is
  T − S into the walk, S the module time of the walk's first sample; before a host started the
  module, at the walk's start; after its end, at its end. With ``--feet 2`` the receiver is on
  the body (the feet's midpoint, :func:`~firmware_sim.sensors.feet.body_truth`), and S is the first
  foot to start. Outages (``--gps-outage``, and a scenario's scripted one) count the walk's time,
  T − S (0 before the walk), as the batch ones do.
* **The reader.** The pty pairs as the module's do
  (:class:`~firmware_sim.transports.pty_endpoint.PtyEndpoint`), looked at when a sentence is due.
  Nothing waits for a reader: with none, the sentences are dropped; one that does not read gets
  up to :data:`BACKLOG_BYTES` queued, then new sentences are dropped — whole, never cut. Both are
  counted (:attr:`GpsPtyEndpoint.dropped_sentences`, in serve's status line). What a reader
  writes to the receiver is read and ignored.
* **Its cost.** A fix costs the pacer's thread about 0.2 ms (pymap3d and pynmea2), once a second
  of module time; both are imported before the loop starts (:meth:`WalkReceiver.prepare`).
"""

from __future__ import annotations

import errno
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TypeVar

import numpy as np

from firmware_sim.mcu.clock import Clock
from firmware_sim.mcu.module import Module
from firmware_sim.sensors.gps import (
    DEFAULT_ORIGIN,
    DEFAULT_START,
    GpsErrors,
    Receiver,
    nmea_lines,
    parse_outages,
    scenario_errors,
)
from firmware_sim.sensors.playback import StartOnFirstRead
from firmware_sim.transports.factory import SettingsError
from firmware_sim.transports.pty_endpoint import PtyEndpoint

__all__ = ["BACKLOG_BYTES", "GpsPtyEndpoint", "GpsSettings", "WalkReceiver", "gps_settings", "open_gps_pty"]

#: Sentence bytes a reader that does not read may have waiting (about 25 s of GGA and RMC).
BACKLOG_BYTES = 4096

T = TypeVar("T")


@dataclass(frozen=True)
class GpsSettings:
    """The receiver ``serve`` runs: its pty, where the scenario is on the globe, its errors."""

    pty: str
    origin: tuple[float, float, float] = DEFAULT_ORIGIN
    errors: GpsErrors = field(default_factory=GpsErrors)


def gps_settings(pty: str, origin: str | None, outages: Sequence[str]) -> GpsSettings:
    """``--gps-pty``, ``--origin`` and ``--gps-outage`` as settings; a SettingsError names the option."""
    from hostlib.aids.geodesy import parse_origin

    try:
        place = DEFAULT_ORIGIN if origin is None else parse_origin(origin)
    except ValueError as exc:
        raise SettingsError("{}: " + _escaped(exc), "origin") from None
    try:
        errors = GpsErrors(outages=parse_outages(outages))
    except ValueError as exc:
        raise SettingsError("{}: " + _escaped(exc), "gps_outage") from None
    return GpsSettings(pty, place, errors)


def _escaped(exc: Exception) -> str:
    return str(exc).replace("{", "{{").replace("}", "}}")


class WalkReceiver:
    """The receiver on a served walker: the sentences of every epoch the module's *clock* reached.

    *walks*: the served modules' scenario playback (its start is the walk's start); *t*, *pos*,
    *vel*: the walk's truth (sample times [s], NED position and velocity), as the scenario made it.
    """

    def __init__(self, clock: Clock, walks: Sequence[StartOnFirstRead], t: np.ndarray, pos: np.ndarray,
                 vel: np.ndarray, receiver: Receiver):
        self.clock = clock
        self.walks = list(walks)
        self.t = np.asarray(t, dtype=float)
        self.pos = np.asarray(pos, dtype=float)
        self.vel = np.asarray(vel, dtype=float)
        self.receiver = receiver
        self.epoch_cycles = round(clock.cpu_hz / receiver.errors.rate_hz)
        self._next = 0  #: cycle of the next epoch
        self.epochs = 0  #: epochs told so far

    def prepare(self) -> None:
        """Load what a fix needs (pymap3d, pynmea2) now, before the module's loop runs: a first
        import inside the loop would hold the module up for a tenth of a second."""
        import pymap3d  # noqa: F401
        import pynmea2  # noqa: F401

    def walk_start_s(self) -> float | None:
        """The module time [s] of the walk's first sample (None while no host started a module)."""
        starts = [w.start for w in self.walks if w.start is not None]
        return None if not starts else (min(starts) + 1) / self.clock.rate_hz

    def due(self) -> bool:
        """Whether the module's clock reached the next epoch."""
        return self.clock.now_cycles >= self._next

    def take_due(self) -> list[str]:
        """The sentences (without line ends) of every epoch the module's clock has reached."""
        out: list[str] = []
        errors = self.receiver.errors
        while self.clock.now_cycles >= self._next:
            out.extend(nmea_lines([self._fix(self._next / self.clock.cpu_hz)], DEFAULT_START, errors))
            self._next += self.epoch_cycles
            self.epochs += 1
        return out

    def _fix(self, t_module: float):
        start = self.walk_start_s()
        walked = 0.0 if start is None else max(0.0, t_module - start)
        i = min(int(np.searchsorted(self.t, self.t[0] + walked)), len(self.t) - 1)
        return self.receiver.fix(t_module, walked, self.pos[i], self.vel[i])


class _ReaderLine:
    """What the pty's pairing connects and disconnects: whether a reader holds the receiver's pty.
    Nothing flows through it (the endpoint writes the receiver's sentences itself)."""

    def __init__(self, receiver: WalkReceiver):
        self.receiver = receiver
        self.connected = False

    def connect(self) -> None:
        self.connected = True

    def disconnect(self) -> None:
        self.connected = False

    def host_read(self) -> bytes:
        return b""

    def host_write(self, data: bytes) -> int:
        return len(data)

    def host_pending(self) -> bool:
        """Whether a pump is worth it: an epoch is due (the pacer asks before pumping)."""
        return self.receiver.due()


class GpsPtyEndpoint(PtyEndpoint):
    """The receiver's sentences on a pty at *link_path* (module docstring: pairing, dropping)."""

    #: it carries nothing to the module: the module's lookahead ignores it (pacer.endpoints)
    to_module = False

    def __init__(self, receiver: WalkReceiver, link_path: str | os.PathLike[str],
                 backlog: int = BACKLOG_BYTES):
        self.receiver = receiver
        self.backlog = backlog
        self._tail = b""  # bytes of whole sentences not yet taken by the pty
        self.sentences = 0  #: sentences handed to a reader's pty
        #: sentences dropped: no reader, a full backlog, or queued for a reader that left
        self.dropped_sentences = 0
        super().__init__(_ReaderLine(receiver), link_path)

    def pump(self) -> None:
        if self.closed or not (self._tail or self.receiver.due()):
            return
        if self._follow_host() and self.paired:
            self._ignore_input()
        for line in self.receiver.take_due():
            data = (line + "\r\n").encode("ascii")
            if self.paired and len(self._tail) + len(data) <= self.backlog:
                self._tail += data
                self.sentences += 1
            else:
                self.dropped_sentences += 1
        if self.paired and self._tail:
            self._write_tail()

    def _on_master(self, io: Callable[[], T]) -> T | None:
        """``io()`` on the master; None when it would block, or when the reader left (EIO: then
        unpaired)."""
        try:
            return io()
        except BlockingIOError:
            return None
        except OSError as e:
            if e.errno != errno.EIO:
                raise
            self._hangup()
            return None

    def _ignore_input(self) -> None:
        """Read what the reader wrote (a receiver's configuration, say) and forget it."""
        for _ in range(16):
            data = self._on_master(lambda: os.read(self.master, 65536))
            if data is None or len(data) < 65536:
                return

    def _write_tail(self) -> None:
        sent = self._on_master(lambda: os.write(self.master, self._tail))
        if sent:
            self._tail = self._tail[sent:]

    def _hangup(self) -> None:
        lost = self._tail.count(b"\n")  # sentences queued for a reader that left
        self.sentences -= lost
        self.dropped_sentences += lost
        self._tail = b""
        super()._hangup()

    def status(self) -> dict[str, object]:
        return {"kind": "gps-pty", "path": str(self.link_path), "slave": self.slave_name,
                "paired": self.paired, "connects": self.connects, "sentences": self.sentences,
                "dropped_sentences": self.dropped_sentences}

    def status_line(self) -> str:
        return (f"gps {'on' if self.paired else 'off'}: {self.sentences} sentences, "
                f"{self.dropped_sentences} dropped (epoch {self.receiver.epochs})")

    def __repr__(self) -> str:
        return (f"GpsPtyEndpoint({self.link_path} -> {self.slave_name}, "
                f"{'paired' if self.paired else 'no reader'}, {self.dropped_sentences} sentences dropped)")


def _walk_of(module: Module) -> tuple[StartOnFirstRead, object]:
    """A served module's scenario playback and the scenario's truth."""
    played = getattr(module.sensors, "source", None)
    truth = getattr(getattr(played, "source", None), "truth", None)
    if not isinstance(played, StartOnFirstRead) or truth is None:
        raise ValueError("the GPS receiver follows a simulated walk: this module plays no scenario")
    return played, truth


def open_gps_pty(settings: GpsSettings, modules: Sequence[Module], scenario: str,
                 seed: int) -> GpsPtyEndpoint:
    """The receiver on the walker *modules* serve (one module, or a walker's left and right foot:
    then on the body), its errors and draws those of the batch receiver for *scenario* and *seed*,
    on the first module's clock, at ``settings.pty``."""
    from firmware_sim.sensors.feet import body_truth

    walks, truths = zip(*(_walk_of(m) for m in modules), strict=True)
    if len(truths) == 2:
        t, pos, vel, _yaw = body_truth(*truths)
    elif len(truths) == 1:
        t, pos, vel = truths[0].t, truths[0].pos, truths[0].vel
    else:
        raise ValueError(f"the GPS receiver is on one walker: one module or two feet, not {len(truths)}")
    errors = scenario_errors(settings.errors, scenario, t, pos)
    receiver = Receiver(settings.origin, errors, seed)
    walker = WalkReceiver(modules[0].clock, walks, t, pos, vel, receiver)
    walker.prepare()
    return GpsPtyEndpoint(walker, settings.pty)
