"""A PNG of a track seen from above, with 1σ position ellipses every few steps.

matplotlib is optional (the ``plot`` extra: ``pip install openshoe-emulator[plot]``)
and imported only when a plot is made. No pyplot and no global backend change:
the figure is drawn on an Agg canvas directly, so this works headless and does
not disturb an interactive session.

Axes: east to the right, north up (the module's frame is x north, y east).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from .tracking import Track

__all__ = ["ellipse_params", "plot_track"]


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


def plot_track(
    track: Track,
    path: str | Path,
    *,
    every: int = 10,
    n_sigma: float = 1.0,
    title: str | None = None,
    dpi: int = 120,
    reference: np.ndarray | None = None,
    reference_label: str = "ground truth",
) -> Path:
    """Draw *track* (east right, north up) with n-σ ellipses every *every* steps and at the end.

    *reference*: optional known path to draw beneath the track, rows of (north, east[, …]) metres
    in the track's frame (e.g. a simulation's ground truth or surveyed points).
    """
    if every < 1:
        raise ValueError(f"every must be >= 1, got {every}")
    Figure, FigureCanvasAgg, Ellipse = _matplotlib()
    pos = track.positions
    covs = track.covariances
    fig = Figure(figsize=(7, 7))
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    if reference is not None:
        ref = np.asarray(reference, dtype=float)
        if ref.ndim != 2 or ref.shape[1] < 2:
            raise ValueError(f"reference must be rows of (north, east), got shape {ref.shape}")
        ax.plot(ref[:, 1], ref[:, 0], "--", color="0.55", lw=1.0, label=reference_label)
    ax.plot(pos[:, 1], pos[:, 0], "-", color="tab:blue", lw=1.2, label="track")
    ax.plot(pos[0, 1], pos[0, 0], "o", color="tab:green", label="start")
    ax.plot(pos[-1, 1], pos[-1, 0], "s", color="tab:red", label="end")
    marks = sorted(set(range(0, len(pos), every)) | {len(pos) - 1})
    for k in marks:
        w, h, ang = ellipse_params(covs[k][:2, :2], n_sigma)
        if w > 0:
            ax.add_patch(Ellipse((pos[k, 1], pos[k, 0]), w, h, angle=ang, fill=False,
                                 color="tab:orange", lw=0.8))
    ax.set_xlabel("east [m]")
    ax.set_ylabel("north [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, lw=0.3)
    ax.legend(loc="best", fontsize="small")
    ax.set_title(title or f"{len(track)} steps, {track.distance:.1f} m, "
                 f"{n_sigma:g}σ every {every} steps, closure {track.closure_error():.2f} m")
    out = Path(path)
    fig.savefig(out, dpi=dpi, format="png")
    return out
