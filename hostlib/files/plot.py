"""A PNG of a track: seen from above with enlarged 1σ ellipses every few steps, and its height.

matplotlib is optional (the ``plot`` extra: ``pip install openshoe-emulator[plot]``)
and imported only when a plot is made. No pyplot and no global backend change:
the figure is drawn on an Agg canvas directly, so this works headless and does
not disturb an interactive session.

Axes: east to the right, north up (the module's frame is x north, y east).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..track.steps import Track

__all__ = ["PlotOptions", "along_track", "ellipse_params", "ellipse_scale", "plot_track"]


def _matplotlib() -> tuple[Any, Any, Any]:
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
        from matplotlib.patches import Ellipse
    except ImportError as exc:
        raise ImportError(
            "plotting needs matplotlib; install it with `pip install matplotlib` "
            "(or the package's `plot` extra)"
        ) from exc
    return Figure, FigureCanvasAgg, Ellipse


def ellipse_params(cov_xy: np.ndarray, n_sigma: float = 1.0) -> tuple[float, float, float]:
    """Width, height [m] and angle [deg, from east towards north] of the n-σ ellipse of a
    north/east 2×2 covariance, drawn in east/north axes."""
    c = np.asarray(cov_xy, dtype=np.float64)
    en = np.array([[c[1, 1], c[0, 1]], [c[0, 1], c[0, 0]]])  # east, north
    vals, vecs = np.linalg.eigh(en)
    vals = np.clip(vals, 0.0, None)
    major = vecs[:, 1]
    angle = math.degrees(math.atan2(major[1], major[0]))
    return 2 * n_sigma * math.sqrt(vals[1]), 2 * n_sigma * math.sqrt(vals[0]), angle


#: "Nice" enlargement factors for the ellipses (the smallest that makes them visible is used).
_NICE_SCALES = (1, 2, 5, 10, 20, 50, 100, 200, 500, 1000)
#: An enlarged ellipse's major axis should span about this fraction of the plan view's extent.
_VISIBLE_FRACTION = 0.04


def ellipse_scale(track_extent_m: float, largest_axis_m: float) -> float:
    """The enlargement that makes the largest ellipse span about 4 % of the plot (a nice number).

    1 when the ellipses are already that large; never below 1.
    """
    if largest_axis_m <= 0.0 or track_extent_m <= 0.0:
        return 1.0
    wanted = _VISIBLE_FRACTION * track_extent_m / largest_axis_m
    for k in _NICE_SCALES:
        if k >= wanted:
            return float(k)
    return float(_NICE_SCALES[-1])


def along_track(positions: np.ndarray) -> np.ndarray:
    """Cumulative horizontal distance [m] at each row of (north, east[, …]) positions."""
    steps = np.linalg.norm(np.diff(np.asarray(positions, dtype=float)[:, :2], axis=0), axis=1)
    return np.concatenate([[0.0], np.cumsum(steps)])


@dataclass(frozen=True)
class PlotOptions:
    """What :func:`plot_track` draws besides the track, and how."""

    #: every *every*-th step (and the last) gets its position ellipse
    every: int = 10
    #: the ellipses' size in σ
    n_sigma: float = 1.0
    #: the plan's title (None: the track's steps, distance and closure)
    title: str | None = None
    #: the PNG's resolution [dots per inch]
    dpi: int = 120
    #: a known path drawn beneath the track, rows of (north, east[, down]) metres in the track's
    #: frame (e.g. a simulation's ground truth or surveyed points)
    reference: np.ndarray | None = None
    #: the reference's name in the legends
    reference_label: str = "ground truth"
    #: how many times the ellipses are enlarged (None: so that the largest spans about 4 % of the
    #: plot, :func:`ellipse_scale`; the legend states the factor)
    scale: float | None = None
    #: a panel under the plan with the height (up) over the distance walked, the track's and the
    #: reference's
    height_profile: bool = True
    #: more paths drawn thin beside the track in the plan, label → rows of (north, east[, down])
    #: (e.g. each foot's beside a two-feet body track)
    paths: Mapping[str, np.ndarray] | None = None
    #: the track's name in the legends
    label: str = "track"


def plot_track(track: Track, path: str | Path, options: PlotOptions | None = None, **settings: Any) -> Path:
    """Draw *track* seen from above (east right, north up), and its height along the way, into the
    PNG at *path*; returns the file.

    Every *every*-th step (and the last) gets its n-σ position ellipse, enlarged so that it can be
    seen at the plan's scale; a reference path, more paths beside the track and the height profile
    as *options* say (:class:`PlotOptions`). Any of its fields may also be given as a keyword
    (``plot_track(track, "t.png", every=5)``), which wins over *options*.
    """
    o = replace(options or PlotOptions(), **settings)
    if o.every < 1:
        raise ValueError(f"every must be >= 1, got {o.every}")
    Figure, FigureCanvasAgg, _Ellipse = _matplotlib()
    pos = track.positions
    ref = _reference_rows(o.reference)
    fig = Figure(figsize=(7, 9.5) if o.height_profile else (7, 7))
    FigureCanvasAgg(fig)
    if o.height_profile:
        grid = fig.add_gridspec(2, 1, height_ratios=(3.2, 1))
        ax, axz = fig.add_subplot(grid[0]), fig.add_subplot(grid[1])
    else:
        ax, axz = fig.add_subplot(1, 1, 1), None
    if ref is not None:
        ax.plot(ref[:, 1], ref[:, 0], "--", color="0.55", lw=1.0, label=o.reference_label)
    for (name, rows), color in zip((o.paths or {}).items(), itertools.cycle(_PATH_COLORS)):
        path_rows = _reference_rows(rows)
        ax.plot(path_rows[:, 1], path_rows[:, 0], "-", color=color, lw=0.7, alpha=0.8, label=name)
    ax.plot(pos[:, 1], pos[:, 0], "-", color="tab:blue", lw=1.2, label=o.label)
    ax.plot(pos[0, 1], pos[0, 0], "o", color="tab:green", label="start")
    ax.plot(pos[-1, 1], pos[-1, 0], "s", color="tab:red", label="end")
    _draw_ellipses(ax, pos, track.covariances, o.every, o.n_sigma, o.scale)
    ax.set_xlabel("east [m]")
    ax.set_ylabel("north [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, lw=0.3)
    ax.legend(loc="best", fontsize="small")
    ax.set_title(o.title or f"{len(track)} steps, {track.distance:.1f} m, "
                            f"closure {track.closure_error():.2f} m")
    if axz is not None:
        _draw_height_profile(axz, pos, ref, o.reference_label, o.label)
    fig.tight_layout()
    out = Path(path)
    fig.savefig(out, dpi=o.dpi, format="png")
    return out


#: Colours of the *paths* beside a track (then again from the first).
_PATH_COLORS = ("tab:purple", "tab:olive", "tab:cyan", "tab:brown")


def _reference_rows(reference: np.ndarray | None) -> np.ndarray | None:
    """The reference path as float rows of (north, east[, down]), or None; refuses other shapes."""
    if reference is None:
        return None
    ref = np.asarray(reference, dtype=float)
    if ref.ndim != 2 or ref.shape[1] < 2:
        raise ValueError(f"reference must be rows of (north, east), got shape {ref.shape}")
    return ref


def _draw_ellipses(ax, pos: np.ndarray, covs: np.ndarray, every: int, n_sigma: float,
                   scale: float | None) -> None:
    """The n-σ position ellipse of every *every*-th step and the last, enlarged *scale* times
    (None: :func:`ellipse_scale`); the legend names the factor once."""
    _Figure, _Canvas, Ellipse = _matplotlib()
    marks = sorted(set(range(0, len(pos), every)) | {len(pos) - 1})
    shapes = [ellipse_params(covs[k][:2, :2], n_sigma) for k in marks]
    extent = float(np.ptp(pos[:, :2], axis=0).max()) if len(pos) > 1 else 0.0
    if scale is None:
        scale = ellipse_scale(extent, max((w for w, _h, _a in shapes), default=0.0))
    label = f"{n_sigma:g}σ ellipse" + (f" ×{scale:g}" if scale != 1 else "") + f", every {every} steps"
    for k, (w, h, ang) in zip(marks, shapes, strict=True):
        if w > 0:
            ax.add_patch(Ellipse((pos[k, 1], pos[k, 0]), w * scale, h * scale, angle=ang, fill=False,
                                 color="tab:orange", lw=1.0, label=label))
            label = None


def _draw_height_profile(ax: Any, pos: np.ndarray, ref: np.ndarray | None, reference_label: str,
                         label: str = "track") -> None:
    """Height (up = −z) over the horizontal distance walked, track and reference."""
    if ref is not None and ref.shape[1] >= 3:
        ax.plot(along_track(ref), -ref[:, 2], "--", color="0.55", lw=1.0, label=reference_label)
    ax.plot(along_track(pos), -pos[:, 2], "-", color="tab:blue", lw=1.2, label=label)
    ax.set_xlabel("distance walked [m]")
    ax.set_ylabel("height [m]")
    ax.grid(True, lw=0.3)
    ax.legend(loc="best", fontsize="small")
