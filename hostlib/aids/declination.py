"""Magnetic declination from the World Magnetic Model, where and when the walk is (``pygeomag``).

A compass measures heading relative to magnetic north; the track's heading is relative to true
north; the difference is the declination D (east positive). A host takes its first value from the
World Magnetic Model at the first GPS fix and the date (:func:`declination_deg`), then refines it
as a filter state while GPS makes it observable (aids.md §1–2). The model's coefficients are the
ones ``pygeomag`` ships; none are typed in here.
"""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass

__all__ = ["MagneticField", "decimal_year", "magnetic_field", "declination_deg"]


@dataclass(frozen=True)
class MagneticField:
    """The model's field at a place and time."""

    declination_deg: float  #: D, east of true north positive
    inclination_deg: float  #: I, down positive
    total_nt: float  #: F [nT]
    horizontal_nt: float  #: H [nT]


def decimal_year(when: dt.date | dt.datetime) -> float:
    """*when* as a year with its fraction (2026-07-02 ≈ 2026.5), as the model takes time."""
    if isinstance(when, dt.datetime):
        start = dt.datetime(when.year, 1, 1, tzinfo=when.tzinfo)
        end = dt.datetime(when.year + 1, 1, 1, tzinfo=when.tzinfo)
        return when.year + (when - start) / (end - start)
    start, end = dt.date(when.year, 1, 1), dt.date(when.year + 1, 1, 1)
    return when.year + (when - start).days / (end - start).days


def magnetic_field(lat_deg: float, lon_deg: float, alt_m: float,
                   when: dt.date | dt.datetime) -> MagneticField:
    """The World Magnetic Model's field; a ``ValueError`` when *when* is outside the model's lifespan."""
    from pygeomag import GeoMag

    try:
        r = GeoMag().calculate(glat=float(lat_deg), glon=float(lon_deg), alt=float(alt_m) / 1000.0,
                               time=decimal_year(when))
    except Exception as e:  # noqa: BLE001 - pygeomag raises plain exceptions for dates out of range
        raise ValueError(f"no magnetic model for {when:%Y-%m-%d} at {lat_deg:.4f},{lon_deg:.4f}: "
                         f"{e}") from None
    return MagneticField(float(r.d), float(r.i), float(r.f), float(r.h))


def declination_deg(lat_deg: float, lon_deg: float, alt_m: float, when: dt.date | dt.datetime) -> float:
    """D [deg], east positive, at a place and time (:func:`magnetic_field`)."""
    return magnetic_field(lat_deg, lon_deg, alt_m, when).declination_deg
