"""Height over distance, with and without height compensation."""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["plot_heights"]


Profile = tuple[np.ndarray, np.ndarray]


def plot_heights(path: Path, title: str, off: Profile, on: Profile, truth: Profile | None = None) -> Path:
    """Height [m] over distance walked [m]: the track without and with compensation (and truth)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 4))
    if truth is not None:
        ax.plot(*truth, color="0.5", linestyle="--", label="ground truth")
    ax.plot(*off, label="height compensation off")
    ax.plot(*on, label="height compensation on")
    ax.set_xlabel("distance walked [m]")
    ax.set_ylabel("height [m] (up)")
    ax.set_title(title)
    ax.grid(True, alpha=0.4)
    ax.legend()
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
