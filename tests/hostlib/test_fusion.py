"""The host-side fusion filter: with every aid off it is the step tracker bit for bit; a per-step
compass holds a drifting heading; GPS aligns the heading and, with the compass, teaches the
declination; its inputs are checked."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hostlib.aids.compass import StanceReading
from hostlib.files.replay import replay_session
from hostlib.fusion.tracker import FusionSettings, FusionTracker
from hostlib.track.steps import StepTracker, rotation_z

from .loops import fusion_capture, rectangle

DP = np.diag([1e-4, 1e-4, 1e-4, 1e-6])
FIELD_NED = 51.5 * np.array([math.cos(math.radians(72.5)), 0.0, math.sin(math.radians(72.5))])


def _reading(true_heading: float, declination: float, deviation: float = 0.0) -> StanceReading:
    """A level board at *true_heading* in a field whose magnetic north is *declination* (+ a local
    *deviation*) east of true north; the module's quaternion has yaw 0 (just reset)."""
    field_true = rotation_z(declination + deviation) @ FIELD_NED
    return StanceReading(rotation_z(true_heading).T @ field_true, np.eye(3), 3)


def _walk(n: int, turn_bias: float, step_m: float = 0.7):
    """A straight walk north whose module reports each step with a heading error *turn_bias*."""
    for k in range(n):
        yield np.array([step_m, 0.0, 0.0, turn_bias]), k + 1


step_rows = st.lists(st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(-0.2, 0.2), st.floats(-0.5, 0.5),
                               st.floats(1e-6, 1e-2)), min_size=1, max_size=40)


@settings(max_examples=60, deadline=None)
@given(rows=step_rows)
def test_with_every_aid_off_the_track_is_the_step_trackers_bit_for_bit(rows):
    plain, fused = StepTracker(), FusionTracker()
    for k, (x, y, z, psi, var) in enumerate(rows):
        dp = np.eye(4) * var
        plain.add_step([x, y, z, psi], dp, k + 1)
        fused.add_step([x, y, z, psi], dp, k + 1, reading=_reading(0.3, 0.1))
    assert np.array_equal(plain.track.poses, fused.track.poses)
    assert np.array_equal(plain.track.covariances, fused.track.covariances)


def test_a_capture_replayed_through_the_fusion_tracker_with_aids_off_is_unchanged():
    data = fusion_capture(rectangle((0.02, 0.0, 0.0)), b"OSEMU-M00000003")
    plain = replay_session(data).tracker.track
    fused = replay_session(data, tracker=FusionTracker(last_counter=None)).tracker
    assert np.array_equal(plain.poses, fused.track.poses)
    assert fused.step_times[:2] == pytest.approx([2 * 64000 / 64e6, 3 * 64000 / 64e6])


def test_the_first_compass_reading_turns_the_track_onto_true_north():
    d = math.radians(6.0)
    f = FusionTracker(FusionSettings(compass=True, declination_rad=d))
    f.add_step([0.7, 0.0, 0.0, 0.0], DP, 1, reading=_reading(math.radians(40.0), d))
    assert f.heading == pytest.approx(math.radians(40.0), abs=1e-9)
    forty = math.radians(40.0)
    np.testing.assert_allclose(f.position[:2], 0.7 * np.array([math.cos(forty), math.sin(forty)]), atol=1e-9)
    assert math.sqrt(f.covariance[3, 3]) == pytest.approx(math.radians(20.0))
    assert f.fusion.heading_aligned_by == "compass"


def test_a_per_step_compass_holds_a_heading_the_module_lets_drift():
    bias = math.radians(0.2)  # per step: 20° after 100 steps
    plain = FusionTracker()
    compass = FusionTracker(FusionSettings(compass=True, compass_sigma_rad=math.radians(10.0)))
    dp = np.diag([1e-4, 1e-4, 1e-4, (2 * bias) ** 2])  # an honest heading variance per step
    rng = np.random.default_rng(3)
    for dx, k in _walk(100, bias):
        plain.add_step(dx, dp, k)
        true = 0.0  # the walker keeps north; the module thinks it turns
        compass.add_step(dx, dp, k, reading=_reading(true, 0.0, rng.normal() * math.radians(10.0)))
    assert math.degrees(plain.heading) == pytest.approx(20.0)
    # a Kalman filter trails a steady turn by bias / gain ≈ 0.2° / √(q / r) ≈ 5°; plus the deviation
    assert abs(math.degrees(compass.heading)) < 8.0
    assert abs(compass.position[1]) < 0.3 * abs(plain.position[1])
    # the first reading aligned; of the others the gate rejects the few beyond 3σ (Gaussian: 0.3 %,
    # a little more while the filter trails the module's turn)
    assert compass.fusion.compass_updates + compass.fusion.compass_rejected == 99
    assert compass.fusion.compass_rejected <= 3


