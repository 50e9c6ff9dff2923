"""GPS fixes for the host: NMEA 0183 read with ``pynmea2``, placed in the track's frame with ``pymap3d``.

A receiver (a serial device, or a file of its sentences) talks GGA and RMC. :class:`NmeaReader`
takes its lines one at a time, as they arrive, and gives a :class:`GpsFix` for every GGA with a
position. Nothing it meets stops it, and nothing is lost without being counted
(:class:`NmeaStats`):

* a line that is not a sentence, or whose checksum is wrong, is **garbled**: skipped and counted,
  and the first few are kept with their line numbers for the report;
* a GGA with fix quality 0 (the receiver has no position) is a **missing fix**: counted;
* other sentences (RMC, GSA, GSV, …) are counted as **other**; RMC's date is kept, so fixes get a
  full UTC time once the receiver has said the date.

A receiver read live, as its sentences come, is :mod:`hostlib.run.gps_stream`.

:func:`read_nmea` reads a whole file (:func:`fixes_of_log` refuses one without a fix:
:class:`GpsLogError`); :func:`local_positions` turns fixes into north, east, down
metres about an origin (the first fix's position unless given), the frame a host fuses them in.
"""

from __future__ import annotations

import datetime as dt
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..inputs import InputFileError, read_input

__all__ = ["GpsFix", "GpsLogError", "NmeaStats", "NmeaReader", "fix_place", "fixes_of_log", "read_nmea",
           "local_positions", "seconds_since"]

#: Garbled lines kept (with their numbers) for the report; the rest are only counted.
KEEP_GARBLED = 10


class GpsLogError(InputFileError):
    """A GPS log that cannot be read, or that holds no fix; the message names the file."""


@dataclass(frozen=True)
class GpsFix:
    """A position the receiver gave."""

    line: int  #: line number of its GGA (1-based)
    time: dt.time  #: UTC time of day
    date: dt.date | None  #: UTC date, once an RMC has said it
    lat_deg: float
    lon_deg: float
    alt_m: float  #: above mean sea level, as GGA reports it
    quality: int  #: GGA fix quality (1 GPS, 2 DGPS, …)
    satellites: int
    hdop: float  #: NaN when not given

    @property
    def utc(self) -> dt.datetime | None:
        """Date and time, when the date is known."""
        if self.date is None:
            return None
        return dt.datetime.combine(self.date, self.time).replace(tzinfo=dt.timezone.utc)


@dataclass
class NmeaStats:
    """What a reader met."""

    lines: int = 0
    fixes: int = 0
    missing_fix: int = 0
    garbled: int = 0
    other: int = 0
    #: (line number, reason) of the first :data:`KEEP_GARBLED` garbled lines
    garbled_lines: list[tuple[int, str]] = field(default_factory=list)
    #: UTC time of day of the first GGA, with a fix or not: when the receiver started talking
    first_time: dt.time | None = None

    def summary(self) -> str:
        first = "; first: " + ", ".join(f"line {n} ({why})" for n, why in self.garbled_lines[:3]) \
            if self.garbled_lines else ""
        return (f"{self.lines} NMEA lines: {self.fixes} fixes, {self.missing_fix} without a fix, "
                f"{self.garbled} garbled (skipped){first}, {self.other} other sentences")


