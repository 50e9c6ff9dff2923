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

Learned only when asked for (``--compass-swing``). Taught by the headings alone, on NavShoe's
outage loop, calibrated in situ, it took the seeds it was diagnosed on (1–5) from 0.91 % to 0.58 %
of the distance without GPS, but the held-out seeds 6–20 from 1.01 % to 1.22 %: on one loop the
four legs' headings come one after the other, and without GPS the filter cannot tell a swing from
the heading the module drifted by between them; where it is wrong, the declination follows it
through the outage. Shaped as the warming builds the level error (times the warm-up's ramp, with or
without a constant part) it did no better held out (1.21 % and 1.22 %). The levelled field's dip,
which knows nothing of the drift or the declination, now teaches it too where the walk has a place
(*dip*, :mod:`hostlib.fusion.compass_dip`): 0.59 %, 0.85 % and 0.70 % on seeds 1–5, 6–20 and 21–30
calibrated first, 0.62 %, 0.86 % and 0.82 % with the wiggle inside the walk; still no default (the
weighed warming swing below: 0.76 %, 0.93 %, 0.66 % and 0.56 %, 0.90 %, 0.66 %).

**Held by default: the warming's swing, weighed and not learned** (:data:`WARMING_SWING`). What a
calibration cannot see is the level the module's warming moves after it; that part grows as
``1 − e^(−t/τ)`` with the dies' warm-up (τ 120 s, t from the compass's first calibrated reading),
and its size follows from the gyros' warm-up prior (module_errors' 8.06e-4 rad/s, held off the
level for about 4 s by the ZUPTs of a swaying stance, the diagnosis's figure) and Z/H: σ 0.6°.
Held as a consider block (:class:`~hostlib.fusion.core.StateFilter`: no update moves its estimate,
its covariance and correlations go on), it is never estimated, so it cannot be mislearned; it
tells the filter that a reading's error depends on the heading and grows as the module warms, so
that what GPS teaches the declination at one heading is not carried whole to the others. On the
outage loop (``python -m lab.accuracy navshoe-in-situ``), calibrated first: 0.76 % on seeds 1–5
and 0.93 % on seeds 6–20, against 0.91 % and 1.01 % without it; with the wiggle inside the walk
0.56 % and 0.90 % against 0.71 % and 0.91 %.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .gauss_markov import require_positive

__all__ = ["CALIBRATED_SWING", "WARMING_SWING", "CompassSwing", "swing_basis"]


@dataclass(frozen=True)
class CompassSwing:
    """The prior of a calibrated compass's swing [B, C]: zero-mean, 1σ *sigma_rad* on each term,
    constant over a walk; with *warmup_tau_s*, grown as the module's dies warm, the swing times
    ``1 − e^(−t/τ)``, t from the compass's first calibrated reading (:func:`warming`); *learned*
    False: weighed and not estimated (a consider block of :class:`~hostlib.fusion.core.StateFilter`)."""

    #: 1σ of each term [rad]
    sigma_rad: float
    #: the module's warm-up time constant [s] the swing grows with (None: whole from the start)
    warmup_tau_s: float | None = None
    #: learned from the readings (True), or weighed and not estimated (a consider block)
    learned: bool = True
    #: learned from the levelled field's inclination too, where the walk's place gives the field's
    #: (:mod:`hostlib.fusion.compass_dip`)
    dip: bool = False

    def __post_init__(self) -> None:
        require_positive(self, ("sigma_rad",))
        if self.warmup_tau_s is not None:
            require_positive(self, ("warmup_tau_s",))

    @property
    def variance(self) -> float:
        """σ², the prior variance of each term [rad²]."""
        return self.sigma_rad ** 2

    def describe(self) -> str:
        grown = "" if self.warmup_tau_s is None else f" grown as the module warms (τ {self.warmup_tau_s:g} s)"
        return (f"σ {math.degrees(self.sigma_rad):g}° on B sin ψ + C cos ψ{grown}"
                + ("" if self.learned else ", weighed, not learned")
                + (", learned from the headings and, with a place, the levelled field's inclination"
                   if self.dip else ""))

    def warming(self, seconds: float) -> float:
        """What the swing has grown to *seconds* after the compass's first calibrated reading: 1
        without a warm-up, else ``1 − e^(−t/τ)`` (0 before it or without a time)."""
        if self.warmup_tau_s is None:
            return 1.0
        if not seconds > 0.0:
            return 0.0
        return -math.expm1(-seconds / self.warmup_tau_s)


#: A calibrated compass's swing, learned (``--compass-swing``): what the calibration's iron and the
#: level at the end of the stance leave, 1.1 µT per axis against 15.3 µT of horizontal field (module
#: docstring); taught by the headings and, where the walk's place gives the field's inclination, by
#: the levelled field's dip (:mod:`hostlib.fusion.compass_dip`).
CALIBRATED_SWING = CompassSwing(math.radians(4.0), dip=True)
#: The swing the module's warming builds after a calibration, weighed and not learned: the horizontal
#: gyros' bias moves by the warm-up's σ (:data:`hostlib.fusion.module_errors.MIMU22BT`: 8.06e-4 rad/s,
#: τ 120 s), a swaying stance's ZUPTs hold the level off by about 4 s of it (0.18°), and a level
#: error δ turns a reading by up to δ Z/H, 3.2 at 72.5° inclination: σ 0.6° (module docstring).
WARMING_SWING = CompassSwing(math.radians(0.6), warmup_tau_s=120.0, learned=False)


def swing_basis(magnetic_heading: float) -> np.ndarray:
    """[sin ψ_m, cos ψ_m] at the board's magnetic heading *magnetic_heading* [rad]: a reading's
    heading error is this times the swing [B, C]."""
    return np.array([math.sin(magnetic_heading), math.cos(magnetic_heading)])
