"""The shoe's hard and soft iron: an ellipsoid fit of magnetometer readings, kept per module.

Metal in the sole adds a constant offset b (hard iron, 3 numbers) and a distortion (soft iron, a
3×3 matrix) to the field the magnetometers see (shared/spec/aids.md §3). While the wearer wiggles
the shoe in place the true field is constant, so the readings lie on an ellipsoid; fitting it and
mapping it back onto a sphere of the local field's magnitude recovers::

    m_true ≈ A (m_read − b)

with A symmetric: a rotation of the whole sphere is not observable from the readings alone, so it
is the part of the soft iron no fit of them recovers. With the attitude of each reading it is
(:mod:`hostlib.calibration.iron_rotation`), and :meth:`MagCalibration.turned` makes the soft iron R_m A, no
longer symmetric. :func:`fit_ellipsoid` is the algebraic
least-squares fit of the general quadric ``mᵀ M m + 2 vᵀ m = 1`` (:func:`fit_quadric`, which also
gives the covariance of its nine coefficients, from which a caller can judge how well the readings
determine what it needs); :class:`MagCalibration` applies, saves and loads the result, with the
module's serial number it belongs to.

Saved per module: :func:`save_for_module` writes ``<serial>.json`` into :func:`calibration_dir` —
``$OPENSHOE_MAGCAL_DIR`` when set, else ``$XDG_CONFIG_HOME/openshoe/magcal`` (``~/.config`` when
XDG_CONFIG_HOME is unset) — and :func:`load_for_module` finds it again for the same module.
"""

from __future__ import annotations

import json
import math
import os
import re
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import HostError
from ..inputs import InputFileError, load_json

__all__ = ["MAGCAL_DIR_ENV", "MagCalibration", "MagCalibrationError", "QuadricFit", "calibration_dir",
           "fit_ellipsoid", "fit_quadric", "load_for_module", "module_file", "save_for_module"]

#: Readings needed at the least (9 unknowns; a wiggle gives thousands).
MIN_READINGS = 30
#: The environment variable that names the directory of the per-module calibrations.
MAGCAL_DIR_ENV = "OPENSHOE_MAGCAL_DIR"


class MagCalibrationError(HostError, ValueError):
    """Readings that do not determine an ellipsoid, or a calibration file that is not one."""


