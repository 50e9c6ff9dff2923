"""What a calibration leaves of a compass's error that turns with the heading: the compass swing
B sin ψ + C cos ψ, as two states of the host's filter.

A calibration (given, saved for the module, or fitted in situ by the wiggle) removes the shoe's
iron, but not all of it, and a reading's field is levelled with the attitude at the end of the
stance, which is not exact either. What is left adds to the board-frame field a small vector fixed
in the board's frame:

* the iron the ellipsoid fit left, about a microtesla per axis
  (:data:`hostlib.fusion.hard_iron.CALIBRATED`);
* the attitude's tilt error δθ at the end of the stance: levelled with it, the field's vertical
  part Z leaks Z·δθ into the horizontal along the board axis it tilts — 0.44 µT for 0.5° (the
  level's σ of :mod:`hostlib.aids.field_check`) at the Earth's 50 µT vertical in the north of
  Europe. On the emulated module it has two causes (docs/heading-aids.md, "Where the level error
  comes from"): the magnetometers in a step packet are the latest reading, a few milliseconds newer
  than the attitude (the filter runs N/2 samples behind the sensors), and at a reset at the end of
  the stance the heel is already lifting; and the module's own level drifts as its dies warm (the
  horizontal gyros' bias, which the ZUPTs of a swaying stance leave as a tilt), after any
  calibration has seen it.

With the foot level, a board-frame vector (b_x, b_y) turns the heading by
(b_x sin ψ + b_y cos ψ) / H, ψ the board's heading from magnetic north and H the horizontal field:
the classic compass swing's one-cycle terms B sin ψ + C cos ψ. The swing does not change while the
heading holds, so readings along a straight leg cannot average it away, and in GPS's training it
passes for the declination, which then carries the wrong angle into an outage. Held as two constant
states [B, C], it is told apart from D wherever the walk turns: a reading then measures

    ψ_c = χ − D − d − (B sin ψ_m + C cos ψ_m),   ψ_m = χ − D

linearised at the filter's own magnetic heading ψ_m (smooth from step to step, unlike a reading's
own levelled field; the terms' derivative with respect to χ and D is B cos ψ_m − C sin ψ_m, a few
hundredths, left out). Diagnosis on the simulated outage loop: with the true iron removed, readings
still swung 1.5° on two modules of four (B ≈ −1.5°), and the calibration's own residual swung
another 0.2–0.7°.

The prior (:data:`CALIBRATED_SWING`): σ 4° on each term, the two causes above together, 1.1 µT per
axis, against the horizontal field of 15.3 µT at 59° N: atan(1.1 / 15.3) ≈ 4.1°. A horizontal field
twice as strong (nearer the equator) halves it; a larger σ is the safe side. Not held for an
uncalibrated compass (its iron turns readings by up to tens of degrees; the local deviation carries
it, :mod:`hostlib.fusion.compass_trust`), nor with the hard iron learned as states
(:mod:`hostlib.fusion.hard_iron`), which models the same vector in the board's frame.

Held only when asked for (``--compass-swing``). On NavShoe's outage loop, calibrated in situ, it
took the seeds it was diagnosed on (1–5) from 0.91 % to 0.58 % of the distance without GPS, but
the held-out seeds 6–20 from 1.01 % to 1.22 %: on one loop the four legs' headings come one after
the other, and without GPS the filter cannot tell a swing from the heading the module drifted by
between them; where it is wrong, the declination follows it through the outage. Shaped as the
warming builds the level error (times the warm-up's ramp, with or without a constant part) it did
no better held out (1.21 % and 1.22 %).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .gauss_markov import require_positive

__all__ = ["CALIBRATED_SWING", "CompassSwing", "swing_basis"]


@dataclass(frozen=True)
class CompassSwing:
    """The prior of a calibrated compass's swing [B, C]: zero-mean, 1σ *sigma_rad* on each term,
    constant over a walk."""

    sigma_rad: float

    def __post_init__(self) -> None:
        require_positive(self, ("sigma_rad",))

    @property
    def variance(self) -> float:
        """σ², the prior variance of each term [rad²]."""
        return self.sigma_rad ** 2

    def describe(self) -> str:
        return f"σ {math.degrees(self.sigma_rad):g}° on B sin ψ + C cos ψ"


#: A calibrated compass's swing: what the calibration's iron and the level at the end of the stance
#: leave, 1.1 µT per axis against 15.3 µT of horizontal field (module docstring).
CALIBRATED_SWING = CompassSwing(math.radians(4.0))


def swing_basis(magnetic_heading: float) -> np.ndarray:
    """[sin ψ_m, cos ψ_m] at the board's magnetic heading *magnetic_heading* [rad]: a reading's
    heading error is this times the swing [B, C]."""
    return np.array([math.sin(magnetic_heading), math.cos(magnetic_heading)])
