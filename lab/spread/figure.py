"""The figure of a spread experiment (``spread.png``): where the walks end, and how high.

Left, like the module paper's Fig. 7: each walk's end error, across-track on x and along-track
(length) on y, in metres on equal axes, with the 1σ ellipse of the 2×2 covariance and the mean
(a cross). Right: the height error of each walk against its seed, with the mean and the ±1σ band.
Several groups (a fleet of new modules and one module) share both panels, one colour each.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .summary import Spread

__all__ = ["ellipse_axes", "plot_spread"]

COLOURS = ("tab:blue", "tab:orange", "tab:green", "tab:red")


def ellipse_axes(cov_along_across: Sequence[Sequence[float]]) -> tuple[float, float, float]:
    """The 1σ ellipse of a covariance of (along, across) drawn with across on x and along on y:
    (width, height, angle [deg]) for :class:`matplotlib.patches.Ellipse`."""
    c = np.asarray(cov_along_across, dtype=float)
    xy = np.array([[c[1, 1], c[0, 1]], [c[1, 0], c[0, 0]]])  # (across, along)
    values, vectors = np.linalg.eigh(xy)
    major = vectors[:, 1]
    angle = math.degrees(math.atan2(major[1], major[0]))
    return 2.0 * math.sqrt(max(values[1], 0.0)), 2.0 * math.sqrt(max(values[0], 0.0)), angle


def _scatter(ax: Any, label: str, rows: Sequence[dict[str, Any]], spread: Spread, colour: str) -> None:
    from matplotlib.patches import Ellipse

    across = [r["end_across_m"] for r in rows]
    along = [r["end_along_m"] for r in rows]
    ax.plot(across, along, "o", ms=4, alpha=0.7, color=colour,
            label=f"{label}: {spread.n} walks, horizontal 1σ {spread.horizontal_m:.3f} m")
    mean = (spread.across_m.mean, spread.length_m.mean)
    # a black edge: the mean stays visible on a tight cloud of its own colour
    ax.plot(*mean, "X", ms=11, mfc=colour, mec="black", mew=1.0, zorder=5)
    if spread.n > 1:
        width, height, angle = ellipse_axes(spread.covariance_m2)
        ax.add_patch(Ellipse(mean, width, height, angle=angle, fill=False, lw=1.5, color=colour,
                             zorder=4))


def _heights(ax: Any, label: str, rows: Sequence[dict[str, Any]], spread: Spread, colour: str) -> None:
    seeds = [r["seed"] for r in rows]
    ax.plot(seeds, [r["end_height_m"] for r in rows], "o", ms=4, alpha=0.7, color=colour, label=label)
    m, sd = spread.height_m.mean, spread.height_m.sd
    ax.axhline(m, color=colour, lw=1)
    if spread.n > 1:
        ax.axhspan(m - sd, m + sd, color=colour, alpha=0.12, lw=0)


def plot_spread(groups: Sequence[tuple[str, Sequence[dict[str, Any]], Spread]], path: Path,
                title: str) -> Path | None:
    """Write the figure of *groups* (label, rows, their spread) to *path*; None without matplotlib."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return None
    fig, (left, right) = plt.subplots(1, 2, figsize=(12.0, 6.0), width_ratios=(1.0, 1.1),
                                      layout="constrained")
    for (label, rows, spread), colour in zip(groups, COLOURS, strict=False):
        _scatter(left, label, rows, spread, colour)
        _heights(right, label, rows, spread, colour)
    left.axhline(0.0, color="0.5", lw=0.6)
    left.axvline(0.0, color="0.5", lw=0.6)
    left.set_aspect("equal", adjustable="datalim")
    left.set_xlabel("across-track error [m] (positive: right of the true end)")
    left.set_ylabel("along-track (length) error [m] (positive: too long)")
    left.set_title("end of the track against the truth (× mean, ellipse 1σ)", fontsize=10)
    left.legend(fontsize=8, loc="best")
    left.grid(alpha=0.3)
    right.axhline(0.0, color="0.5", lw=0.6)
    right.set_xlabel("walk (seed)")
    right.set_ylabel("height error [m] (positive: track ends above the truth)")
    right.set_title("height error per walk (line mean, band ±1σ)", fontsize=10)
    right.legend(fontsize=8, loc="best")
    right.grid(alpha=0.3)
    fig.suptitle(title, fontsize=11)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
