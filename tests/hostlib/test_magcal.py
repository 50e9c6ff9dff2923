"""The shoe's hard and soft iron from a wiggle: an ellipsoid fit recovers the offset and, up to
the rotation no fit can see, the distortion, which the attitude's rotation then turns; files are
checked and bound to their module, kept per module where the host finds them again, and those
saved before the turn still load."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hostlib.calibration.magcal import (
    MagCalibration,
    MagCalibrationError,
    calibration_dir,
    fit_ellipsoid,
    load_for_module,
    module_file,
    save_for_module,
)


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


def test_a_calibration_turned_by_the_attitude_keeps_the_fields_magnitude_and_saves_the_turn(tmp_path):
    readings, _, _ = _wiggle(np.random.default_rng(5))
    cal = fit_ellipsoid(readings, module_serial="OSEMU-M00000005")
    c, s = math.cos(math.radians(2.0)), math.sin(math.radians(2.0))
    about_z = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    turned = cal.turned(about_z)
    np.testing.assert_allclose(turned.apply(readings), cal.apply(readings) @ about_z.T, atol=1e-12)
    np.testing.assert_allclose(turned.soft_iron, about_z @ cal.soft_iron)
    assert turned.rotation_deg == pytest.approx(2.0) and math.isnan(cal.rotation_deg)
    assert (turned.field_ut, turned.rms_residual_ut, turned.module_serial) == \
        (cal.field_ut, cal.rms_residual_ut, cal.module_serial)
    turned.save(tmp_path / "t.json")
    back = MagCalibration.load(tmp_path / "t.json")
    np.testing.assert_array_equal(back.soft_iron, turned.soft_iron)
    assert back.rotation_deg == turned.rotation_deg


def test_a_file_saved_before_the_attitude_turned_calibrations_still_loads(tmp_path):
    old = tmp_path / "OSEMU-M00000009.json"
    old.write_text('{"kind": "openshoe-mag-calibration", "module_serial": "OSEMU-M00000009", '
                   '"hard_iron_ut": [1.0, -2.0, 0.5], "soft_iron": [[1.02, 0.01, 0.0], [0.01, 0.98, 0.02], '
                   '[0.0, 0.02, 1.0]], "field_ut": 51.5, "rms_residual_ut": 0.3}')
    cal, _ = load_for_module("OSEMU-M00000009", tmp_path)
    np.testing.assert_array_equal(cal.hard_iron, [1.0, -2.0, 0.5])
    assert cal.soft_iron[1, 2] == 0.02 and math.isnan(cal.rotation_deg) and cal.field_ut == 51.5


def test_a_file_that_is_not_a_calibration_is_refused_by_name(tmp_path):
    bad = tmp_path / "x.json"
    bad.write_text('{"kind": "openshoe-mag-calibration", "hard_iron_ut": [1, 2], "soft_iron": []}')
    with pytest.raises(MagCalibrationError, match="x.json"):
        MagCalibration.load(bad)
    bad.write_text("not json")
    with pytest.raises(MagCalibrationError, match="x.json"):
        MagCalibration.load(bad)


def test_by_default_the_fit_maps_the_readings_onto_the_fields_own_magnitude():
    readings, _, _ = _wiggle(np.random.default_rng(2))
    cal = fit_ellipsoid(readings)
    assert 48.0 < cal.field_ut < 55.0 and cal.rms_residual_ut < 0.8
    assert np.mean(np.linalg.norm(cal.apply(readings), axis=1)) == pytest.approx(cal.field_ut, rel=1e-3)


def test_the_calibration_directory_is_the_variable_else_the_xdg_config_home(tmp_path):
    assert calibration_dir({"OPENSHOE_MAGCAL_DIR": str(tmp_path / "mine"), "XDG_CONFIG_HOME": "/x"}) == \
        tmp_path / "mine"
    assert calibration_dir({"XDG_CONFIG_HOME": str(tmp_path)}) == tmp_path / "openshoe" / "magcal"
    assert calibration_dir({}) == Path.home() / ".config" / "openshoe" / "magcal"


def test_a_calibration_is_saved_for_its_module_and_found_again(tmp_path):
    readings, _, _ = _wiggle(np.random.default_rng(3))
    cal = fit_ellipsoid(readings, module_serial="OSEMU-M00000007")
    path = save_for_module(cal, tmp_path / "new")
    assert path == tmp_path / "new" / "OSEMU-M00000007.json" and not list(path.parent.glob("*.partial"))
    found, where = load_for_module("OSEMU-M00000007", tmp_path / "new")
    assert where == path
    np.testing.assert_array_equal(found.soft_iron, cal.soft_iron)
    assert load_for_module("OSEMU-M00000008", tmp_path / "new") is None
    with pytest.raises(MagCalibrationError, match="names no module"):
        save_for_module(fit_ellipsoid(readings), tmp_path)


def test_a_file_of_another_module_under_this_ones_name_is_refused(tmp_path):
    readings, _, _ = _wiggle(np.random.default_rng(4))
    fit_ellipsoid(readings, module_serial="OSEMU-M00000001").save(tmp_path / "OSEMU-M00000002.json")
    with pytest.raises(MagCalibrationError, match="M00000002.json: .*belongs to module OSEMU-M00000001"):
        load_for_module("OSEMU-M00000002", tmp_path)


@settings(max_examples=200, deadline=None)
@given(serial=st.text(min_size=1, max_size=40))
def test_any_serial_number_names_a_file_in_the_directory_or_is_refused(serial):
    try:
        path = module_file(serial, "/calibrations")
    except MagCalibrationError:
        assert not any(c.isascii() and (c.isalnum()) for c in serial)
        return
    assert path.parent == Path("/calibrations") and path.suffix == ".json"
    assert path.name[0] not in "-." and "/" not in path.name and "\\" not in path.name


finite = st.floats(-1e6, 1e6, allow_nan=False)


@settings(max_examples=100, deadline=None)
@given(hard=st.lists(finite, min_size=3, max_size=3), soft=st.lists(finite, min_size=9, max_size=9),
       serial=st.text(alphabet="ABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789-", min_size=1, max_size=15))
def test_any_calibration_saves_and_loads_back_unchanged(tmp_path_factory, hard, soft, serial):
    cal = MagCalibration(np.array(hard), np.array(soft).reshape(3, 3), serial, 51.5, 0.3)
    path = tmp_path_factory.mktemp("cal") / "c.json"
    cal.save(path)
    back = MagCalibration.load(path)
    np.testing.assert_array_equal(back.hard_iron, cal.hard_iron)
    np.testing.assert_array_equal(back.soft_iron, cal.soft_iron)
    assert back.module_serial == serial
