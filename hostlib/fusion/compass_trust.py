"""How far the filter trusts a compass reading: the field it must be, and what an uncalibrated shoe
costs it.

**The field check.** :func:`field_check` is the reference a reading's field is held against
(:class:`hostlib.aids.field_check.FieldCheck`): the magnitude a magnetometer calibration mapped its
readings onto, when it says, else the World Magnetic Model's total intensity at the walk's place
(:attr:`FusionSettings.magnetic_field <hostlib.fusion.settings.FusionSettings.magnetic_field>`), and
the model's inclination, when the place is known. With neither, no reading is checked. The
disturbance an honest reading may carry (:func:`disturbance_ut`) is what is left of the shoe's iron
(:func:`iron_left_ut`) and the local deviation in microtesla.

**An uncalibrated compass.** A shoe's hard iron b adds to the field a vector fixed in the board's
frame; with the foot level, its part across the horizontal field H turns the heading by about
b⊥ / H. Nobody calibrated the shoe, and the filter does not learn b
(:attr:`FusionSettings.hard_iron <hostlib.fusion.settings.FusionSettings.hard_iron>` not held): then
each reading carries an error of σ atan(σ_b / H) (:func:`~hostlib.fusion.hard_iron.iron_heading_sigma`)
that is the same reading after reading while the heading holds. The filter weighs the compass for it
(:attr:`FusionSettings.uncalibrated_iron <hostlib.fusion.settings.FusionSettings.uncalibrated_iron>`):
the local deviation's variance gains atan(σ_b / H)² — the deviation is the correlated part of a
reading's error, as the iron's is (an approximation: the iron's error stays while the heading does,
the deviation's fades over its length) — or, without the deviation held, the reading's own.
H is the WMM's horizontal intensity at the place, or, without a place, the horizontal field the
compass's first reading measures.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from ..aids.field_check import WMM_INCLINATION_SIGMA_RAD, WMM_TOTAL_SIGMA_UT, FieldCheck
from .hard_iron import CALIBRATED, UNCALIBRATED

if TYPE_CHECKING:
    from ..calibration.magcal import MagCalibration
    from .settings import FusionSettings

__all__ = ["disturbance_ut", "field_check", "iron_left_ut", "weighs_uncalibrated"]


def field_check(settings: FusionSettings, calibration: MagCalibration | None) -> FieldCheck | None:
    """The reference a reading calibrated with *calibration* is checked against (module docstring);
    None: nothing to check it against, or every reading used (no gate)."""
    if settings.compass_gate_sigmas is None:
        return None
    wmm = settings.magnetic_field
    inclination = None if wmm is None else math.radians(wmm.inclination_deg)
    if calibration is not None and math.isfinite(calibration.field_ut) and calibration.field_ut > 0.0:
        residual = calibration.rms_residual_ut if math.isfinite(calibration.rms_residual_ut) else 0.0
        return FieldCheck(calibration.field_ut, inclination, residual, WMM_INCLINATION_SIGMA_RAD,
                          "the calibration's field" + ("" if wmm is None else ", the WMM's inclination"),
                          settings.compass_gate_sigmas)
    if wmm is None:
        return None
    return FieldCheck(wmm.total_nt / 1000.0, inclination, WMM_TOTAL_SIGMA_UT, WMM_INCLINATION_SIGMA_RAD,
                      "WMM", settings.compass_gate_sigmas)


def iron_left_ut(settings: FusionSettings, calibration: MagCalibration | None) -> float:
    """1σ per axis [µT] of the shoe's iron left in a reading: the learned iron's prior, held; a
    calibration's remainder (:data:`~hostlib.fusion.hard_iron.CALIBRATED`); else the whole iron
    (:attr:`~hostlib.fusion.settings.FusionSettings.uncalibrated_iron`, or
    :data:`~hostlib.fusion.hard_iron.UNCALIBRATED`)."""
    if settings.hard_iron is not None:
        return settings.hard_iron.sigma_ut
    if calibration is not None:
        return CALIBRATED.sigma_ut
    return (settings.uncalibrated_iron or UNCALIBRATED).sigma_ut


def disturbance_ut(settings: FusionSettings, calibration: MagCalibration | None,
                   horizontal_ut: float) -> float:
    """1σ per axis [µT] an honest reading's field may differ from the Earth's by: the iron left
    (:func:`iron_left_ut`) and the local deviation, its heading σ (held, σ_d; else the compass's σ_c,
    all of it) across the horizontal field *horizontal_ut*."""
    deviation = settings.compass_deviation
    sigma = deviation.sigma_rad if deviation is not None else settings.compass_sigma_rad
    return math.hypot(iron_left_ut(settings, calibration), math.tan(sigma) * horizontal_ut)


def weighs_uncalibrated(settings: FusionSettings, calibration: MagCalibration | None) -> bool:
    """Whether the compass is weighed for an unknown hard iron (module docstring): asked for
    (:attr:`~hostlib.fusion.settings.FusionSettings.uncalibrated_iron`), no *calibration*, and the
    iron not learned."""
    return settings.uncalibrated_iron is not None and calibration is None and settings.hard_iron is None
