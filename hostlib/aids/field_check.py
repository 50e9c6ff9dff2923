"""Is a compass reading the Earth's field? Its magnitude and inclination against what the field is.

A heading is only as good as the field it is taken from. The Earth's field at a place has a known
total intensity F and inclination I (the World Magnetic Model, :mod:`hostlib.aids.declination`; or
the magnitude a magnetometer calibration mapped its readings onto,
:attr:`hostlib.calibration.magcal.MagCalibration.field_ut`). A reading near steel or a magnet, or
taken while the foot was not still, has another magnitude or another dip, and its heading is then
not a heading of the Earth's field: :class:`FieldCheck` rejects it before the filter sees it.

The tolerance comes from what may make an honest reading differ from the reference, each a 1σ:

* the reference itself: the WMM's own error (:data:`WMM_TOTAL_SIGMA_UT`,
  :data:`WMM_INCLINATION_SIGMA_RAD`), or the calibration's residual;
* a disturbance δ per axis of the field [µT]: what is left of the shoe's iron (the whole of it
  uncalibrated, :data:`hostlib.fusion.hard_iron.UNCALIBRATED`; a calibration's remainder,
  :data:`~hostlib.fusion.hard_iron.CALIBRATED`) and the local deviation (its heading σ times the
  horizontal field: tan σ_d · H). Along the field's direction it changes the magnitude by δ, across
  it the dip by δ / F;
* the level the reading is taken in: roll and pitch at the end of a stance are good to
  :data:`TILT_SIGMA_RAD` (an accelerometer bias of about 9 mg), which turns the dip as much.

So σ_F² = σ_ref,F² + δ² and σ_I² = σ_ref,I² + (δ / F)² + σ_tilt², and a reading whose magnitude or
inclination lies more than *sigmas* of them from the reference is rejected (3σ, the innovation
gate's: 99.7 % of honest readings pass each test).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["TILT_SIGMA_RAD", "WMM_INCLINATION_SIGMA_RAD", "WMM_TOTAL_SIGMA_UT", "FieldCheck",
           "level_field"]

#: The WMM's global 1σ error of the total intensity F [µT] (the WMM 2020 report's error model: 145 nT).
WMM_TOTAL_SIGMA_UT = 0.145
#: The WMM's global 1σ error of the inclination I [rad] (the same error model: 0.21°).
WMM_INCLINATION_SIGMA_RAD = math.radians(0.21)
#: 1σ of the level (roll, pitch) at the end of a stance [rad]: the accelerometers' bias after a run of
#: zero-velocity updates, about 9 mg, is 0.5°.
TILT_SIGMA_RAD = math.radians(0.5)


def level_field(field_board: np.ndarray, rotation: np.ndarray) -> tuple[float, float, float]:
    """The field of a reading levelled with its attitude: its magnitude F [µT], inclination I [rad]
    (down positive) and horizontal intensity H [µT]."""
    n = np.asarray(rotation, dtype=np.float64) @ np.asarray(field_board, dtype=np.float64).reshape(3)
    horizontal = math.hypot(float(n[0]), float(n[1]))
    return float(np.linalg.norm(n)), math.atan2(float(n[2]), horizontal), horizontal


@dataclass(frozen=True)
class FieldCheck:
    """The reference field a reading is held against (module docstring): its magnitude *total_ut*
    and inclination *inclination_rad* (None: not known, the magnitude alone is checked), each with
    its own 1σ, where they come from (*source*), and how many σ a reading may lie from them."""

    total_ut: float
    inclination_rad: float | None
    total_sigma_ut: float
    inclination_sigma_rad: float
    source: str
    sigmas: float = 3.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.total_ut) and self.total_ut > 0.0):
            raise ValueError(f"a reference field is a magnitude > 0 µT, not {self.total_ut}")
        if not self.sigmas > 0.0:
            raise ValueError(f"sigmas must be > 0, not {self.sigmas}")

    def tolerance(self, disturbance_ut: float) -> tuple[float, float]:
        """(σ_F [µT], σ_I [rad]) of an honest reading whose field may be off by *disturbance_ut* per
        axis (module docstring)."""
        sigma_f = math.hypot(self.total_sigma_ut, disturbance_ut)
        sigma_i = math.sqrt(self.inclination_sigma_rad ** 2 + (disturbance_ut / self.total_ut) ** 2
                            + TILT_SIGMA_RAD ** 2)
        return sigma_f, sigma_i

    def problem(self, field_board: np.ndarray, rotation: np.ndarray, disturbance_ut: float) -> str | None:
        """Why a reading (the calibrated board-frame field [µT] and its board → navigation rotation)
        is not the Earth's field, or None when it may be."""
        total, inclination, _ = level_field(field_board, rotation)
        sigma_f, sigma_i = self.tolerance(disturbance_ut)
        if not math.isfinite(total) or abs(total - self.total_ut) > self.sigmas * sigma_f:
            return (f"magnitude {total:.1f} µT, the field is {self.total_ut:.1f} ± "
                    f"{self.sigmas * sigma_f:.1f} µT")
        dip = self.inclination_rad
        if dip is not None and abs(inclination - dip) > self.sigmas * sigma_i:
            return (f"inclination {math.degrees(inclination):.1f}°, the field's is "
                    f"{math.degrees(self.inclination_rad):.1f} ± {math.degrees(self.sigmas * sigma_i):.1f}°")
        return None

    def describe(self) -> str:
        dip = self.inclination_rad
        return (f"{self.total_ut:.1f} µT" + ("" if dip is None else f", inclination {math.degrees(dip):.1f}°")
                + f" ({self.source})")