class NmeaReader:
    """Lines in, fixes out (module docstring); no I/O of its own."""

    def __init__(self) -> None:
        self.stats = NmeaStats()
        self._date: dt.date | None = None

    @property
    def date(self) -> dt.date | None:
        """The UTC date the receiver said last (RMC); None before it said one."""
        return self._date

    def _garbled(self, why: str) -> None:
        self.stats.garbled += 1
        if len(self.stats.garbled_lines) < KEEP_GARBLED:
            self.stats.garbled_lines.append((self.stats.lines, why))

    def feed(self, line: str | bytes) -> GpsFix | None:
        """One line (with or without its line end); the fix it carries, if any."""
        import pynmea2

        self.stats.lines += 1
        if isinstance(line, bytes):
            line = line.decode("ascii", errors="replace")
        text = line.strip()
        if not text:
            self._garbled("empty line")
            return None
        try:
            msg = pynmea2.parse(text, check=True)
        except pynmea2.ChecksumError:
            self._garbled("bad checksum")
            return None
        except (pynmea2.ParseError, ValueError, AttributeError, TypeError):
            self._garbled("not an NMEA sentence")
            return None
        kind = getattr(msg, "sentence_type", "")
        if kind == "RMC":
            date = _field(msg, "datestamp")
            self._date = date if isinstance(date, dt.date) else self._date
            self.stats.other += 1
            return None
        if kind != "GGA":
            self.stats.other += 1
            return None
        return self._gga(msg)

    def _gga(self, msg) -> GpsFix | None:
        stamp = _field(msg, "timestamp")
        if self.stats.first_time is None and isinstance(stamp, dt.time):
            self.stats.first_time = stamp.replace(tzinfo=None)
        try:
            quality = int(msg.gps_qual or 0)
            if quality == 0:
                self.stats.missing_fix += 1
                return None
            lat, lon = float(msg.latitude), float(msg.longitude)
            alt = float(msg.altitude) if msg.altitude not in (None, "") else math.nan
            sats = int(msg.num_sats or 0)
            hdop = float(msg.horizontal_dil) if msg.horizontal_dil else math.nan
            if not (isinstance(stamp, dt.time) and msg.lat_dir in ("N", "S") and msg.lon_dir in ("E", "W")
                    and abs(lat) <= 90.0 and abs(lon) <= 180.0 and not math.isinf(alt)):
                raise ValueError("no time, no hemisphere, or a place off the globe")
        except (TypeError, ValueError, AttributeError, OverflowError):
            self._garbled("GGA fields out of form")
            return None
        self.stats.fixes += 1
        return GpsFix(self.stats.lines, stamp.replace(tzinfo=None), self._date, lat, lon, alt, quality, sats,
                      hdop)

    def feed_all(self, lines: Iterable[str | bytes]) -> list[GpsFix]:
        return [fix for fix in map(self.feed, lines) if fix is not None]


def _field(msg: object, name: str) -> object:
    """A field of a parsed sentence, or None when it is not there or out of form (pynmea2 parses a
    field when it is read, and a bad one raises, or comes back as its text)."""
    try:
        return getattr(msg, name, None)
    except (TypeError, ValueError, IndexError, OverflowError):
        return None


def seconds_since(start: dt.time, fixes: Sequence[GpsFix]) -> np.ndarray:
    """(n,) seconds from the time of day *start* to each fix (across midnight: a walk is shorter
    than a day)."""
    def seconds(t: dt.time) -> float:
        return t.hour * 3600.0 + t.minute * 60.0 + t.second + t.microsecond * 1e-6

    t0 = seconds(start)
    return np.array([(seconds(f.time) - t0) % 86400.0 for f in fixes], dtype=np.float64)


def fix_place(fix: GpsFix) -> tuple[float, float, float]:
    """Latitude, longitude and altitude (0 when the receiver gave none) of *fix*: the geographic
    origin a first fix gives a track."""
    return fix.lat_deg, fix.lon_deg, fix.alt_m if math.isfinite(fix.alt_m) else 0.0


def read_nmea(path: str | Path) -> tuple[list[GpsFix], NmeaStats]:
    """Every fix in a file of NMEA sentences, and what the reader met. A file that cannot be read
    (no such file, a directory, a device: a receiver is read live, :mod:`hostlib.run.gps_stream`) is
    refused with a :class:`GpsLogError` naming it; what it holds is never refused, only counted."""
    reader = NmeaReader()
    try:
        fixes = reader.feed_all(read_input(path, "GPS log").splitlines(keepends=True))  # a pipe too
    except InputFileError as exc:
        raise GpsLogError(str(exc)) from None
    except OSError as exc:
        raise GpsLogError(f"{path}: cannot read the GPS log: {exc.strerror or exc}") from None
    return fixes, reader.stats


def fixes_of_log(path: str | Path) -> tuple[list[GpsFix], NmeaStats]:
    """:func:`read_nmea`, refusing a log without a fix (:class:`GpsLogError`, saying what its
    lines were and the first garbled ones with their line numbers)."""
    fixes, stats = read_nmea(path)
    if not fixes:
        raise GpsLogError(f"{path}: no GPS fix in {stats.lines} lines ({stats.summary()})")
    return fixes, stats


def local_positions(fixes: Sequence[GpsFix], origin: Sequence[float] | None = None) -> np.ndarray:
    """(n, 3) north, east, down [m] of *fixes* about *origin* (lat, lon[, alt]; default the first fix)."""
    import pymap3d

    from .geodesy import parse_origin

    if not fixes:
        return np.zeros((0, 3))
    lat0, lon0, h0 = parse_origin(origin if origin is not None else
                                  (fixes[0].lat_deg, fixes[0].lon_deg, fixes[0].alt_m))
    lat = np.array([f.lat_deg for f in fixes])
    lon = np.array([f.lon_deg for f in fixes])
    alt = np.array([f.alt_m for f in fixes])
    n, e, d = pymap3d.geodetic2ned(lat, lon, alt, lat0, lon0, h0)
    return np.stack([n, e, d], axis=-1)
