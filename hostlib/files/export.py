"""Writing tracks out: CSV (every pose with its covariance) and GeoJSON (for maps).

Frames. The module's navigation frame is **x north, y east, z down** (NED),
heading χ from north towards east. GeoJSON and most GIS tools want east, north,
up, so the local export maps ``(x, y, z) → (east, north, up) = (y, x, −z)``.

Geographic export. Given an *origin* (latitude, longitude [deg], altitude [m],
WGS84) the local offsets are east, north, up in the tangent plane at the origin,
and are turned into longitude, latitude and altitude on the WGS84 ellipsoid
exactly (through Earth-centred coordinates) by ``pymap3d``; GPS fixes come in
the other way (:mod:`hostlib.aids.gps`) through the same functions.

Two feet. A walker's two modules fused (:mod:`hostlib.fusion.feet`) give one CSV: the body track (the
feet's midpoint) and its covariance in the usual columns, each row followed by
:data:`FEET_COLUMNS` — which foot made the row's step and both feet's fused poses with their 1σ
(:func:`write_feet_csv`, :func:`read_feet_csv`); :func:`read_csv` reads its body track.
"""

from __future__ import annotations

import csv
import json
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from protocol.board import FOOT_SIDES

from ..aids.geodesy import enu_to_geodetic, enu_to_ned, geodetic_to_enu, ned_to_enu, parse_origin
from ..track.steps import Track

__all__ = [
    "CSV_COLUMNS",
    "FEET_COLUMNS",
    "GEO_COLUMNS",
    "FeetTrack",
    "enu_to_geodetic",
    "geodetic_to_enu",
    "parse_origin",
    "read_csv",
    "read_feet_csv",
    "read_geojson",
    "to_geojson",
    "write_csv",
    "write_feet_csv",
    "write_geojson",
]

_COV_NAMES = ("x", "y", "z", "chi")
#: CSV columns: row 0 is the initial pose (no step); positions [m], angles [rad].
CSV_COLUMNS: tuple[str, ...] = (
    "index", "counter", "x_north_m", "y_east_m", "z_down_m", "heading_rad",
    "dx_m", "dy_m", "dz_m", "dpsi_rad",
    *(f"P_{_COV_NAMES[r]}_{_COV_NAMES[c]}" for r in range(4) for c in range(r, 4)),
)
#: Extra CSV columns of a track placed on the globe (WGS84, from the origin of its frame).
GEO_COLUMNS: tuple[str, ...] = ("lat_deg", "lon_deg", "alt_m")
_TRIU = np.triu_indices(4)


def _f(v: float) -> str:
    return repr(float(v))  # shortest exact round trip


def write_csv(track: Track, path: str | Path, origin: Sequence[float] | None = None) -> None:
    """Write every pose of *track* (initial pose first) with its 4×4 covariance (upper triangle).

    Row 0 is the initial pose; its ``counter`` is the counter before the first
    step (0 after 0x34, empty when unknown), so gaps can be recomputed on reading.
    With *origin* (lat, lon[, alt] of the frame's origin) every row also gets
    :data:`GEO_COLUMNS`, the pose on the WGS84 ellipsoid.
    """
    if origin is None:
        _write_track_rows(track, path)
        return
    geo = enu_to_geodetic(ned_to_enu(track.positions), origin)
    _write_track_rows(track, path, GEO_COLUMNS, ([_f(g[1]), _f(g[0]), _f(g[2])] for g in geo))


def _write_track_rows(track: Track, path: str | Path, extra_columns: tuple[str, ...] = (),
                      extra: Iterable[list[str]] = ()) -> None:
    """:data:`CSV_COLUMNS` of every pose of *track*, then *extra_columns* (one list of fields per
    pose in *extra*)."""
    poses, covs, steps, counters = track.poses, track.covariances, track.steps, track.counters
    extra_rows = iter(extra)
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(CSV_COLUMNS + extra_columns)
        for k in range(len(poses)):
            step = [""] * 4 if k == 0 else [_f(v) for v in steps[k - 1]]
            if k == 0:
                counter = "" if track.start_counter is None else str(track.start_counter)
            else:
                counter = str(int(counters[k - 1]))
            w.writerow([k, counter, *(_f(v) for v in poses[k]), *step, *(_f(v) for v in covs[k][_TRIU]),
                        *next(extra_rows, ())])


def read_csv(path: str | Path) -> Track:
    """Read a track written by :func:`write_csv` (or the body track of :func:`write_feet_csv`);
    a bad line, in any of its columns, is refused with its line number."""
    return _read_track_rows(path)[0]


def _read_track_rows(path: str | Path, *extra_columns: tuple[str, ...]) -> tuple[Track, list[Any]]:
    """The track in :data:`CSV_COLUMNS` of a track CSV whose further columns are those of
    :data:`_EXTRA_COLUMNS` (with *extra_columns*, exactly one of those), and each row's further fields
    parsed by their parser there (row 0: the initial pose)."""
    poses, covs, steps, counters, extras = [], [], [], [], []
    start: int | None = None
    n = len(CSV_COLUMNS)
    with open(path, newline="") as fh:
        r = csv.reader(fh)
        header = next(r, None)
        if header is None or tuple(header[:n]) != CSV_COLUMNS or tuple(header[n:]) not in _EXTRA_COLUMNS:
            raise ValueError(
                f"{path}: line 1: not an OpenShoe track CSV (expected columns {CSV_COLUMNS[:6]}…)"
            )
        if extra_columns and tuple(header[n:]) not in extra_columns:
            raise ValueError(f"{path}: line 1: no columns {extra_columns[0][:3]}… (expected after "
                             f"{CSV_COLUMNS[-1]!r})")
        width = len(header)
        parse_extra = _EXTRA_COLUMNS[tuple(header[n:])]
        for lineno, row in enumerate(r, start=2):
            try:
                if len(row) != width:
                    raise ValueError(f"expected {width} fields, got {len(row)}")
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
                extras.append(parse_extra(row[n:], len(poses) - 1))
            except ValueError as exc:
                raise ValueError(f"{path}: line {lineno}: {exc}") from None
    if not poses:
        raise ValueError(f"{path}: no initial pose row")
    steps_a = np.array(steps).reshape(-1, 4)
    return Track.from_arrays(np.array(poses), np.array(covs), steps_a, counters, start), extras


