"""The shoe's hard iron from end-of-stance readings: what level readings can and cannot determine.

A host sees the magnetometers once per step, at the end of the stance, with the foot flat on the
floor: the board's vertical stays within a few degrees of one direction while its heading turns
through every direction of the walk. Such readings lie on a band round the vertical, not on an
ellipsoid: the quadric fit of :func:`hostlib.calibration.magcal.fit_ellipsoid` cannot tell the vertical
semi-axis (soft iron) nor the vertical offset (hard iron) from the field's vertical component, and
with a disturbed field (a building's) it comes out as no ellipsoid at all.

What level readings do determine is the horizontal circle: levelled with the attitude's roll and
pitch (not its yaw), the horizontal field of reading k is ``Rz(ψ_k)ᵀ B_h + (T_k b)_xy``, a circle of
radius |B_h| about the hard iron's horizontal part. :func:`fit_level_hard_iron` fits that circle
(the algebraic least-squares fit, Kåsa's) and returns the hard iron in the board frame, its
component along the mean vertical set to 0: it is not observable from level readings, and a level
compass does not see it. The soft iron is left at the identity (two more parameters of a
horizontal ellipse would take up the floor's disturbance, not the shoe's iron).

The tilts of the readings differ from their mean by a few degrees, so taking the circle's centre
in each reading's levelled frame as the same offset costs the cosine of that difference: well
under a percent of the hard iron.

Whatever else turns the levelled horizontal field by a constant board-frame offset fits too: a
constant tilt error δθ of the attitude adds about B_v·δθ along the board axis it tilts, exactly
like a horizontal hard iron, and the circle takes it out with the iron.

:func:`iron_calibration` picks the model: the full ellipsoid when the readings' vertical spans at
least :data:`MIN_TILT_SPAN_DEG` (a wiggle, as NavShoe's in-situ calibration asks for) and the fit
is an ellipsoid, else the level circle; it says which and what the ellipsoid fit gave.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from hostlib.aids.compass import StanceReading
from hostlib.calibration.magcal import MagCalibration, MagCalibrationError, fit_ellipsoid
from hostlib.track.steps import rotation_z

__all__ = ["MIN_TILT_SPAN_DEG", "IronFit", "fit_level_hard_iron", "iron_calibration", "levelling",
           "tilt_span_deg"]

#: The spread of the board's vertical (95th percentile of its angle from the mean) below which the
#: readings are taken as level: an ellipsoid needs the shoe turned through tens of degrees.
MIN_TILT_SPAN_DEG = 30.0


def levelling(rotation: np.ndarray) -> np.ndarray:
    """The rotation that levels the board (its roll and pitch), without its yaw: ``Rz(−ψ) R``."""
    r = np.asarray(rotation, dtype=np.float64)
    return rotation_z(-math.atan2(r[1, 0], r[0, 0])) @ r


def tilt_span_deg(readings: Sequence[StanceReading]) -> float:
    """How far the board's vertical strays from its mean direction over *readings*: the 95th
    percentile of the angle [deg]."""
    down = np.array([np.asarray(r.rotation)[2] for r in readings])
    mean = down.mean(axis=0)
    mean /= np.linalg.norm(mean)
    return float(np.percentile(np.degrees(np.arccos(np.clip(down @ mean, -1.0, 1.0))), 95))


def fit_level_hard_iron(readings: Sequence[StanceReading]) -> tuple[MagCalibration, float]:
    """The hard iron (module docstring) of level *readings*, and the fitted horizontal field
    |B_h| [µT]. The calibration's RMS residual is that of the readings' distances from the circle."""
    if len(readings) < 3:
        raise MagCalibrationError(f"{len(readings)} readings; a circle needs at least 3")
    tilts = [levelling(r.rotation) for r in readings]
    u = np.array([(t @ r.field_board)[:2] for t, r in zip(tilts, readings, strict=True)])
    x, y = u.T
    design = np.column_stack([2.0 * x, 2.0 * y, np.ones(len(u))])
    (cx, cy, c), *_ = np.linalg.lstsq(design, x * x + y * y, rcond=None)
    radius = math.sqrt(max(c + cx * cx + cy * cy, 0.0))
    mean_tilt = np.mean(tilts, axis=0)
    w, _, vt = np.linalg.svd(mean_tilt)
    mean_tilt = w @ vt  # the nearest rotation
    hard = mean_tilt.T @ np.array([cx, cy, 0.0])
    residual = np.linalg.norm(u - [cx, cy], axis=1) - radius
    rms = float(np.sqrt(np.mean(residual ** 2)))
    cal = MagCalibration(hard, np.eye(3), field_ut=math.nan, rms_residual_ut=rms)
    return cal, radius


@dataclass(frozen=True)
class IronFit:
    """The calibration :func:`iron_calibration` chose, and why."""

    calibration: MagCalibration
    model: str  #: "ellipsoid" or "level circle"
    tilt_span_deg: float  #: :func:`tilt_span_deg` of the readings
    ellipsoid: str  #: what :func:`hostlib.calibration.magcal.fit_ellipsoid` made of the readings
    horizontal_ut: float = math.nan  #: the level circle's radius |B_h| [µT] (NaN for the ellipsoid)


def iron_calibration(readings: Sequence[StanceReading]) -> IronFit:
    """The shoe's iron from *readings* (module docstring: ellipsoid if they span it, else the circle)."""
    span = tilt_span_deg(readings)
    try:
        full = fit_ellipsoid([r.field_board for r in readings])
        ellipsoid = (f"an ellipsoid, hard iron {np.round(full.hard_iron, 1).tolist()} µT, "
                     f"soft-iron eigenvalues {np.round(np.linalg.eigvalsh(full.soft_iron), 2).tolist()}")
    except MagCalibrationError as exc:
        full, ellipsoid = None, f"refused: {exc}"
    if full is not None and span >= MIN_TILT_SPAN_DEG:
        return IronFit(full, "ellipsoid", span, ellipsoid)
    cal, radius = fit_level_hard_iron(readings)
    return IronFit(cal, "level circle", span, ellipsoid, radius)
