"""A simulated GPS receiver: 1 Hz fixes of the walker's true position, with a receiver's errors, as NMEA 0183.

A scenario is placed on the globe by an *origin* (latitude, longitude, altitude; WGS84): its
navigation frame (x north, y east, z down) is the tangent plane there, and a fix's geodetic
position comes from the true local position through ``pymap3d`` (exact on the ellipsoid).

Errors (:class:`GpsErrors`), as a consumer receiver has them in the open:

* a **slowly wandering offset** per axis, a first-order Gauss–Markov process with a time constant
  of minutes (multipath and atmosphere change as the satellites move): horizontal RMS a few
  metres, vertical about 1.7 times that. This is what makes fixes strongly correlated in time,
  and why a filter must inflate their covariance (aids.md §2);
* a small **white** part per fix (receiver noise);
* **outages**: intervals without a fix (under a roof, in a tunnel, or the whole rest of a walk).
  The receiver keeps talking: GGA with fix quality 0 and RMC with status ``V``, as real receivers
  do, so a host sees the missing fix rather than silence.

Every draw comes from one generator seeded by the run's seed, in a fixed order, so a fix file is
the same for the same scenario, seed and settings. :class:`Receiver` makes the fixes one epoch at a
time (``openshoe-emu serve --gps-pty``: as the module's clock reaches each), :func:`simulate_fixes`
over a whole walk with it. :func:`nmea_lines` writes GGA then RMC per
fix with ``pynmea2``; the UTC time is the scenario's time after *start* (a fixed default date, so
that runs are reproducible; the date matters for the magnetic model of a host).
"""

from __future__ import annotations

import datetime as dt
import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

__all__ = ["DEFAULT_ORIGIN", "DEFAULT_START", "GpsErrors", "Fix", "Receiver", "simulate_fixes", "nmea_lines",
           "write_nmea", "parse_outages", "outage_after_distance", "scenario_errors"]

#: Where a scenario is placed when no origin is given: KTH, Stockholm (where OpenShoe comes from).
DEFAULT_ORIGIN = (59.3498, 18.0707, 30.0)
#: UTC time of a scenario's t = 0 unless told otherwise.
DEFAULT_START = dt.datetime(2026, 6, 1, 10, 0, 0, tzinfo=dt.timezone.utc)
KNOTS_PER_M_S = 3600.0 / 1852.0


@dataclass(frozen=True)
class GpsErrors:
    """A receiver's error model (module docstring); lengths in metres, times in seconds."""

    horizontal_rms_m: float = 3.0  #: RMS of the wandering horizontal offset (both axes together)
    vertical_rms_m: float = 5.0
    correlation_s: float = 120.0  #: the offset's time constant
    white_m: float = 0.3  #: per-fix noise, per axis
    rate_hz: float = 1.0
    satellites: int = 9
    hdop: float = 0.9
    #: (start, end) [s] of the scenario's time without a fix
    outages: tuple[tuple[float, float], ...] = field(default_factory=tuple)

    def __post_init__(self) -> None:
        numbers = (self.horizontal_rms_m, self.vertical_rms_m, self.white_m)
        if min(numbers) < 0 or self.correlation_s <= 0 or self.rate_hz <= 0:
            raise ValueError("GPS errors: RMS values must be ≥ 0, the time constant and the rate > 0")
        for a, b in self.outages:
            if not b > a:
                raise ValueError(f"GPS outage ({a}, {b}): it must end after it starts")

    def in_outage(self, t: float) -> bool:
        return any(a <= t < b for a, b in self.outages)


@dataclass(frozen=True)
class Fix:
    """One epoch of the receiver."""

    t: float  #: scenario time [s]
    valid: bool  #: False during an outage (no position)
    ned: np.ndarray  #: (3,) the reported position in the scenario's frame [m] (NaN without a fix)
    true_ned: np.ndarray  #: (3,) where the walker really was
    lat_deg: float
    lon_deg: float
    alt_m: float
    speed_m_s: float  #: true ground speed (what the receiver's Doppler gives, near enough)
    course_deg: float  #: true course over ground, from north towards east


def parse_outages(texts: Sequence[str]) -> tuple[tuple[float, float], ...]:
    """``START:END`` [s] per item (END may be ``end``: to the end of the walk)."""
    out = []
    for text in texts:
        a, sep, b = text.partition(":")
        try:
            if not sep:
                raise ValueError
            out.append((float(a), math.inf if b.strip().lower() == "end" else float(b)))
        except ValueError:
            raise ValueError(f"a GPS outage is START:END in seconds (END may be 'end'), "
                             f"got {text!r}") from None
    return tuple(out)


def outage_after_distance(t: np.ndarray, pos: np.ndarray, metres: float) -> tuple[float, float]:
    """The outage (start, ∞) that begins once the walker at NED positions *pos* (times *t*) has gone
    *metres* horizontally (a scenario's ``Environment.gps_outage_after_m``)."""
    from .truth import walked_distance

    k = int(np.searchsorted(walked_distance(pos), metres))
    return (float(t[min(k, len(t) - 1)]), math.inf)


def scenario_errors(errors: GpsErrors, scenario: str, t: np.ndarray, pos: np.ndarray) -> GpsErrors:
    """*errors* with the outage the named *scenario* scripts, if any, added."""
    from .scenarios import environment

    after = environment(scenario).gps_outage_after_m
    if after is None:
        return errors
    return replace(errors, outages=(*errors.outages, outage_after_distance(t, pos, after)))


