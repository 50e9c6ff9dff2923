"""The levelled field's inclination (its dip) as a measurement of a calibrated compass's swing.

A calibrated compass's swing B sin ψ + C cos ψ (:mod:`hostlib.fusion.compass_swing`) is a small
vector fixed in the board's frame: the tilt δ of the attitude a reading is levelled with at the end
of the stance (the module's level drifting as its dies warm; the magnetometers a few milliseconds
newer than the attitude), and the iron a calibration left. At the board's magnetic heading ψ_m, the
part of a tilt about magnetic north turns the levelled field's horizontal direction by Z/H times
itself; the part about magnetic east turns the field in its vertical plane, its dip by as much. The
same board-fixed tilt, seen at a heading a quarter turn on, swaps the two. So a reading whose heading
reads short by the swing, ψ_c = χ − D − d − (B sin ψ_m + C cos ψ_m), has its dip off by

    κ (C sin ψ_m − B cos ψ_m),   κ = H/Z = cot I

(for the iron left in the board's horizontal κ is sin I cos I, 10 % less at 72.5°: the tilt's is
used, the warming's cause). The heading readings alone cannot tell the swing from the heading the
module drifted by between the walk's legs, nor, at one heading, from the declination; the dip knows
nothing of the heading, the declination or the module's drift. Where the walk turns, the dips at one
heading tell the swing that the headings a quarter turn away suffer from, and the filter carries
that to the declination and the heading through their covariances with the swing.

A reading's dip, measured against the World Magnetic Model's inclination, carries besides:

* a constant offset o: the model's own error (0.21°,
  :data:`~hostlib.aids.field_check.WMM_INCLINATION_SIGMA_RAD`) and the calibration's vertical iron
  left (1 µT, :data:`~hostlib.fusion.hard_iron.CALIBRATED`, which turns the dip by H/F² per µT);
* the local deviation of the field where the foot stands: per axis as large as the one that turns
  the heading by σ_d (σ_d H per axis), it turns the dip by σ_d H/F = σ_d cos I, correlated over the
  same length (:mod:`hostlib.fusion.deviation`): a second state d_I, walked as d is;
* the reading's own white error, the chips' noise: σ_c cos I for the same reason.

State ``"dip"`` = [o, d_I] (:mod:`hostlib.fusion.aid_states`), held with a swing the dip teaches
(:attr:`~hostlib.fusion.compass_swing.CompassSwing.dip`), the compass's local deviation and a place
(the WMM's field): without a place there is no inclination to measure the dip against, and the
headings alone teach the swing.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from ..aids.field_check import WMM_INCLINATION_SIGMA_RAD, level_field
from .core import StateFilter
from .gauss_markov import decay, transition
from .hard_iron import CALIBRATED

if TYPE_CHECKING:
    from .settings import FusionSettings, FusionStats

__all__ = ["DipAid", "dip_prior", "dip_swing_row", "held"]


def held(s: FusionSettings) -> bool:
    """Whether *s* hold the dip's states: the compass, its swing learned from the dip, its local
    deviation and the WMM's field at the place."""
    return bool(s.compass and s.compass_swing is not None and s.compass_swing.dip
                and s.hard_iron is None and s.compass_deviation is not None and s.magnetic_field is not None)


def _field(s: FusionSettings) -> tuple[float, float, float]:
    """(I [rad], H [µT], F [µT]) of the WMM's field in *s*."""
    wmm = s.magnetic_field
    return math.radians(wmm.inclination_deg), wmm.horizontal_nt / 1000.0, wmm.total_nt / 1000.0


def dip_prior(s: FusionSettings) -> tuple[np.ndarray, np.ndarray] | None:
    """The prior of [o, d_I] (module docstring), or None when *s* do not hold them."""
    if not held(s):
        return None
    inclination, horizontal, total = _field(s)
    offset = math.hypot(WMM_INCLINATION_SIGMA_RAD, CALIBRATED.sigma_ut * horizontal / total ** 2)
    local = s.compass_deviation.sigma_rad * math.cos(inclination)
    return np.zeros(2), np.diag([offset ** 2, local ** 2])


def dip_swing_row(magnetic_heading: float, inclination_rad: float) -> np.ndarray:
    """∂dip/∂[B, C] at the board's *magnetic_heading* [rad]: κ [−cos ψ_m, sin ψ_m], κ = cot I (a
    reading's heading is ψ_c = χ − D − d − (B sin ψ_m + C cos ψ_m))."""
    kappa = 1.0 / math.tan(inclination_rad)
    return kappa * np.array([-math.cos(magnetic_heading), math.sin(magnetic_heading)])


class DipAid:
    """The dip's measurement and its states' process noise on an aided filter (a mixin of
    :class:`~hostlib.fusion.aided.AidedFilter`, which has the attributes below)."""

    filter: StateFilter
    aid_settings: FusionSettings
    fusion: FusionStats

    def _walk_dip(self, distance_m: float) -> None:
        """The dip's local deviation d_I (held) after a walk of *distance_m* [m], as d's."""
        if "dip" not in self.filter:
            return
        s = self.aid_settings
        variance = (s.compass_deviation.sigma_rad * math.cos(_field(s)[0])) ** 2
        f = self.filter
        decay(f.x, f.P, [f.index("dip", 1)], *transition(distance_m, s.compass_deviation.length_m, variance))

    def _dip_step(self, reading: tuple[np.ndarray, np.ndarray], magnetic_heading: float) -> None:
        """A calibrated *reading* (board-frame field [µT], board → navigation rotation) at the
        filter's *magnetic_heading* [rad] measures o + d_I + κ (C sin ψ_m − B cos ψ_m) (module
        docstring), within the compass's gate; the swing, o and d_I learn from it."""
        if "dip" not in self.filter:
            return
        s = self.aid_settings
        inclination = _field(s)[0]
        dip = level_field(*reading)[1] - inclination
        f = self.filter
        row = dip_swing_row(magnetic_heading, inclination)
        h = f.row({("dip", 0): 1.0, ("dip", 1): 1.0, ("swing", 0): float(row[0]),
                   ("swing", 1): float(row[1])})
        innovation = dip - float(h @ f.x)
        r = (s.compass_sigma_rad * math.cos(inclination)) ** 2
        gate = s.compass_gate_sigmas
        if gate is not None and innovation ** 2 > gate ** 2 * (float(h @ f.P @ h) + r):
            self.fusion.dip_rejected += 1
            return
        f.update(h, innovation, r)
        self.fusion.dip_updates += 1