def test_standing_resets_carry_no_compass_update_unless_asked():
    for mode, expected in (("step", 0), ("every-reset", 5)):
        f = FusionTracker(FusionSettings(compass=True, compass_mode=mode))
        f.add_step([0.7, 0, 0, 0], DP, 1, reading=_reading(0.0, 0.0))
        for k in range(2, 7):
            f.add_step([0.002, 0, 0, 0], DP, k, reading=_reading(0.0, 0.0))
        assert f.fusion.compass_updates == expected


def _gps_walk(settings: FusionSettings, heading: float, declination: float, n: int = 400):
    """Walk straight along *heading* at 0.7 m per second-long step with fixes every second; the
    module's frame starts turned by −*heading* (it does not know north)."""
    f = FusionTracker(settings)
    times = np.arange(0, n + 1, 1.0)
    path = np.outer(times * 0.7, [math.cos(heading), math.sin(heading)])
    f.add_fixes(times, path)
    for k in range(1, n + 1):
        f.add_step([0.7, 0.0, 0.0, 0.0], DP, k, reading=_reading(heading, declination), time_s=float(k))
    return f


def test_gps_alone_turns_the_track_onto_its_course():
    f = _gps_walk(FusionSettings(gps=True), math.radians(70.0), 0.0)
    assert f.fusion.heading_aligned_by == "gps"
    assert math.degrees(f.heading) == pytest.approx(70.0, abs=0.5)
    assert f.fusion.gps_updates > 20 and f.fusion.gps_before_alignment > 0


def test_gps_and_the_compass_learn_the_declination_the_prior_got_wrong():
    truth = math.radians(6.0)
    prior = math.radians(14.0)
    f = _gps_walk(FusionSettings(gps=True, compass=True, compass_sigma_rad=math.radians(3.0),
                                 declination_rad=prior), math.radians(-30.0), truth)
    assert abs(math.degrees(f.declination - truth)) < 2.0
    assert f.declination_sigma < math.radians(5.0)
    assert math.degrees(f.heading) == pytest.approx(-30.0, abs=2.0)


def test_fixes_out_of_order_or_not_finite_are_refused():
    f = FusionTracker(FusionSettings(gps=True))
    f.add_fix(5.0, [1.0, 2.0])
    with pytest.raises(ValueError, match="older"):
        f.add_fix(4.0, [1.0, 2.0])
    with pytest.raises(ValueError, match="finite"):
        f.add_fix(6.0, [math.nan, 2.0])
    with pytest.raises(ValueError, match="compass_mode"):
        FusionSettings(compass_mode="always")


def test_a_resent_step_is_neither_summed_nor_aided_twice():
    f = FusionTracker(FusionSettings(compass=True))
    f.add_step([0.7, 0, 0, 0], DP, 1, reading=_reading(0.5, 0.0))
    f.add_step([0.7, 0, 0, 0], DP, 2, reading=_reading(0.5, 0.0))
    before = f.track.poses.copy()
    f.add_step([0.7, 0, 0, 0], DP, 2, reading=_reading(0.5, 0.0))
    assert np.array_equal(before, f.track.poses) and f.duplicates == 1 and f.fusion.compass_updates == 1


def test_the_filter_core_refuses_a_non_finite_update_and_keeps_its_state():
    from hostlib.fusion.core import NonFiniteUpdate, StateFilter

    f = StateFilter()
    f.add_block("pose", [0.0, 0.0, 0.0, 0.0], np.eye(4))
    f.add_block("declination", [0.1], [[0.01]])
    x, p = f.snapshot()
    with pytest.raises(NonFiniteUpdate, match="not finite"):
        f.update(f.row({("pose", 3): 1.0, "declination": -1.0}), math.nan, 0.01)
    assert np.array_equal(f.x, x) and np.array_equal(f.P, p)
    assert f.index("declination") == 4 and list(f.others("pose")) == [4]


def test_a_compass_reading_that_is_not_finite_is_refused_and_counted():
    f = FusionTracker(FusionSettings(compass=True))
    f.add_step([0.5, 0.0, 0.0, 0.0], np.eye(4) * 1e-4, 1)
    f._compass_step(math.nan, "pose", True)  # what a packet's NaN magnetometer reading gives
    assert f.fusion.compass_refused == 1 and not f.heading_aligned
    assert np.isfinite(f.filter.x).all() and np.isfinite(f.filter.P).all()