class Receiver:
    """The receiver's errors, epoch after epoch (module docstring): its draws in the same order
    whether the epochs are a batch (:func:`simulate_fixes`) or come one at a time as a served
    module's clock reaches them (``openshoe-emu serve --gps-pty``)."""

    def __init__(self, origin: Sequence[float] = DEFAULT_ORIGIN, errors: GpsErrors | None = None,
                 seed: int = 0):
        if len(origin) not in (2, 3):
            raise ValueError(f"origin is (latitude, longitude[, altitude]), got {origin!r}")
        self.origin = (*(float(v) for v in origin), 0.0)[:3]
        self.errors = errors = errors or GpsErrors()
        self._rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x6795]))  # its own stream
        self._sigma = np.array([errors.horizontal_rms_m / math.sqrt(2)] * 2 + [errors.vertical_rms_m])
        self._phi = math.exp(-1.0 / (errors.rate_hz * errors.correlation_s))
        self._offset = self._sigma * self._rng.standard_normal(3)  # drawn from the stationary distribution
        self._epochs = 0

    def fix(self, t: float, walked_s: float, true_ned: np.ndarray, vel: np.ndarray) -> Fix:
        """The fix of the next epoch, at time *t* [s] (its UTC is ``start + t``), *walked_s* seconds
        into the walk (what the outages count), the walker at NED *true_ned* moving at *vel*."""
        import pymap3d

        errors, sigma, phi, rng = self.errors, self._sigma, self._phi, self._rng
        if self._epochs:
            self._offset = phi * self._offset + math.sqrt(1 - phi * phi) * sigma * rng.standard_normal(3)
        self._epochs += 1
        white = errors.white_m * rng.standard_normal(3)
        true = np.asarray(true_ned, dtype=float)
        v = np.asarray(vel, dtype=float)
        speed = float(math.hypot(v[0], v[1]))
        course = float(math.degrees(math.atan2(v[1], v[0])) % 360.0)
        if errors.in_outage(walked_s):
            nan = np.full(3, np.nan)
            return Fix(t, False, nan, true, math.nan, math.nan, math.nan, speed, course)
        ned = true + self._offset + white
        lat, lon, alt = pymap3d.ned2geodetic(ned[0], ned[1], ned[2], *self.origin)
        return Fix(t, True, ned, true, float(lat), float(lon), float(alt), speed, course)


def simulate_fixes(t: np.ndarray, pos: np.ndarray, vel: np.ndarray, origin: Sequence[float] = DEFAULT_ORIGIN,
                   errors: GpsErrors | None = None, seed: int = 0) -> list[Fix]:
    """The receiver's fixes over a walk sampled at times *t* (s) with true NED positions *pos* and
    velocities *vel* (the scenario's ground truth), one per 1/rate s from t[0]."""
    receiver = Receiver(origin, errors, seed)
    t = np.asarray(t, dtype=float)
    epochs = np.arange(t[0], t[-1] + 1e-9, 1.0 / receiver.errors.rate_hz)
    idx = np.clip(np.searchsorted(t, epochs), 0, len(t) - 1)
    return [receiver.fix(float(epoch), float(epoch - t[0]), pos[i], vel[i])
            for epoch, i in zip(epochs, idx, strict=True)]


def _ddmm(value: float, degree_digits: int, hemispheres: str) -> tuple[str, str]:
    """|value| as NMEA ``(d)ddmm.mmmmm``, and its hemisphere: ``hemispheres[0]`` (e.g. N) when
    positive, ``hemispheres[1]`` (S) when negative."""
    a = abs(value)
    deg = int(a)
    minutes = round((a - deg) * 60.0, 5)
    if minutes >= 60.0:
        deg, minutes = deg + 1, 0.0
    return f"{deg:0{degree_digits}d}{minutes:08.5f}", hemispheres[value < 0]


def nmea_lines(fixes: Sequence[Fix], start: dt.datetime = DEFAULT_START,
               errors: GpsErrors | None = None) -> Iterator[str]:
    """GGA then RMC per fix (talker ``GP``), each a complete sentence with its checksum."""
    import pynmea2

    errors = errors or GpsErrors()
    for fix in fixes:
        when = start + dt.timedelta(seconds=fix.t)
        hhmmss = when.strftime("%H%M%S") + f".{when.microsecond // 10000:02d}"
        ddmmyy = when.strftime("%d%m%y")
        if fix.valid:
            lat, ns = _ddmm(fix.lat_deg, 2, "NS")
            lon, ew = _ddmm(fix.lon_deg, 3, "EW")
            gga = (hhmmss, lat, ns, lon, ew, "1", f"{errors.satellites:02d}", f"{errors.hdop:.1f}",
                   f"{fix.alt_m:.2f}", "M", "0.0", "M", "", "")
            rmc = (hhmmss, "A", lat, ns, lon, ew, f"{fix.speed_m_s * KNOTS_PER_M_S:.2f}",
                   f"{fix.course_deg:.1f}", ddmmyy, "", "", "A")
        else:
            gga = (hhmmss, "", "", "", "", "0", "00", "", "", "M", "", "M", "", "")
            rmc = (hhmmss, "V", "", "", "", "", "", "", ddmmyy, "", "", "N")
        yield str(pynmea2.GGA("GP", "GGA", gga))
        yield str(pynmea2.RMC("GP", "RMC", rmc))


def write_nmea(path: str | Path, fixes: Sequence[Fix], start: dt.datetime = DEFAULT_START,
               errors: GpsErrors | None = None) -> Path:
    """The sentences of :func:`nmea_lines`, one per line ending in CR LF as on the wire."""
    path = Path(path)
    with path.open("w", newline="") as f:
        for line in nmea_lines(fixes, start, errors):
            f.write(line + "\r\n")
    return path
