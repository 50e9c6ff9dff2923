"""The GPS receiver's correlated error as a state of the host's filter: a bias that wanders in time.

A consumer receiver's horizontal error is mostly a slowly wandering offset (multipath and the
atmosphere change as the satellites move: a few metres, correlated over minutes) plus a little
white noise per fix. Taken as white noise, fixes a second apart are far from independent, so the
filter must inflate their σ and use them seldom (:attr:`hostlib.fusion.tracker.FusionSettings.gps_sigma_m`,
15 m every 10 s for a 3 m receiver); even so it learns the heading from fixes hundreds of metres
apart more surely than a wandering offset allows.

:class:`GpsBias` models the offset b = [b_north, b_east] as a first-order Gauss–Markov process in
time, the same on both axes and independent between them: over Δt seconds

    b ← φ b,   var b ← φ² var b + (1 − φ²) σ_b²,   φ = exp(−Δt / τ),

stationary with variance σ_b² per axis, two fixes Δt apart correlated exp(−Δt / τ). The filter
holds b as two more states; a fix then measures the position plus b, north and east, with only
its white σ_w, and every fix can be used (:mod:`hostlib.fusion.tracker`).

The defaults are a receiver specified at **3 m RMS horizontally** (both axes together, as
receivers are specified: σ_b = 3 / √2 ≈ 2.12 m per axis) whose error is correlated over
**τ = 120 s** — the figures the inflated σ is worked out from — with the emulated receiver's white
part, **0.3 m per axis** (``firmware_sim.sensors.gps.GpsErrors``: the same 3 m, 120 s and 0.3 m).
Another receiver has its own; an open-sky RTK fix or a receiver under trees would not fit these.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .gauss_markov import require_positive, transition

__all__ = ["RECEIVER_HORIZONTAL_RMS_M", "GpsBias"]

#: The horizontal RMS [m] (both axes together) of the receiver the defaults describe.
RECEIVER_HORIZONTAL_RMS_M = 3.0


@dataclass(frozen=True)
class GpsBias:
    """The receiver's error (module docstring): a Gauss–Markov bias of 1σ *sigma_m* per axis and
    time constant *tau_s*, plus each fix's white 1σ *white_sigma_m* per axis."""

    #: σ_b: the bias's RMS per axis [m] (the 3 m horizontal RMS over two axes)
    sigma_m: float = RECEIVER_HORIZONTAL_RMS_M / math.sqrt(2.0)
    #: τ: two fixes Δt apart have biases correlated exp(−Δt / τ) [s]
    tau_s: float = 120.0
    #: σ_w: each fix's own white error per axis [m] (the receiver's noise)
    white_sigma_m: float = 0.3

    def __post_init__(self) -> None:
        require_positive(self, ("sigma_m", "tau_s", "white_sigma_m"))

    @property
    def variance(self) -> float:
        """σ_b², the stationary (and initial) variance of each axis of b [m²]."""
        return self.sigma_m ** 2

    def transition(self, seconds: float) -> tuple[float, float]:
        """(φ, q) over *seconds*: b ← φ b, var b ← φ² var b + q (per axis)."""
        return transition(seconds, self.tau_s, self.variance)

    def describe(self) -> str:
        return (f"σ {self.sigma_m:.2g} m per axis over τ {self.tau_s:g} s, "
                f"white σ {self.white_sigma_m:g} m")
