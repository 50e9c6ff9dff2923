"""The in-situ calibration (hostlib.calibration.wiggle): it collects the stream's readings, ends by itself at
the first step longer than half a metre and not before, fits the shoe's iron — the ellipsoid, then
its rotation from the attitude — and refuses, saying why, readings that do not determine an
ellipsoid (attitudes that do not determine the rotation leave the ellipsoid's calibration); the
fusion tracker's compass waits for it and then starts from it with NavShoe's 10°."""

from __future__ import annotations

import math

import numpy as np
import pytest

from firmware_sim.sensors.config import DEFAULT_CONFIG
from hostlib.calibration.wiggle import HEADING_SIGMA_DEG, STOP_STEP_M, WiggleCalibration
from hostlib.events import PacketEvent, StepEvent, StepOutcome
from hostlib.fusion.tracker import FusionSettings, FusionTracker
from protocol.codec import Step
from protocol.extensions import MAG_STREAM_START, MAG_STREAM_STOP
from protocol.ids import StateId

from .loops import STANCE_STATES
from .wiggles import FIELD, packet_states, wiggle_packets


@pytest.fixture(scope="module")
def good_wiggle():
    return wiggle_packets()


def _collected(packets) -> WiggleCalibration:
    w = WiggleCalibration()
    for states in packets:
        w.add_packet(states)
    return w


def test_it_starts_and_stops_the_stream_with_the_protocols_commands():
    assert WiggleCalibration.START == MAG_STREAM_START and WiggleCalibration.STOP == MAG_STREAM_STOP


def test_it_ends_at_the_first_step_longer_than_half_a_metre_and_not_before(good_wiggle):
    packets, _, _ = good_wiggle
    w = _collected(packets)
    short = ([0.1, 0.05, 0.0, 0.3], [0.3, -0.3, 0.0, 1.0], [0.0, 0.4, -0.6, 0.0],
             [STOP_STEP_M, 0.0, 0.0, 0.0])
    for dx in short:
        assert w.add_step(dx, "M1") is False and not w.done, f"{dx} is no step longer than 0.5 m"
    assert w.add_step([0.4, 0.31, 0.0, 0.0], "M1") is True
    assert w.done and w.steps == 5 and w.calibration is not None and w.refusal is None
    assert w.calibration.module_serial == "M1"
    assert w.add_step([1.5, 0.0, 0.0, 0.0], "M1") is False, "it ends once"
    readings = len(w.readings)
    w.add_packet(packets[0])
    assert len(w.readings) == readings and w.late_packets == 1, "the stream until the stop: not fitted"


def test_the_fit_recovers_the_iron_of_a_wiggle(good_wiggle):
    packets, soft, hard = good_wiggle
    w = _collected(packets)
    cal = w.finish("M1")
    np.testing.assert_allclose(cal.hard_iron, hard, atol=0.5)
    m = cal.soft_iron @ soft
    np.testing.assert_allclose(m / np.cbrt(np.linalg.det(m)), np.eye(3), atol=0.01)
    assert w.coverage_deg > -10.0 and w.heading_sigma_deg < 0.2
    assert "magnetometers calibrated from" in w.summary()


def _rotation_left_deg(soft_iron: np.ndarray, true_soft: np.ndarray) -> float:
    """The angle [deg] of the rotation in soft_iron · true_soft (its polar decomposition's)."""
    w, _, vt = np.linalg.svd(soft_iron @ true_soft)
    return math.degrees(math.acos(float(np.clip((np.trace(w @ vt) - 1.0) / 2.0, -1.0, 1.0))))


@pytest.mark.parametrize("lag_cycles", [0, 16])
def test_the_attitude_turns_the_fit_by_the_irons_rotation_even_when_it_lags_the_field(lag_cycles):
    # the module's attitude is up to 16 ms older than its magnetometers: while the shoe tilts they
    # disagree, and only the readings held still tell the rotation
    packets, soft, _ = wiggle_packets(turn_deg=(1.5, -1.0, 2.0), attitude_lag_cycles=lag_cycles)
    w = _collected(packets)
    cal = w.finish("M1")
    assert _rotation_left_deg(w.ellipsoid.soft_iron, soft) == pytest.approx(2.7, abs=0.1)
    assert _rotation_left_deg(cal.soft_iron, soft) < 0.05
    assert cal.rotation_deg == pytest.approx(2.7, abs=0.1) and w.rotation_refusal is None
    assert w.rotation.inclination_deg == pytest.approx(72.5, abs=0.2)
    assert 0.4 * len(w.readings) < w.rotation.readings < 0.6 * len(w.readings)
    assert "the attitude turned the field 2.7° (inclination 72.5°" in w.summary()