@dataclass(frozen=True)
class MagCalibration:
    """``m_true = soft_iron @ (m_read − hard_iron)`` in the board frame [µT]."""

    hard_iron: np.ndarray  #: (3,) µT
    #: (3, 3): symmetric from an ellipsoid fit; a rotation times that once turned with the attitude
    soft_iron: np.ndarray
    module_serial: str = ""  #: the module it was fitted on ("" unknown)
    field_ut: float = float("nan")  #: the field magnitude the readings were mapped onto
    rms_residual_ut: float = float("nan")  #: RMS of |A(m − b)| − field over the readings
    #: how far [deg] the attitude turned the ellipsoid's soft iron (:meth:`turned`; NaN: it did not)
    rotation_deg: float = float("nan")

    def apply(self, field_board) -> np.ndarray:
        """The calibrated field of a reading (3,) or readings (n, 3)."""
        m = np.asarray(field_board, dtype=np.float64)
        return (m - self.hard_iron) @ self.soft_iron.T

    def turned(self, rotation) -> MagCalibration:
        """The calibration whose calibrated field is this one's turned by *rotation* (3, 3): the
        soft iron ``rotation @ soft_iron``; the field's magnitude, and so the residual, stay."""
        r = np.asarray(rotation, dtype=np.float64)
        angle = math.degrees(math.acos(float(np.clip((np.trace(r) - 1.0) / 2.0, -1.0, 1.0))))
        return replace(self, soft_iron=r @ self.soft_iron, rotation_deg=angle)

    def to_json(self) -> dict[str, Any]:
        return {"kind": "openshoe-mag-calibration", "module_serial": self.module_serial,
                "hard_iron_ut": self.hard_iron.tolist(), "soft_iron": self.soft_iron.tolist(),
                "field_ut": self.field_ut, "rms_residual_ut": self.rms_residual_ut,
                "rotation_deg": self.rotation_deg}

    def save(self, path: str | Path) -> None:
        """Write the calibration as JSON to *path* (whole: a file half written is never left there)."""
        path = Path(path)
        partial = path.with_name(path.name + ".partial")
        partial.write_text(json.dumps(self.to_json(), indent=2) + "\n")
        partial.replace(path)

    @classmethod
    def load(cls, path: str | Path) -> MagCalibration:
        """Read a file :meth:`save` wrote; :class:`MagCalibrationError` naming the file and what is
        wrong with it otherwise (:func:`hostlib.inputs.load_json`, :meth:`from_json`)."""
        try:
            doc = load_json(path, "magnetometer calibration")
        except InputFileError as exc:
            raise MagCalibrationError(str(exc)) from None
        try:
            return cls.from_json(doc)
        except ValueError as exc:
            raise MagCalibrationError(f"{path}: not a magnetometer calibration: {exc}") from None

    @classmethod
    def from_json(cls, doc: Any) -> MagCalibration:
        """The calibration in a parsed file (:meth:`to_json`); ValueError says what is wrong."""
        if not isinstance(doc, dict):
            raise ValueError(f"expected a JSON object, got {type(doc).__name__}")
        if doc.get("kind") != "openshoe-mag-calibration":
            raise ValueError(f"'kind' is {_shown(doc.get('kind'))}, expected 'openshoe-mag-calibration'")
        hard = _numbers(doc, "hard_iron_ut", (3,), "3 finite numbers [µT]")
        soft = _numbers(doc, "soft_iron", (3, 3), "3×3 finite numbers (3 rows of 3)")
        serial = doc.get("module_serial", "")
        if not isinstance(serial, str):
            raise ValueError(f"'module_serial' must be text, got {_shown(serial)}")
        figures = []
        for key in ("field_ut", "rms_residual_ut", "rotation_deg"):
            value = doc.get(key)
            if value is not None and not (isinstance(value, (int, float)) and not isinstance(value, bool)):
                raise ValueError(f"{key!r} must be a number or null, got {_shown(value)}")
            figures.append(math.nan if value is None else float(value))
        return cls(hard, soft, serial, *figures)

    def check_module(self, module_serial: str) -> None:
        """Refuse to apply a calibration fitted on another module (the iron is the shoe's)."""
        if self.module_serial and module_serial and self.module_serial != module_serial:
            raise MagCalibrationError(f"this magnetometer calibration belongs to module "
                                      f"{self.module_serial}, not {module_serial}")


def _shown(value: Any) -> str:
    """*value* as a message shows it: its repr, cut short."""
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _numbers(doc: dict[str, Any], key: str, shape: tuple[int, ...], what: str) -> np.ndarray:
    """The array *doc[key]*, nested lists of *shape* holding finite numbers; ValueError otherwise."""
    if key not in doc:
        raise ValueError(f"missing {key!r}")
    if not _is_array(doc[key], shape):
        raise ValueError(f"{key!r} must be {what}, got {_shown(doc[key])}")
    return np.asarray(doc[key], dtype=np.float64)


def _is_array(value: Any, shape: tuple[int, ...]) -> bool:
    """Whether *value* is nested lists of *shape* holding finite numbers (no text, no true/false)."""
    if shape:
        return isinstance(value, list) and len(value) == shape[0] and all(_is_array(v, shape[1:])
                                                                           for v in value)
    if not isinstance(value, (int, float)) or isinstance(value, bool):
        return False
    try:
        return math.isfinite(value)
    except OverflowError:  # an integer too large for a float
        return False


_NOT_AN_ELLIPSOID = "the readings do not span an ellipsoid (turn the shoe more)"


