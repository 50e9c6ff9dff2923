"""The spread of a set of walks' end errors: means, sample standard deviations, the horizontal
spread, as numbers (:class:`Spread`) and as the table a person reads (:func:`lines`).

The errors are the row columns of :func:`firmware_sim.app.runs.run_one`: ``end_along_m`` (the
length error of a straight walk), ``end_across_m``, ``end_height_m`` and ``end_heading_deg``. The
% figures are each walk's error in % of its own tracked distance (``distance_m``), then their mean
and standard deviation. Standard deviations are the sample ones (N−1); with one walk they are NaN.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["MeanSd", "Spread", "horizontal_ratio", "lines", "write_rows"]


@dataclass(frozen=True)
class MeanSd:
    """The mean and the sample standard deviation (N−1) of a set of values."""

    mean: float
    sd: float

    @classmethod
    def of(cls, values: Sequence[float]) -> MeanSd:
        v = np.asarray(values, dtype=float)
        if v.size == 0:
            return cls(math.nan, math.nan)
        return cls(float(v.mean()), float(v.std(ddof=1)) if v.size > 1 else math.nan)


@dataclass(frozen=True)
class Spread:
    """Where the ends of *n* walks land against the truth (module docstring)."""

    n: int
    distance_m: float  #: mean tracked distance of a walk
    length_m: MeanSd  #: along the true final heading (positive: the track is too long)
    across_m: MeanSd  #: to the right of the true final heading
    height_m: MeanSd  #: positive: the track ends above the truth
    length_pct: MeanSd
    across_pct: MeanSd
    height_pct: MeanSd
    heading_deg: MeanSd
    #: the sample covariance of (along, across) [m²], row-major
    covariance_m2: tuple[tuple[float, float], tuple[float, float]]

    @property
    def horizontal_m(self) -> float:
        """The horizontal spread √trace(cov(along, across)) = √(sd_along² + sd_across²) [m]."""
        return math.sqrt(self.covariance_m2[0][0] + self.covariance_m2[1][1])

    @classmethod
    def of(cls, rows: Sequence[dict[str, Any]]) -> Spread:
        """The spread of *rows* (rows of :func:`~firmware_sim.app.runs.run_one`, one per walk)."""
        col = {k: np.array([float(r[k]) for r in rows], dtype=float)
               for k in ("distance_m", "end_along_m", "end_across_m", "end_height_m", "end_heading_deg")}
        dist = col["distance_m"]
        with np.errstate(divide="ignore", invalid="ignore"):
            pct = {k: 100.0 * col[k] / dist for k in ("end_along_m", "end_across_m", "end_height_m")}
        if len(rows) > 1:
            c = np.cov(np.vstack([col["end_along_m"], col["end_across_m"]]), ddof=1)
            cov = ((float(c[0, 0]), float(c[0, 1])), (float(c[1, 0]), float(c[1, 1])))
        else:
            cov = ((math.nan, math.nan), (math.nan, math.nan))
        return cls(n=len(rows), distance_m=float(dist.mean()) if len(rows) else math.nan,
                   length_m=MeanSd.of(col["end_along_m"]), across_m=MeanSd.of(col["end_across_m"]),
                   height_m=MeanSd.of(col["end_height_m"]), length_pct=MeanSd.of(pct["end_along_m"]),
                   across_pct=MeanSd.of(pct["end_across_m"]), height_pct=MeanSd.of(pct["end_height_m"]),
                   heading_deg=MeanSd.of(col["end_heading_deg"]), covariance_m2=cov)


def horizontal_ratio(one: Spread, fleet: Spread) -> float:
    """One module's horizontal spread over the fleet's (below 1: its ends cluster)."""
    return one.horizontal_m / fleet.horizontal_m if fleet.horizontal_m > 0 else math.nan


# ---------------------------------------------------------------------------------------------
# the table a person reads


def _signed(x: float, digits: int) -> str:
    return "–" if math.isnan(x) else f"{x:+.{digits}f}".replace("-", "−")


def _plain(x: float, digits: int) -> str:
    return "–" if math.isnan(x) else f"{x:.{digits}f}"


def lines(spread: Spread, title: str = "") -> list[str]:
    """The spread as a small table: a title line, then one line per error, mean ± sd (1σ)::

        length error        −0.060 m ± 0.106 m   (−0.06 % ± 0.11 %)

    and last the horizontal spread (√trace of the along/across covariance)."""
    s = spread
    head = f"{title}: " if title else ""
    out = [f"{head}{s.n} walks, mean tracked distance {_plain(s.distance_m, 2)} m; mean ± sd (1σ)"]
    rows = (("length error", s.length_m, s.length_pct), ("across-track error", s.across_m, s.across_pct),
            ("height error", s.height_m, s.height_pct))
    for label, m, p in rows:
        out.append(f"  {label:<19}{_signed(m.mean, 3):>7} m ± {_plain(m.sd, 3)} m   "
                   f"({_signed(p.mean, 2)} % ± {_plain(p.sd, 2)} %)")
    h = s.heading_deg
    out.append(f"  {'heading error':<19}{_signed(h.mean, 3):>7}° ± {_plain(h.sd, 3)}°")
    out.append(f"  {'horizontal spread':<19}{_plain(s.horizontal_m, 3):>7} m   "
               "(√trace of the along/across covariance)")
    return out


def write_rows(groups: Sequence[tuple[str, Sequence[dict[str, Any]]]], path: Path) -> Path:
    """*path* as CSV, one row per walk with the rows' own columns, after a ``group`` column (the
    name of the group the walk belongs to); floats in shortest round-trip form."""
    rows = [(name, row) for name, group in groups for row in group]
    header = ["group"] + list(rows[0][1]) if rows else ["group"]
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        for name, row in rows:
            w.writerow([name] + ["" if v is None else repr(v) if isinstance(v, float) else v
                                 for v in (row.get(k) for k in header[1:])])
    return path
