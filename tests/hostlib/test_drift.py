"""Closed-loop drift correction (hostlib.calibration.drift): calibrating a module from closed loops, applying
the calibration step by step, and its file."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from hostlib.calibration.drift import (
    FORMAT,
    VERSION,
    DriftCalibration,
    DriftError,
    calibrate,
    loop_closure,
    serial_text,
)
from hostlib.track.steps import StepTracker, Track

from .loops import DP, rectangle

V_ERR = (0.03, -0.05, 0.01)  # m/s of swing: the module's systematic drift
SERIAL = b"OSEMU-M00000003"


def _cal(**kw) -> DriftCalibration:
    return calibrate([rectangle(V_ERR).track()], **kw)


def test_a_closed_loop_with_a_constant_velocity_error_gives_that_error_back():
    loop = rectangle(V_ERR)
    track = loop.track()
    assert track.closure_error(horizontal=False) > 0.5, "the drift opens the loop"
    cal = calibrate([track], SERIAL)
    np.testing.assert_allclose(cal.dv, np.negative(V_ERR), atol=1e-5)
    assert cal.t_total_s == pytest.approx(loop.swing.sum())
    assert (cal.steps, cal.captures, cal.module_serial) == (len(loop.swing), 1, SERIAL)


def test_the_calibration_closes_another_loop_of_the_module_moving_each_step_by_its_own_swing():
    cal = _cal()
    other = rectangle(V_ERR, seed=5)  # other swing times, same module
    track = other.track()
    corrected = cal.apply(track, module_serial=None)
    assert corrected.closure_error(horizontal=False) < 1e-4 < 0.5 < track.closure_error(horizontal=False)
    expected = np.concatenate(([0.0], np.cumsum(other.swing)))[:, None] * np.asarray(cal.dv)[None, :]
    np.testing.assert_allclose(corrected.positions - track.positions, expected, atol=1e-12)
    np.testing.assert_array_equal(corrected.headings, track.headings)
    np.testing.assert_array_equal(corrected.covariances, track.covariances)
    np.testing.assert_array_equal(corrected.steps, track.steps)
    np.testing.assert_array_equal(corrected.counters, track.counters)
    np.testing.assert_array_equal(corrected.swing_times, track.swing_times)


def test_several_loops_pool_their_closures_over_their_summed_swing_time():
    a, b = rectangle((0.02, 0.0, 0.0), seed=1), rectangle((0.0, 0.04, 0.0), seed=2)
    cal = calibrate([a.track(), b.track()])
    dp = np.add(loop_closure(a.track()).dp, loop_closure(b.track()).dp)
    np.testing.assert_allclose(cal.dv, dp / (a.swing.sum() + b.swing.sum()), rtol=1e-12)
    assert cal.captures == 2 and cal.steps == len(a.swing) + len(b.swing)


def test_a_walk_starting_at_another_heading_gets_the_drift_turned_with_it():
    cal = _cal()
    heading = math.radians(90.0)
    track = rectangle(V_ERR, seed=3, heading0=heading).track(heading0=heading)
    assert cal.apply(track, module_serial=None).closure_error(horizontal=False) < 1e-4
    from_north = rectangle(V_ERR, seed=3).track()
    assert loop_closure(track).dp == pytest.approx(loop_closure(from_north).dp, abs=1e-5)


def test_the_tracker_keeps_swing_times_beside_the_steps_and_sums_as_without_them():
    loop = rectangle(V_ERR)
    with_swing, without = loop.track(), loop.track(with_swing=False)
    np.testing.assert_array_equal(with_swing.poses, without.poses)
    np.testing.assert_array_equal(with_swing.covariances, without.covariances)
    np.testing.assert_array_equal(with_swing.swing_times, loop.swing)
    assert np.isnan(without.swing_times).all()
    np.testing.assert_array_equal(with_swing.copy().swing_times, loop.swing)
    rebuilt = Track.from_arrays(with_swing.poses, with_swing.covariances, swing_times=with_swing.swing_times)
    np.testing.assert_array_equal(rebuilt.swing_times, loop.swing)


def test_a_step_without_a_swing_time_is_refused():
    track = rectangle(V_ERR).track(with_swing=False)
    with pytest.raises(DriftError, match=r"loop\.bin: .* no swing time .* fusion set-up"):
        calibrate([track], names=["loop.bin"])
    with pytest.raises(DriftError, match=r"walk\.bin: 24 of 24 steps have no swing time \(the first is step"):
        _cal().apply(track, module_serial=None, what="walk.bin")
    tracker = StepTracker()
    tracker.add_step([1.0, 0.0, 0.0, 0.0], DP, 1, 0.4)
    tracker.add_step([1.0, 0.0, 0.0, 0.0], DP, 2)
    with pytest.raises(DriftError, match=r"1 of 2 steps .* step 2, counter 2"):
        _cal().offsets(tracker.track)


def test_swing_times_of_zero_cannot_calibrate():
    tracker = StepTracker()
    for k in range(4):
        tracker.add_step([1.0, 0.1, 0.0, 0.0], DP, k + 1, 0.0)
    with pytest.raises(DriftError, match="SWING_TIME as 0"):
        calibrate([tracker.track], names=["zero.bin"])
    with pytest.raises(DriftError, match="no steps"):
        calibrate([StepTracker().track])


def test_a_calibration_for_another_module_is_refused_naming_both():
    cal = _cal(module_serial=SERIAL)
    track = rectangle(V_ERR, seed=4).track()
    with pytest.raises(DriftError) as caught:
        cal.apply(track, module_serial=b"OSEMU-M00000004")
    assert "OSEMU-M00000003" in str(caught.value) and "OSEMU-M00000004" in str(caught.value)
    with pytest.raises(DriftError, match="does not say which module"):
        cal.apply(track, module_serial=None)
    assert cal.apply(track, module_serial=SERIAL).closure_error() < 1e-4
    assert _cal().apply(track, module_serial=b"any module at all").closure_error() < 1e-4


def test_serial_numbers_read_as_text_or_hex():
    assert serial_text(SERIAL) == "OSEMU-M00000003"
    assert serial_text(bytes(range(0x10, 0x1F))) == "10 11 12 13 14 15 16 17 18 19 1A 1B 1C 1D 1E"
    assert serial_text(None) == "(unknown)"


def test_the_calibration_file_round_trips(tmp_path):
    cal = _cal(module_serial=SERIAL)
    path = tmp_path / "cal.json"
    cal.save(path)
    doc = json.loads(path.read_text())
    assert (doc["format"], doc["version"]) == (FORMAT, VERSION)
    assert bytes.fromhex(doc["module_serial"]) == SERIAL
    assert DriftCalibration.load(path) == cal
    anyone = _cal()
    anyone.save(path)
    assert DriftCalibration.load(path) == anyone and anyone.module_serial is None


def _good() -> dict:
    return _cal(module_serial=SERIAL).to_json()


BAD_FILES = [
    pytest.param("{not json", "invalid JSON", id="not-json"),
    pytest.param("[1, 2, 3]", "expected a JSON object", id="not-an-object"),
    pytest.param({**_good(), "format": "gpx"}, "'format' is 'gpx'", id="other-format"),
    pytest.param({**_good(), "version": 2}, "format version 2 is not supported", id="newer-version"),
    pytest.param({k: v for k, v in _good().items() if k != "dv_m_per_s"}, "missing 'dv_m_per_s'", id="no-dv"),
    pytest.param({**_good(), "dv_m_per_s": [0.1, 0.2]}, "'dv_m_per_s' must be 3 finite numbers", id="dv-2"),
    pytest.param({**_good(), "dv_m_per_s": [0.1, "x", 0.2]}, "'dv_m_per_s' must be 3", id="dv-text"),
    pytest.param({**_good(), "t_total_s": 0}, "'t_total_s' must be a number > 0", id="no-time"),
    pytest.param({**_good(), "steps": 2.5}, "'steps' must be an integer", id="steps"),
    pytest.param({**_good(), "module_serial": "xyz"}, "'module_serial' must be null or", id="serial"),
]


@pytest.mark.parametrize(("content", "reason"), BAD_FILES)
def test_a_bad_calibration_file_is_refused_naming_the_file_and_the_fault(tmp_path, content, reason):
    path = tmp_path / "cal.json"
    path.write_text(content if isinstance(content, str) else json.dumps(content))
    with pytest.raises(DriftError) as caught:
        DriftCalibration.load(path)
    assert str(caught.value).startswith(f"{path}: not a drift calibration: ")
    assert reason in str(caught.value)


def test_a_non_finite_drift_is_refused(tmp_path):
    path = tmp_path / "cal.json"
    path.write_text(json.dumps({**_good(), "dv_m_per_s": [math.nan, 0.0, 0.0]}))
    assert "NaN" in path.read_text()
    with pytest.raises(DriftError, match="'dv_m_per_s' must be 3 finite numbers"):
        DriftCalibration.load(path)


def test_a_missing_calibration_file_is_refused_naming_it(tmp_path):
    with pytest.raises(DriftError, match=r"nope\.json: cannot read the drift calibration"):
        DriftCalibration.load(tmp_path / "nope.json")
