"""The shoe's hard and soft iron from a wiggle: an ellipsoid fit recovers the offset and, up to
the rotation no fit can see, the distortion; files are checked and bound to their module."""

from __future__ import annotations

import numpy as np
import pytest

from hostlib.magcal import MagCalibration, MagCalibrationError, fit_ellipsoid


def _wiggle(rng, n=1500, field=51.5, noise=0.6):
    """Readings of a constant field through random orientations, with iron and noise."""
    v = rng.normal(size=(n, 3))
    v *= field / np.linalg.norm(v, axis=1, keepdims=True)
    soft = np.eye(3) + rng.uniform(-0.05, 0.05, (3, 3))
    soft = 0.5 * (soft + soft.T)  # a symmetric distortion: fully recoverable
    hard = rng.uniform(-4, 4, 3)
    return v @ soft.T + hard + rng.normal(size=v.shape) * noise, soft, hard


@pytest.mark.parametrize("seed", range(5))
def test_the_fit_recovers_hard_and_soft_iron(seed):
    readings, soft, hard = _wiggle(np.random.default_rng(seed))
    cal = fit_ellipsoid(readings, field_ut=51.5)
    np.testing.assert_allclose(cal.hard_iron, hard, atol=0.15)
    np.testing.assert_allclose(cal.soft_iron @ soft, np.eye(3), atol=0.01)
    assert cal.rms_residual_ut < 0.8
    corrected = np.linalg.norm(cal.apply(readings), axis=1)
    assert np.std(corrected) < 0.8 < np.std(np.linalg.norm(readings, axis=1))


def test_too_few_or_flat_readings_are_refused():
    rng = np.random.default_rng(0)
    with pytest.raises(MagCalibrationError, match="at least"):
        fit_ellipsoid(rng.normal(size=(10, 3)))
    flat = rng.normal(size=(200, 3))
    flat[:, 2] = 0.0  # the shoe never tilted
    with pytest.raises(MagCalibrationError, match="turn the shoe"):
        fit_ellipsoid(flat)


def test_a_saved_calibration_loads_back_and_knows_its_module(tmp_path):
    readings, _, _ = _wiggle(np.random.default_rng(1))
    cal = fit_ellipsoid(readings, module_serial="OSEMU-M00000003")
    path = tmp_path / "mag.json"
    cal.save(path)
    back = MagCalibration.load(path)
    np.testing.assert_array_equal(back.soft_iron, cal.soft_iron)
    np.testing.assert_array_equal(back.hard_iron, cal.hard_iron)
    back.check_module("OSEMU-M00000003")
    with pytest.raises(MagCalibrationError, match="belongs to module OSEMU-M00000003"):
        back.check_module("OSEMU-M00000004")


def test_a_file_that_is_not_a_calibration_is_refused_by_name(tmp_path):
    bad = tmp_path / "x.json"
    bad.write_text('{"kind": "openshoe-mag-calibration", "hard_iron_ut": [1, 2], "soft_iron": []}')
    with pytest.raises(MagCalibrationError, match="x.json"):
        MagCalibration.load(bad)
    bad.write_text("not json")
    with pytest.raises(MagCalibrationError, match="x.json"):
        MagCalibration.load(bad)