def test_attitudes_that_do_not_go_with_the_field_leave_the_ellipsoids_calibration(good_wiggle):
    packets, soft, hard = good_wiggle
    level = {StateId.QUATERNION: np.array([0.0, 0.0, 0.0, 1.0])}
    w = _collected([{**p, **level} for p in packets])
    cal = w.finish("M1")
    assert cal is w.ellipsoid and w.rotation is None and math.isnan(cal.rotation_deg)
    assert "the attitude does not go with the magnetometers" in w.rotation_refusal
    assert "the ellipsoid's alone, not turned with the attitude" in w.summary()
    np.testing.assert_allclose(cal.hard_iron, hard, atol=0.5)


def test_step_packets_are_steps_not_readings(good_wiggle):
    packets, _, _ = good_wiggle
    w = WiggleCalibration()
    step_states = {**packets[0], StateId.DX: np.zeros(4)}
    step = Step(dx=np.array([0.8, 0.0, 0.0, 0.0]), dp=np.zeros(10), counter=1)
    events = [PacketEvent(1, b"", packets[0]), PacketEvent(2, b"", step_states), PacketEvent(3, b"", None),
              StepEvent(step, 2, StepOutcome.SUMMED, np.zeros(4), np.zeros((4, 4)), 1, math.nan)]
    assert w.feed(events, "M1") is True
    assert len(w.readings) == 1 and w.steps == 1


@pytest.mark.parametrize(("packets", "why"), [
    ([], "no magnetometer reading came"),
    (wiggle_packets()[0][:20], "20 readings; an ellipsoid fit needs at least 30"),
    (wiggle_packets(tilt_deg=0.0)[0], "leave a level compass uncertain by"),  # only turned round
    (wiggle_packets(tilt_deg=30.0)[0], "do not span an ellipsoid"),
    (wiggle_packets(tilt_deg=55.0)[0], "short of one half of the sphere"),
    (wiggle_packets(noise_ut=6.0)[0], "scatter 8"),  # a field that is not one ellipsoid
])
def test_readings_that_do_not_determine_an_ellipsoid_are_refused_saying_why(packets, why):
    w = _collected(packets)
    assert w.add_step([1.2, 0.0, 0.0, 0.0], "M1") is True
    assert w.calibration is None and why in w.refusal
    assert "navigating uncalibrated" in w.summary()


def test_a_wiggle_that_never_ended_says_so():
    w = WiggleCalibration()
    assert "no step longer than 0.5 m" in w.summary() and not w.done


def _step_states(rotation: np.ndarray, field: np.ndarray, counter: int) -> dict:
    return {**packet_states(rotation, field), StateId.DX: np.array([1.0, 0.0, 0.0, 0.0]),
            StateId.STEP_COUNTER: counter, StateId.T_INT_K: 64_000_000 * counter}


def test_the_compass_waits_for_the_calibration_then_starts_from_it_with_10_degrees(good_wiggle):
    packets, soft, hard = good_wiggle
    tracker = FusionTracker(FusionSettings(compass=True), last_counter=None)
    tracker.hold_compass()
    level = np.eye(3)
    field = soft @ FIELD + hard
    dp = (np.eye(4) * 1e-4)[np.triu_indices(4)]
    for k in range(1, 4):
        tracker.add(Step(np.array([1.0, 0, 0, 0]), dp, k), 0.4, _step_states(level, field, k))
    assert tracker.fusion.compass_updates == 0 and tracker.fusion.compass_skipped == 3
    assert not tracker.heading_aligned
    w = _collected(packets)
    assert w.add_step([1.0, 0.0, 0.0, 0.0], "M1")
    w.release(tracker)
    assert tracker.settings.mag_calibration is w.calibration
    tracker.add(Step(np.array([1.0, 0, 0, 0]), dp, 4), 0.4, _step_states(level, field, 4))
    assert tracker.fusion.heading_aligned_by == "compass"
    assert tracker.covariance5[3, 3] == pytest.approx(math.radians(HEADING_SIGMA_DEG) ** 2)
    # the board faces north: calibrated, the compass reads it (less the field's own declination)
    assert math.degrees(tracker.track.final_pose[3]) == pytest.approx(-DEFAULT_CONFIG.mag.declination_deg,
                                                                     abs=0.5)


def test_a_refused_calibration_lets_the_compass_go_on_uncalibrated_with_its_own_sigma():
    tracker = FusionTracker(FusionSettings(compass=True, compass_sigma_rad=math.radians(20.0)),
                            last_counter=None)
    tracker.hold_compass()
    w = WiggleCalibration()
    w.finish("M1")
    w.release(tracker)
    dp = (np.eye(4) * 1e-4)[np.triu_indices(4)]
    tracker.add(Step(np.array([1.0, 0, 0, 0]), dp, 1), 0.4, {**STANCE_STATES, StateId.T_INT_K: 1})
    assert tracker.settings.mag_calibration is None
    assert tracker.covariance5[3, 3] == pytest.approx(math.radians(20.0) ** 2)
