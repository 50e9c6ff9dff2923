"""The summary plot of a sweep: the closure error of its runs, per combination of settings."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

__all__ = ["plot_closure"]


def _label(row: dict[str, Any], names: Sequence[str]) -> str:
    return ", ".join(f"{n.rsplit('.', 1)[-1]}={row[n]:g}" if isinstance(row[n], float)
                     else f"{n.rsplit('.', 1)[-1]}={row[n]}" for n in names) or "all runs"


def plot_closure(rows: Sequence[dict[str, Any]], setting_names: Sequence[str], path: Path) -> Path | None:
    """A box per combination of settings (every run a dot on it): closure in % of the distance,
    or, when no run is a closed loop, the distance walked. None without matplotlib."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return None
    metric = "closure_pct" if any(not math.isnan(r["closure_pct"]) for r in rows) else "distance_m"
    groups: dict[str, list[float]] = {}
    for row in rows:
        value = row[metric]
        groups.setdefault(_label(row, setting_names), [])
        if not math.isnan(value):
            groups[_label(row, setting_names)].append(value)
    labels = list(groups)
    fig, ax = plt.subplots(figsize=(min(4.0 + 0.6 * len(labels), 24.0), 5.0), layout="constrained")
    ax.boxplot([groups[k] for k in labels], tick_labels=labels, showfliers=False)
    ax.tick_params(axis="x", labelrotation=30, labelsize=8)
    for tick in ax.get_xticklabels():
        tick.set_horizontalalignment("right")
    for i, k in enumerate(labels, start=1):
        xs = [i + 0.15 * ((j % 5) - 2) / 2 for j in range(len(groups[k]))]
        ax.plot(xs, groups[k], "o", ms=3, alpha=0.6, color="tab:blue")
    ax.set_ylabel("closure error [% of distance]" if metric == "closure_pct" else "distance [m]")
    short = ", ".join(n.rsplit(".", 1)[-1] for n in setting_names)
    ax.set_title(f"{len(rows)} runs" + (f", by {short}" if short else ""), fontsize=10)
    ax.grid(axis="y", alpha=0.3)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
