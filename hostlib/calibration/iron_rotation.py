"""The shoe iron's rotation of the field, from the attitude: what an ellipsoid fit cannot see.

The shoe's soft iron is a 3×3 matrix I + S = V U, a symmetric distortion V times a rotation U. An
ellipsoid fit of the readings alone (:mod:`hostlib.calibration.magcal`) recovers the hard iron and V⁻¹: its
calibrated field m_c = A (m − b) has the right magnitude, but it is the board-frame field turned
by U — the readings of a sphere are the same however it is turned. With the iron's elements a few
per cent, U turns the field by a degree or two, and a tilt δ of the field turns a level compass by
up to tan I · δ (3.2 δ at Stockholm's 72.5° inclination).

The attitude sees it. The board-frame field is R_m m_c for one small rotation R_m (= Uᵀ), and in
the navigation frame R(q) R_m m_c is the Earth's field at the spot, the same in every attitude.
:func:`fit_iron_rotation` uses only the part of that which the module's attitude can vouch for:
the field's angle with the vertical (its inclination) is the same in every reading,

    g_kᵀ R_m u_k = sin I   for all k,

with u_k the calibrated field's direction and g_k the vertical (down) in the board frame, the
attitude's third row. Its horizontal direction is left out: the module zeroes the quaternion's yaw
at every reset of its INS, and during a wiggle every hold is a stance, so the yaw restarts at each
of them; keeping it would take one unknown heading per stretch between resets, and the resets are
not marked in the stream. The inclination alone needs no yaw, and it determines all three angles
of R_m as soon as the vertical moves in the board frame (tilting the shoe): a rotation about an
axis the vertical never leaves does not change the field's angle with it. A heading offset common
to all readings (a turn of the field about the vertical) is not the iron's anyway: it is the
declination's and the heading's.

The estimate is Gauss–Newton on the four unknowns R_m (three small angles, updated as
R_m ← exp([δ]×) R_m) and sin I, from R_m = I; the residuals are linear in both to first order
(∂/∂δ of g·exp([δ]×) v is v × g), and a few iterations converge. Only readings with the shoe held
still count (:data:`STILL_TILT_DEG`): a stream packet's attitude is the INS's, which runs half
the detector window behind the newest sample, while its magnetometers are the newest read (held
at 100 Hz): 6–16 ms apart at 1 kHz. While the shoe tilts, that mismatch tilts the field by as
much as the iron does; fitted on all a wiggle's readings, the rotation comes out 0.7° off, mostly
about the board's z axis. (A turn about the vertical does not matter: it keeps the angle with it.)

It refuses — :class:`hostlib.calibration.magcal.MagCalibrationError`, saying why — readings that do not
determine the rotation: too few held still; attitudes that leave it so uncertain that a level
compass could be off by more than the caller's limit (1σ, worst heading: the vertical never left
one axis of the board); or readings whose inclination scatters by more than
:data:`MAX_INCLINATION_SCATTER_DEG` about the fit (the attitude does not go with the magnetometers,
the field changed, or the ellipsoid is off: a distortion left in the calibrated field turns
different directions differently, which no one rotation undoes).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..aids.compass import StanceReading
from ..track.steps import rotation_z
from .magcal import MIN_READINGS, MagCalibration, MagCalibrationError

__all__ = ["MAX_INCLINATION_SCATTER_DEG", "STILL_TILT_DEG", "IronRotation", "fit_iron_rotation",
           "rotation_of_vector", "still_readings"]

#: A reading counts as held still when the board's vertical moved by at most this [deg] to the
#: readings before and after it: 12.5°/s at the stream's 62.5 Hz, so that the attitude (up to
#: 16 ms older than the magnetometers) is off by at most 0.2° from theirs.
STILL_TILT_DEG = 0.2
#: The largest RMS scatter [deg] of the readings' inclination about the fit. In simulation
#: (``python -m lab.accuracy magcal``, docs/heading-aids.md) a wiggle tilting the shoe by up to 90°
#: leaves 0.4° (the chips' noise), 80° 0.6° and 70° 1.5°, where the ellipsoid's own error starts
#: to show; 65° leaves 2.6° and 60° 4.4°, whose ellipsoids the calibration refuses and where
#: turning them helps little or harms. An attitude that does not go with the field leaves tens
#: of degrees.
MAX_INCLINATION_SCATTER_DEG = 2.0
#: Gauss–Newton's iterations at the most, and the step [rad] below which it stops.
_ITERATIONS = 20
_CONVERGED_RAD = 1e-10
#: Level headings at which :meth:`IronRotation.heading_sigma_deg` looks [deg].
_LEVEL_HEADINGS_DEG = np.arange(0.0, 180.0, 15.0)
_AXES = "xyz"


@dataclass(frozen=True)
class IronRotation:
    """The field's rotation R_m in the board frame: the board-frame field is ``rotation @ m_c``
    for a calibrated field m_c of the ellipsoid fit."""

    rotation: np.ndarray  #: (3, 3)
    inclination_deg: float  #: the field's inclination the readings agree on (down positive)
    #: (3, 3) [rad²] covariance of the rotation vector (board frame), from the residuals' scatter
    covariance: np.ndarray
    scatter_deg: float  #: RMS of the readings' inclination about the fit
    readings: int  #: the readings held still that it was fitted on

    def heading_sigma_deg(self) -> float:
        """The 1σ heading error [deg] its covariance leaves on a level compass, worst over
        headings. With the level board at heading ψ from magnetic north the rotation vector is
        φ = R_z(ψ) θ in the navigation frame, and the compass turns by φ_x tan I − φ_z: a tilt
        about the horizontal field counts tan I times, a turn about the vertical once."""
        if not np.isfinite(self.covariance).all():
            return math.inf
        a = np.array([math.tan(math.radians(self.inclination_deg)), 0.0, -1.0])
        worst = max(float(a @ r @ self.covariance @ r.T @ a)
                    for r in (rotation_z(math.radians(psi)) for psi in _LEVEL_HEADINGS_DEG))
        return math.degrees(math.sqrt(max(worst, 0.0)))


def still_readings(readings: Sequence[StanceReading]) -> list[StanceReading]:
    """The *readings* (in the order they came) whose board vertical moved by at most
    :data:`STILL_TILT_DEG` to their neighbours'; the first and the last reading each have one
    neighbour."""
    if len(readings) < 2:
        return list(readings)
    down = np.array([r.rotation[2] for r in readings], dtype=np.float64)
    down /= np.linalg.norm(down, axis=1, keepdims=True)
    moved = np.degrees(np.arccos(np.clip(np.sum(down[1:] * down[:-1], axis=1), -1.0, 1.0)))
    before = np.concatenate([moved[:1], moved])
    after = np.concatenate([moved, moved[-1:]])
    keep = np.maximum(before, after) <= STILL_TILT_DEG
    return [r for r, k in zip(readings, keep, strict=True) if k]


def rotation_of_vector(theta) -> np.ndarray:
    """The rotation of the rotation vector *theta* [rad] (Rodrigues)."""
    theta = np.asarray(theta, dtype=np.float64)
    angle = float(np.linalg.norm(theta))
    if angle == 0.0:
        return np.eye(3)
    k = theta / angle
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + math.sin(angle) * kx + (1.0 - math.cos(angle)) * (kx @ kx)


def _linearised(u: np.ndarray, down: np.ndarray, rotation: np.ndarray,
                sin_inclination: float) -> tuple[np.ndarray, np.ndarray]:
    """The residuals g_kᵀ R_m u_k − sin I (n,) and their Jacobian (n, 4) with respect to a small
    rotation δ (R_m ← exp([δ]×) R_m) and sin I."""
    v = u @ rotation.T
    residual = np.sum(down * v, axis=1) - sin_inclination
    return residual, np.column_stack([np.cross(v, down), -np.ones(len(v))])


def _weakest_axis(information: np.ndarray) -> str:
    """The board axis closest to the rotation the readings determine least."""
    _, vectors = np.linalg.eigh(information)
    return _AXES[int(np.argmax(np.abs(vectors[:, 0])))]


def fit_iron_rotation(calibration: MagCalibration, readings: Sequence[StanceReading],
                      max_heading_sigma_deg: float,
                      max_scatter_deg: float = MAX_INCLINATION_SCATTER_DEG) -> IronRotation:
    """R_m of the ellipsoid fit *calibration* from *readings* in the order they came (module
    docstring); :class:`MagCalibrationError` saying why when they do not determine it, leave a
    level compass uncertain by more than *max_heading_sigma_deg* (1σ, worst heading), or scatter
    about it by more than *max_scatter_deg* in inclination (RMS)."""
    still = still_readings(readings)
    if len(still) < MIN_READINGS:
        raise MagCalibrationError(f"{len(still)} readings with the shoe held still (at least "
                                  f"{MIN_READINGS}): hold each orientation for a moment")
    field = calibration.apply(np.array([r.field_board for r in still]))
    u = field / np.linalg.norm(field, axis=1, keepdims=True)
    down = np.array([r.rotation[2] for r in still], dtype=np.float64)
    down /= np.linalg.norm(down, axis=1, keepdims=True)
    if not (np.isfinite(u).all() and np.isfinite(down).all()):
        raise MagCalibrationError("readings or attitudes that are not finite numbers")
    rotation = np.eye(3)
    sin_inclination = float(np.mean(np.sum(down * u, axis=1)))
    for _ in range(_ITERATIONS):
        residual, jacobian = _linearised(u, down, rotation, sin_inclination)
        step, *_ = np.linalg.lstsq(jacobian, -residual, rcond=None)
        rotation = rotation_of_vector(step[:3]) @ rotation
        sin_inclination += float(step[3])
        if float(np.linalg.norm(step[:3])) < _CONVERGED_RAD:
            break
    residual, jacobian = _linearised(u, down, rotation, sin_inclination)
    information = jacobian.T @ jacobian
    # the three angles' information once sin I is eliminated (Schur complement)
    angles = information[:3, :3] - np.outer(information[:3, 3], information[3, :3]) / information[3, 3]
    variance = float(np.sum(residual ** 2)) / max(len(residual) - 4, 1)
    eig = np.linalg.eigvalsh(angles)
    determined = eig[0] > 1e-9 * max(float(eig[-1]), 1e-300)
    covariance = variance * np.linalg.inv(angles) if determined else np.full((3, 3), math.inf)
    inclination = math.degrees(math.asin(float(np.clip(sin_inclination, -1.0, 1.0))))
    # the inclination's scatter: the residual is a change of sin I, cos I per radian of it
    scatter = math.degrees(math.sqrt(variance) / max(math.cos(math.radians(inclination)), 1e-9))
    result = IronRotation(rotation, inclination, covariance, scatter, len(still))
    if not scatter <= max_scatter_deg:
        raise MagCalibrationError(f"the field's inclination scatters {scatter:.1f}° RMS about the fit over "
                                  f"the attitudes (at most {max_scatter_deg:.1f}°): the attitude does not go "
                                  f"with the magnetometers, the field changed, or the ellipsoid is off")
    sigma = result.heading_sigma_deg()
    if not sigma <= max_heading_sigma_deg:
        raise MagCalibrationError(f"the attitudes leave the field's rotation about the board's "
                                  f"{_weakest_axis(angles)} axis undetermined (a level compass "
                                  f"±{sigma:.1f}°, at most {max_heading_sigma_deg:.1f}°): the shoe was not "
                                  f"tilted while held still")
    return result