# -- two feet ------------------------------------------------------------------------------

_FOOT_FIELDS = ("x_north_m", "y_east_m", "z_down_m", "heading_rad",
                "sigma_north_m", "sigma_east_m", "sigma_down_m", "sigma_heading_rad")
#: Extra CSV columns of a two-feet track (:func:`write_feet_csv`): which foot made the row's step
#: (``left``/``right``; empty in row 0), then each foot's fused pose and its 1σ.
FEET_COLUMNS: tuple[str, ...] = ("foot", *(f"{side}_{name}" for side in FOOT_SIDES for name in _FOOT_FIELDS))


@dataclass(frozen=True)
class FeetTrack:
    """What a two-feet CSV holds: the body track, which foot made each step, and each foot's
    fused poses and their 1σ (side → (n + 1, 4): x, y, z [m], χ [rad]; row 0 the start)."""

    body: Track
    sides: tuple[str, ...]
    feet: Mapping[str, np.ndarray]
    sigmas: Mapping[str, np.ndarray]

    @classmethod
    def of(cls, tracker: Any) -> FeetTrack:
        """The fused track of a :class:`hostlib.fusion.feet.TwoFeetTracker` (take it while no steps
        arrive: after the walk, or after :meth:`~hostlib.fusion.feet.TwoFeetTracker.fuse_in_time_order`)."""
        return cls(tracker.body, tuple(tracker.sides),
                   {side: tracker.fused_foot(side) for side in FOOT_SIDES},
                   {side: tracker.fused_foot_sigmas(side) for side in FOOT_SIDES})


def write_feet_csv(feet: Any, path: str | Path, origin: Sequence[float] | None = None) -> None:
    """Write the body track of *feet* (a :class:`hostlib.fusion.feet.TwoFeetTracker` or a
    :class:`FeetTrack`) in :data:`CSV_COLUMNS`, each row followed by :data:`FEET_COLUMNS`; with
    *origin* (lat, lon[, alt] of the frame's origin, e.g. the first GPS fix) then by
    :data:`GEO_COLUMNS`, the body on the WGS84 ellipsoid, as :func:`write_csv` places one foot's."""
    ft = feet if isinstance(feet, FeetTrack) else FeetTrack.of(feet)
    geo = None if origin is None else enu_to_geodetic(ned_to_enu(ft.body.positions), origin)
    rows = ([("" if k == 0 else ft.sides[k - 1]),
             *(_f(v) for side in FOOT_SIDES for v in (*ft.feet[side][k], *ft.sigmas[side][k])),
             *(() if geo is None else (_f(geo[k][1]), _f(geo[k][0]), _f(geo[k][2])))]
            for k in range(len(ft.body) + 1))
    _write_track_rows(ft.body, path, FEET_COLUMNS + (() if geo is None else GEO_COLUMNS), rows)


def read_feet_csv(path: str | Path) -> FeetTrack:
    """Read what :func:`write_feet_csv` wrote (its geographic columns, if any, are the body's
    position again and are not kept); a bad line is refused with its line number."""
    body, rows = _read_track_rows(path, FEET_COLUMNS, FEET_COLUMNS + GEO_COLUMNS)
    sides = tuple(side for side, _ in rows[1:])
    values = np.array([v[:16] for _, v in rows]).reshape(len(rows), 2, 2, 4)  # row, foot, pose/σ, value
    return FeetTrack(body, sides, {side: values[:, i, 0] for i, side in enumerate(FOOT_SIDES)},
                     {side: values[:, i, 1] for i, side in enumerate(FOOT_SIDES)})


def _parse_feet_fields(fields: list[str], row: int) -> tuple[str, list[float]]:
    foot = fields[0]
    if row == 0 and foot:
        raise ValueError(f"foot {foot!r} in the initial pose's row (no foot stepped)")
    if row > 0 and foot not in FOOT_SIDES:
        raise ValueError(f"foot {foot!r} is not {' or '.join(FOOT_SIDES)}")
    return foot, [float(v) for v in fields[1:]]


def _parse_floats(fields: list[str], row: int) -> list[float]:
    return [float(v) for v in fields]


#: What may follow :data:`CSV_COLUMNS` in a track CSV, and how its fields are read.
_EXTRA_COLUMNS: dict[tuple[str, ...], Callable[[list[str], int], Any]] = {
    (): _parse_floats, GEO_COLUMNS: _parse_floats, FEET_COLUMNS: _parse_feet_fields,
    FEET_COLUMNS + GEO_COLUMNS: _parse_feet_fields}


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
        lat0, lon0, h0 = parse_origin(origin)
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
