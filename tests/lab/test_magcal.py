"""``python -m lab.accuracy magcal``: one module's wiggle and walk through the module and the calibrating
host: the fitted iron close to the simulated one, its rotation included; the per-step compass with
it as good as with the true iron, with the ellipsoid alone as good as the best ellipsoid's, and
that better than none; and the wiggles of less tilt, the least tilted refused."""

from __future__ import annotations

import csv
import io

import pytest

from lab.accuracy import magcal, main


@pytest.mark.slow
def test_one_module_is_calibrated_and_its_compass_compared_five_ways(tmp_path):
    out = io.StringIO()
    assert main(["magcal", "--seeds", "3", "--workers", "0", "--out", str(tmp_path)], out) == 0
    text = out.getvalue()
    assert "navshoe-calibration, 1 modules" in text and "refused 0" in text
    with (tmp_path / "magcal.csv").open() as f:
        rows = {r["calibration"]: r for r in csv.DictReader(f)}
    assert set(rows) == set(magcal.CALIBRATIONS)
    fitted, none = rows["fitted"], rows["none"]
    assert float(fitted["hard_iron_error_ut"]) < 1.0 < float(none["hard_iron_error_ut"])
    assert float(fitted["soft_iron_residual"]) < 0.02 < float(none["soft_iron_residual"])
    assert float(fitted["longest_wiggle_step_m"]) < 0.25 and int(fitted["compass_steps"]) > 40
    assert not fitted["rotation_refused"] and int(fitted["still_readings"]) > 1000
    assert float(fitted["rotation_left_deg"]) < 0.3 < 1.0 < float(rows["ellipsoid only"]["rotation_left_deg"])
    rms = {name: float(r["compass_rms_deg"]) for name, r in rows.items()}
    assert rms["fitted"] < rms["ellipsoid only"] < rms["none"]
    assert abs(rms["fitted"] - rms["true"]) < 0.3, "turned by the attitude: as good as the true iron"
    assert abs(rms["ellipsoid only"] - rms["best ellipsoid"]) < 0.3, "as good as an ellipsoid fit can be"
    assert "with the attitude: " in text
    with (tmp_path / "magcal-tilt.csv").open() as f:
        tilts = {float(r["tilt_deg"]): r for r in csv.DictReader(f)}
    assert set(tilts) == set(magcal.TILTS_DEG)
    assert tilts[50.0]["refused"] and not tilts[90.0]["refused"]
    assert float(tilts[90.0]["fit_error_deg"]) < float(tilts[70.0]["fit_error_deg"]) < 3.0
    assert float(tilts[90.0]["attitude_error_deg"]) < 1.0
    assert "wiggles of less tilt" in text
