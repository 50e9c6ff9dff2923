"""Geodesy for the aids: local north-east-down and east-north-up frames, and WGS84 places (pymap3d).

A track is kept in metres about its origin, x north, y east, z down; GPS fixes, GeoJSON and the
World Magnetic Model speak latitude, longitude and altitude. These functions convert between them
about an origin given as ``LAT,LON[,ALT]`` (:func:`parse_origin`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

__all__ = ["enu_to_geodetic", "enu_to_ned", "geodetic_to_enu", "ned_to_enu", "parse_origin"]


def ned_to_enu(xyz: np.ndarray) -> np.ndarray:
    """(…, 3) north, east, down → east, north, up."""
    xyz = np.asarray(xyz, dtype=np.float64)
    return np.stack([xyz[..., 1], xyz[..., 0], -xyz[..., 2]], axis=-1)


def enu_to_ned(enu: np.ndarray) -> np.ndarray:
    enu = np.asarray(enu, dtype=np.float64)
    return np.stack([enu[..., 1], enu[..., 0], -enu[..., 2]], axis=-1)


def enu_to_geodetic(enu: np.ndarray, origin: Sequence[float]) -> np.ndarray:
    """(…, 3) local east, north, up [m] → longitude, latitude [deg], altitude [m] (WGS84, pymap3d)."""
    import pymap3d

    lat0, lon0, h0 = parse_origin(origin)
    enu = np.asarray(enu, dtype=np.float64)
    lat, lon, alt = pymap3d.enu2geodetic(enu[..., 0], enu[..., 1], enu[..., 2], lat0, lon0, h0)
    return np.stack(np.broadcast_arrays(lon, lat, alt), axis=-1)


def geodetic_to_enu(lonlath: np.ndarray, origin: Sequence[float]) -> np.ndarray:
    """Inverse of :func:`enu_to_geodetic`."""
    import pymap3d

    lat0, lon0, h0 = parse_origin(origin)
    g = np.asarray(lonlath, dtype=np.float64)
    e, n, u = pymap3d.geodetic2enu(g[..., 1], g[..., 0], g[..., 2], lat0, lon0, h0)
    return np.stack(np.broadcast_arrays(e, n, u), axis=-1)


def parse_origin(origin: Sequence[float] | str) -> tuple[float, float, float]:
    """(latitude, longitude, altitude) from a sequence of 2 or 3 numbers or ``"LAT,LON[,ALT]"``
    (altitude 0 when left out); a ``ValueError`` naming the form otherwise."""
    try:
        o = [float(v) for v in (origin.split(",") if isinstance(origin, str) else origin)]
    except (TypeError, ValueError):
        o = []
    if len(o) not in (2, 3) or not all(math.isfinite(v) for v in o) or abs(o[0]) > 90 or abs(o[1]) > 180:
        raise ValueError(f"origin is LAT,LON[,ALT] in degrees and metres (|LAT| ≤ 90, |LON| ≤ 180), "
                         f"got {origin!r}")
    return o[0], o[1], (o[2] if len(o) == 3 else 0.0)
