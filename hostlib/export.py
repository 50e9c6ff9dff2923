"""Writing tracks out: CSV (every pose with its covariance) and GeoJSON (for maps).

Frames. The module's navigation frame is **x north, y east, z down** (NED),
heading χ from north towards east. GeoJSON and most GIS tools want east, north,
up, so the local export maps ``(x, y, z) → (east, north, up) = (y, x, −z)``.

Geographic export. Given an *origin* (latitude, longitude [deg], altitude [m],
WGS84) the local offsets are turned into longitude/latitude with the local
flat-earth (tangent-plane) approximation on the WGS84 ellipsoid::

    R_N = a / sqrt(1 − e² sin²φ₀)              (prime vertical radius)
    R_M = a (1 − e²) / (1 − e² sin²φ₀)^{3/2}   (meridian radius)
    φ = φ₀ + north / (R_M + h₀),  λ = λ₀ + east / ((R_N + h₀) cos φ₀),  h = h₀ + up

Its error grows with the square of the distance from the origin: below a
millimetre within 1 km, a few centimetres within 10 km — far below a
foot-mounted system's drift. It is not valid near the poles (cos φ₀ → 0).
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .tracking import Track

__all__ = [
    "CSV_COLUMNS",
    "enu_to_geodetic",
    "geodetic_to_enu",
    "read_csv",
    "read_geojson",
    "to_geojson",
    "write_csv",
    "write_geojson",
]

#: WGS84 semi-major axis [m] and first eccentricity squared.
WGS84_A = 6378137.0
WGS84_E2 = 6.69437999014e-3

_COV_NAMES = ("x", "y", "z", "chi")
#: CSV columns: row 0 is the initial pose (no step); positions [m], angles [rad].
CSV_COLUMNS: tuple[str, ...] = (
    "index", "counter", "x_north_m", "y_east_m", "z_down_m", "heading_rad",
    "dx_m", "dy_m", "dz_m", "dpsi_rad",
    *(f"P_{_COV_NAMES[r]}_{_COV_NAMES[c]}" for r in range(4) for c in range(r, 4)),
)
_TRIU = np.triu_indices(4)


def _f(v: float) -> str:
    return repr(float(v))  # shortest exact round trip


def write_csv(track: Track, path: str | Path) -> None:
    """Write every pose of *track* (initial pose first) with its 4×4 covariance (upper triangle).

    Row 0 is the initial pose; its ``counter`` is the counter before the first
    step (0 after 0x34, empty when unknown), so gaps can be recomputed on reading.
    """
    poses, covs, steps, counters = track.poses, track.covariances, track.steps, track.counters
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(CSV_COLUMNS)
        for k in range(len(poses)):
            step = [""] * 4 if k == 0 else [_f(v) for v in steps[k - 1]]
            if k == 0:
                counter = "" if track.start_counter is None else str(track.start_counter)
            else:
                counter = str(int(counters[k - 1]))
            w.writerow([k, counter, *(_f(v) for v in poses[k]), *step, *(_f(v) for v in covs[k][_TRIU])])


def read_csv(path: str | Path) -> Track:
    """Read a track written by :func:`write_csv`; a bad line is refused with its line number."""
    poses, covs, steps, counters = [], [], [], []
    start: int | None = None
    with open(path, newline="") as fh:
        r = csv.reader(fh)
        header = next(r, None)
        if header is None or tuple(header) != CSV_COLUMNS:
            raise ValueError(
                f"{path}: line 1: not an OpenShoe track CSV (expected columns {CSV_COLUMNS[:6]}…)"
            )
        for lineno, row in enumerate(r, start=2):
            try:
                if len(row) != len(CSV_COLUMNS):
                    raise ValueError(f"expected {len(CSV_COLUMNS)} fields, got {len(row)}")
                if int(row[0]) != len(poses):
                    raise ValueError(f"index {row[0]} out of sequence (expected {len(poses)})")
                poses.append([float(v) for v in row[2:6]])
                cov = np.zeros((4, 4))
                cov[_TRIU] = [float(v) for v in row[10:20]]
                covs.append(cov + np.triu(cov, 1).T)
                if len(poses) == 1:
                    start = int(row[1]) if row[1] else None
                else:
                    counters.append(int(row[1]))
                    steps.append([float(v) for v in row[6:10]])
            except ValueError as exc:
                raise ValueError(f"{path}: line {lineno}: {exc}") from None
    if not poses:
        raise ValueError(f"{path}: no initial pose row")
    return Track.from_arrays(np.array(poses), np.array(covs), np.array(steps).reshape(-1, 4), counters, start)


# -- coordinates ---------------------------------------------------------------------------


def ned_to_enu(xyz: np.ndarray) -> np.ndarray:
    """(…, 3) north, east, down → east, north, up."""
    xyz = np.asarray(xyz, dtype=np.float64)
    return np.stack([xyz[..., 1], xyz[..., 0], -xyz[..., 2]], axis=-1)


def enu_to_ned(enu: np.ndarray) -> np.ndarray:
    enu = np.asarray(enu, dtype=np.float64)
    return np.stack([enu[..., 1], enu[..., 0], -enu[..., 2]], axis=-1)


def _radii(lat0_deg: float) -> tuple[float, float]:
    s = math.sin(math.radians(lat0_deg))
    w = 1.0 - WGS84_E2 * s * s
    return WGS84_A * (1.0 - WGS84_E2) / w**1.5, WGS84_A / math.sqrt(w)  # R_M, R_N


def enu_to_geodetic(enu: np.ndarray, origin: Sequence[float]) -> np.ndarray:
    """(…, 3) local east, north, up [m] → longitude, latitude [deg], altitude [m] (flat-earth WGS84)."""
    lat0, lon0, h0 = _origin(origin)
    if abs(lat0) > 89.0:
        raise ValueError(f"origin latitude {lat0}° is too close to a pole for the local approximation")
    rm, rn = _radii(lat0)
    enu = np.asarray(enu, dtype=np.float64)
    lat = lat0 + np.degrees(enu[..., 1] / (rm + h0))
    lon = lon0 + np.degrees(enu[..., 0] / ((rn + h0) * math.cos(math.radians(lat0))))
    return np.stack([lon, lat, h0 + enu[..., 2]], axis=-1)


def geodetic_to_enu(lonlath: np.ndarray, origin: Sequence[float]) -> np.ndarray:
    """Inverse of :func:`enu_to_geodetic`."""
    lat0, lon0, h0 = _origin(origin)
    rm, rn = _radii(lat0)
    g = np.asarray(lonlath, dtype=np.float64)
    north = np.radians(g[..., 1] - lat0) * (rm + h0)
    east = np.radians(g[..., 0] - lon0) * (rn + h0) * math.cos(math.radians(lat0))
    return np.stack([east, north, g[..., 2] - h0], axis=-1)


def _origin(origin: Sequence[float]) -> tuple[float, float, float]:
    o = [float(v) for v in origin]
    if len(o) not in (2, 3):
        raise ValueError(f"origin is (latitude, longitude[, altitude]), got {origin!r}")
    return o[0], o[1], (o[2] if len(o) == 3 else 0.0)


# -- GeoJSON -------------------------------------------------------------------------------


def to_geojson(track: Track, origin: Sequence[float] | None = None, *, points: bool = True) -> dict[str, Any]:
    """The track as a GeoJSON FeatureCollection: a LineString, and a Point per pose.

    Without *origin* the coordinates are local ENU metres ``[east, north, up]``
    relative to the track's frame origin (``properties.crs = "local-enu-m"``);
    with *origin* = (lat, lon[, alt]) they are ``[lon, lat, alt]`` (WGS84).
    Each Point carries its index, step counter, heading and 1σ values.
    """
    enu = ned_to_enu(track.positions)
    coords = enu if origin is None else enu_to_geodetic(enu, origin)
    coords_l = [[float(v) for v in c] for c in coords]
    sig = track.sigmas
    counters = track.counters
    line_props: dict[str, Any] = {
        "kind": "track",
        "steps": len(track),
        "distance_m": track.distance,
        "missing_steps": track.missing,
        "crs": "local-enu-m" if origin is None else "wgs84-lonlat",
    }
    if origin is not None:
        lat0, lon0, h0 = _origin(origin)
        line_props["origin"] = {"lat": lat0, "lon": lon0, "alt": h0}
    features: list[dict[str, Any]] = [
        {
            "type": "Feature",
            "geometry": {"type": "LineString", "coordinates": coords_l},
            "properties": line_props,
        }
    ]
    if points:
        for k, c in enumerate(coords_l):
            features.append({
                "type": "Feature",
                "geometry": {"type": "Point", "coordinates": c},
                "properties": {
                    "kind": "pose",
                    "index": k,
                    "counter": None if k == 0 else int(counters[k - 1]),
                    "heading_rad": float(track.headings[k]),
                    "sigma_north_m": float(sig[k, 0]),
                    "sigma_east_m": float(sig[k, 1]),
                    "sigma_down_m": float(sig[k, 2]),
                    "sigma_heading_rad": float(sig[k, 3]),
                },
            })
    return {"type": "FeatureCollection", "features": features}


def write_geojson(track: Track, path: str | Path, origin: Sequence[float] | None = None) -> None:
    """Write :func:`to_geojson` to *path*."""
    with open(path, "w") as fh:
        json.dump(to_geojson(track, origin), fh, indent=1)


def read_geojson(path: str | Path) -> tuple[np.ndarray, np.ndarray | None]:
    """Positions (n+1, 3) north, east, down [m] and headings (n+1,) back from :func:`write_geojson`.

    Geographic files are converted back with the origin stored in the file.
    Headings are None when the file has no pose points.
    """
    with open(path) as fh:
        doc = json.load(fh)
    try:
        feats = doc["features"]
        line = next(f for f in feats if f["properties"].get("kind") == "track")
        props = line["properties"]
        coords = np.array(line["geometry"]["coordinates"], dtype=np.float64).reshape(-1, 3)
    except (KeyError, StopIteration, TypeError, ValueError) as exc:
        raise ValueError(f"{path}: not an OpenShoe track GeoJSON ({exc!r})") from None
    if props.get("crs") == "wgs84-lonlat":
        o = props["origin"]
        coords = geodetic_to_enu(coords, (o["lat"], o["lon"], o["alt"]))
    poses = [f for f in feats if f["properties"].get("kind") == "pose"]
    headings = None
    if poses:
        poses.sort(key=lambda p: p["properties"]["index"])
        headings = np.array([p["properties"]["heading_rad"] for p in poses])
    return enu_to_ned(coords), headings