@dataclass(frozen=True)
class QuadricFit:
    """The least-squares quadric ``uᵀ M u + 2 vᵀ u = 1`` of readings scaled by 1/*scale*
    (u = m / scale, so that the nine coefficients are of order one)."""

    readings: np.ndarray  #: (n, 3) µT, the finite readings fitted
    scale: float  #: µT
    coef: np.ndarray  #: (9,) M's xx, yy, zz, xy, xz, yz, then v's x, y, z
    #: (9, 9) the coefficients' covariance: the equation residuals' variance times (DᵀD)⁻¹
    covariance: np.ndarray

    def calibration(self, coef=None, field_ut: float | None = None,
                    module_serial: str = "") -> MagCalibration:
        """The calibration of the quadric *coef* (default: the fitted one): its centre is the hard
        iron, and the symmetric square root of its shape, scaled to *field_ut* (default: the
        readings' mean magnitude about the centre — it scales the field, never the heading), the
        soft iron. :class:`MagCalibrationError` when the quadric is no ellipsoid."""
        a, b, c, d, e, f, g, h, i = self.coef if coef is None else coef
        quad = np.array([[a, d, e], [d, b, f], [e, f, c]])
        try:
            centre = -np.linalg.solve(quad, np.array([g, h, i]))
        except np.linalg.LinAlgError as exc:
            raise MagCalibrationError(_NOT_AN_ELLIPSOID) from exc
        k = 1.0 + float(centre @ quad @ centre)
        w, v = np.linalg.eigh(quad / k)
        if not (w > 0).all():
            raise MagCalibrationError(_NOT_AN_ELLIPSOID)
        sqrt_shape = v @ np.diag(np.sqrt(w)) @ v.T  # maps the ellipsoid onto the unit sphere
        m = self.readings
        hard = centre * self.scale
        radius = float(field_ut) if field_ut is not None else float(np.mean(np.linalg.norm(m - hard, axis=1)))
        soft = sqrt_shape / self.scale * radius
        residual = np.linalg.norm((m - hard) @ soft.T, axis=1) - radius
        return MagCalibration(hard, soft, module_serial, radius, float(np.sqrt(np.mean(residual ** 2))))


def fit_quadric(readings) -> QuadricFit:
    """The algebraic least-squares quadric of readings (n, 3) [µT] (non-finite rows left out);
    :class:`MagCalibrationError` with fewer than :data:`MIN_READINGS` or when they do not
    determine all nine coefficients."""
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
        raise MagCalibrationError(_NOT_AN_ELLIPSOID)
    dof = max(len(u) - design.shape[1], 1)
    variance = float(np.sum((design @ coef - 1.0) ** 2)) / dof
    covariance = variance * np.linalg.pinv(design.T @ design)
    return QuadricFit(m, scale, coef, covariance)


def fit_ellipsoid(readings, field_ut: float | None = None, module_serial: str = "") -> MagCalibration:
    """Fit readings (n, 3) [µT] taken while the field was constant and the shoe turned through
    many orientations; map them onto a sphere of radius *field_ut* (default: the readings' mean
    magnitude after the fit's centring — it scales the field, never the heading)."""
    return fit_quadric(readings).calibration(field_ut=field_ut, module_serial=module_serial)


def calibration_dir(environ: Mapping[str, str] | None = None) -> Path:
    """Where the per-module calibrations are kept (module docstring); *environ* defaults to the
    process's environment."""
    env = os.environ if environ is None else environ
    if env.get(MAGCAL_DIR_ENV):
        return Path(env[MAGCAL_DIR_ENV]).expanduser()
    config = Path(env["XDG_CONFIG_HOME"]) if env.get("XDG_CONFIG_HOME") else Path.home() / ".config"
    return config / "openshoe" / "magcal"


def module_file(module_serial: str, directory: str | Path | None = None) -> Path:
    """The file of module *module_serial*'s calibration in *directory* (default
    :func:`calibration_dir`): its serial number as the name, anything but letters, digits, ``.``,
    ``_`` and ``-`` turned into ``-``."""
    name = re.sub(r"[^A-Za-z0-9._-]+", "-", module_serial).strip("-.")
    if not name:
        raise MagCalibrationError(f"no file name for the module serial number {module_serial!r}")
    return Path(calibration_dir() if directory is None else directory) / f"{name}.json"


def save_for_module(calibration: MagCalibration, directory: str | Path | None = None) -> Path:
    """Save *calibration* as its module's (:func:`module_file`; the directory is made); returns
    the file. A calibration that names no module is refused: it could not be found again."""
    if not calibration.module_serial:
        raise MagCalibrationError("this calibration names no module: save it with save() to a file of "
                                  "your choice")
    path = module_file(calibration.module_serial, directory)
    path.parent.mkdir(parents=True, exist_ok=True)
    calibration.save(path)
    return path


def load_for_module(module_serial: str, directory: str | Path | None = None
                    ) -> tuple[MagCalibration, Path] | None:
    """Module *module_serial*'s saved calibration and its file, or None when there is none;
    :class:`MagCalibrationError` for a file that is not one, or that belongs to another module."""
    path = module_file(module_serial, directory)
    if not path.is_file():
        return None
    calibration = MagCalibration.load(path)
    try:
        calibration.check_module(module_serial)
    except MagCalibrationError as exc:
        raise MagCalibrationError(f"{path}: {exc}") from None
    return calibration, path
