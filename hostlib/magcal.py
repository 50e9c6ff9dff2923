"""The shoe's hard and soft iron: an ellipsoid fit of magnetometer readings, kept per module.

Metal in the sole adds a constant offset b (hard iron, 3 numbers) and a distortion (soft iron, a
3×3 matrix) to the field the magnetometers see (shared/spec/aids.md §3). While the wearer wiggles
the shoe in place the true field is constant, so the readings lie on an ellipsoid; fitting it and
mapping it back onto a sphere of the local field's magnitude recovers::

    m_true ≈ A (m_read − b)

with A symmetric (a rotation of the whole sphere is not observable from the readings alone; it
is the part of the soft iron no fit recovers). :func:`fit_ellipsoid` is the algebraic
least-squares fit of the general quadric ``mᵀ M m + 2 vᵀ m = 1``; :class:`MagCalibration` applies,
saves and loads the result, with the module's serial number it belongs to.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .errors import HostError

__all__ = ["MagCalibration", "MagCalibrationError", "fit_ellipsoid"]

#: Readings needed at the least (9 unknowns; a wiggle gives thousands).
MIN_READINGS = 30


class MagCalibrationError(HostError, ValueError):
    """Readings that do not determine an ellipsoid, or a calibration file that is not one."""


@dataclass(frozen=True)
class MagCalibration:
    """``m_true = soft_iron @ (m_read − hard_iron)`` in the board frame [µT]."""

    hard_iron: np.ndarray  #: (3,) µT
    soft_iron: np.ndarray  #: (3, 3), symmetric
    module_serial: str = ""  #: the module it was fitted on ("" unknown)
    field_ut: float = float("nan")  #: the field magnitude the readings were mapped onto
    rms_residual_ut: float = float("nan")  #: RMS of |A(m − b)| − field over the readings

    def apply(self, field_board) -> np.ndarray:
        """The calibrated field of a reading (3,) or readings (n, 3)."""
        m = np.asarray(field_board, dtype=np.float64)
        return (m - self.hard_iron) @ self.soft_iron.T

    def to_json(self) -> dict[str, Any]:
        return {"kind": "openshoe-mag-calibration", "module_serial": self.module_serial,
                "hard_iron_ut": self.hard_iron.tolist(), "soft_iron": self.soft_iron.tolist(),
                "field_ut": self.field_ut, "rms_residual_ut": self.rms_residual_ut}

    def save(self, path: str | Path) -> None:
        Path(path).write_text(json.dumps(self.to_json(), indent=2) + "\n")

    @classmethod
    def load(cls, path: str | Path) -> MagCalibration:
        """Read a file :meth:`save` wrote; :class:`MagCalibrationError` naming the file otherwise."""
        try:
            doc = json.loads(Path(path).read_text())
            if doc.get("kind") != "openshoe-mag-calibration":
                raise ValueError("not a magnetometer calibration (kind)")
            hard = np.asarray(doc["hard_iron_ut"], dtype=np.float64)
            soft = np.asarray(doc["soft_iron"], dtype=np.float64)
            if hard.shape != (3,) or soft.shape != (3, 3) or not (np.isfinite(hard).all()
                                                                  and np.isfinite(soft).all()):
                raise ValueError("hard_iron_ut must be 3 and soft_iron 3×3 finite numbers")
            return cls(hard, soft, str(doc.get("module_serial", "")), float(doc.get("field_ut", "nan")),
                       float(doc.get("rms_residual_ut", "nan")))
        except (OSError, ValueError, KeyError, TypeError, AttributeError) as exc:
            raise MagCalibrationError(f"{path}: {exc}") from exc

    def check_module(self, module_serial: str) -> None:
        """Refuse to apply a calibration fitted on another module (the iron is the shoe's)."""
        if self.module_serial and module_serial and self.module_serial != module_serial:
            raise MagCalibrationError(f"this magnetometer calibration belongs to module "
                                      f"{self.module_serial}, not {module_serial}")


def fit_ellipsoid(readings, field_ut: float | None = None, module_serial: str = "") -> MagCalibration:
    """Fit readings (n, 3) [µT] taken while the field was constant and the shoe turned through
    many orientations; map them onto a sphere of radius *field_ut* (default: the readings' mean
    magnitude after the fit's centring — it scales the field, never the heading)."""
    m = np.asarray(readings, dtype=np.float64)
    if m.ndim != 2 or m.shape[1] != 3:
        raise MagCalibrationError(f"readings must be (n, 3), got {m.shape}")
    m = m[np.isfinite(m).all(axis=1)]
    if len(m) < MIN_READINGS:
        raise MagCalibrationError(f"{len(m)} readings; an ellipsoid fit needs at least {MIN_READINGS}")
    scale = float(np.abs(m).max()) or 1.0
    u = m / scale  # conditioning
    x, y, z = u.T
    design = np.column_stack([x * x, y * y, z * z, 2 * x * y, 2 * x * z, 2 * y * z, 2 * x, 2 * y, 2 * z])
    coef, _, rank, _ = np.linalg.lstsq(design, np.ones(len(u)), rcond=1e-9)
    if rank < design.shape[1]:
        raise MagCalibrationError("the readings do not span an ellipsoid (turn the shoe more)")
    a, b, c, d, e, f, g, h, i = coef
    quad = np.array([[a, d, e], [d, b, f], [e, f, c]])
    lin = np.array([g, h, i])
    try:
        centre = -np.linalg.solve(quad, lin)
    except np.linalg.LinAlgError as exc:
        raise MagCalibrationError("the readings do not span an ellipsoid (turn the shoe more)") from exc
    k = 1.0 + float(centre @ quad @ centre)
    shape = quad / k
    w, v = np.linalg.eigh(shape)
    if not (w > 0).all():
        raise MagCalibrationError("the readings do not span an ellipsoid (turn the shoe more)")
    sqrt_shape = v @ np.diag(np.sqrt(w)) @ v.T  # maps the ellipsoid onto the unit sphere
    hard = centre * scale
    unit = (m - hard) @ (sqrt_shape / scale).T
    radius = float(field_ut) if field_ut is not None else float(np.mean(np.linalg.norm(unit, axis=1)))
    soft = sqrt_shape / scale * radius
    residual = np.linalg.norm((m - hard) @ soft.T, axis=1) - radius
    return MagCalibration(hard, soft, module_serial, radius, float(np.sqrt(np.mean(residual ** 2))))
