"""The shoe's hard iron as a state of the host's filter, learned while the module walks.

A magnetometer on a shoe reads the Earth's field plus the field of the shoe's own iron (and the
module's): a constant vector b in the board's frame, the *hard iron*. Left in, it turns every
compass heading by an error that depends on the heading itself — a few microtesla against the
15–20 µT of the field's horizontal part is several degrees — so an uncalibrated compass makes a
track worse, not better. NavShoe (shared/spec/aids.md §1) augments its filter with b: a heading
reading then measures the heading minus D, d and what b turns it by, and wherever GPS or the
walk's turns tell the headings apart, b becomes observable and the compass helps again.

:class:`HardIron` is that state's prior: zero-mean, σ per axis, constant over a walk. With a
calibration (:class:`hostlib.calibration.magcal.MagCalibration`) applied first, b is what the
calibration left, and its σ is small; uncalibrated it is the shoe's whole iron. While b is
uncertain, the filter weighs each reading by it: a reading's variance gains g P_b gᵀ (g below), so
an uncalibrated compass with nothing to learn b from counts for little, as it should.

:func:`iron_heading` linearises the reading: the heading ψ̂ of the field less the estimate b̂, and
g = ∂ψ/∂b there, so that ψ(m − b) ≈ ψ̂ + g (b − b̂).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..aids.compass import compass_heading
from .gauss_markov import require_positive

__all__ = ["CALIBRATED", "UNCALIBRATED", "HardIron", "iron_heading", "iron_heading_sigma"]


@dataclass(frozen=True)
class HardIron:
    """The prior of the shoe's hard iron b [µT] in the board's frame: 1σ per axis."""

    sigma_ut: float = 10.0

    def __post_init__(self) -> None:
        require_positive(self, ("sigma_ut",))

    @property
    def variance(self) -> float:
        """σ², the prior variance of each axis [µT²]."""
        return self.sigma_ut ** 2

    def describe(self) -> str:
        return f"σ {self.sigma_ut:g} µT per axis"


#: A shoe nobody calibrated: its iron and the module's, up to about 20 µT (2σ) on each axis, as much
#: as the horizontal field itself in the north of Europe — a heading error of tens of degrees that
#: changes with the heading.
UNCALIBRATED = HardIron(10.0)
#: What an in-situ or file calibration leaves: the ellipsoid fit's centre is good to about a
#: microtesla (the fit's residual over a wiggle's readings).
CALIBRATED = HardIron(1.0)


def iron_heading_sigma(iron: HardIron, horizontal_ut: float) -> float:
    """1σ [rad] of the heading error an unknown hard iron *iron* causes against the horizontal field
    *horizontal_ut* [µT]: with the foot level, the iron's part across the field, σ per axis, turns
    the field's direction by atan(σ_b / H) (an error that depends on the heading, the same while it
    holds)."""
    if not (math.isfinite(horizontal_ut) and horizontal_ut > 0.0):
        return math.pi / 2.0
    return math.atan(iron.sigma_ut / horizontal_ut)


def iron_heading(field_board: np.ndarray, rotation: np.ndarray,
                 iron_ut: np.ndarray) -> tuple[float, np.ndarray]:
    """The heading ψ̂ [rad] from magnetic north of the board-frame field *field_board* less the
    hard-iron estimate *iron_ut*, given the board → navigation *rotation*, and g = ∂ψ/∂b (3,)
    [rad/µT] there (module docstring)."""
    m = np.asarray(field_board, dtype=np.float64) - np.asarray(iron_ut, dtype=np.float64)
    r = np.asarray(rotation, dtype=np.float64)
    psi = compass_heading(m, r)
    n = r @ m
    horizontal = n[0] ** 2 + n[1] ** 2
    if not (math.isfinite(horizontal) and horizontal > 0.0):
        return math.nan, np.zeros(3)
    # ψ = yaw − atan2(n_y, n_x), n = R m: ∂ψ/∂m = −[−n_y, n_x, 0] R / |n_h|², and ∂ψ/∂b = −∂ψ/∂m
    dpsi_dm = -(np.array([-n[1], n[0], 0.0]) / horizontal) @ r
    return psi, -dpsi_dm
