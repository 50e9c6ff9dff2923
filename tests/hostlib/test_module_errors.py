"""The module's step-length scale and climb held as states: an honest covariance along the track and
in height, learned from GPS when there is some, and nothing changed when they are not held."""

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hostlib.fusion.module_errors import ModuleErrors, error_jacobian, step_duration
from hostlib.fusion.tracker import FusionSettings, FusionTracker
from hostlib.track.steps import StepTracker

DP = np.diag([1e-4, 1e-4, 1e-4, 1e-5])


def _steps(rng, n=60):
    for k in range(n):
        yield np.array([0.7 + 0.1 * rng.standard_normal(), 0.05 * rng.standard_normal(),
                        0.01 * rng.standard_normal(), 0.05 * rng.standard_normal()]), k + 1


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2 ** 16), scale=st.floats(0.0, 0.01), climb=st.floats(0.0, 0.01))
def test_without_aids_the_errors_widen_the_covariance_by_the_distance_and_leave_the_track(seed, scale, climb):
    """No aid: the track is the plain sum, and the covariance is the plain one plus σ_s² d dᵀ
    horizontally and σ_c² L² in height (d the displacement, L the path)."""
    errors = ModuleErrors(scale, climb)
    held, plain = FusionTracker(FusionSettings(module_errors=errors)), StepTracker()
    for dx, counter in _steps(np.random.default_rng(seed)):
        held.add_step(dx, DP, counter)
        plain.add_step(dx, DP, counter)
    assert np.array_equal(held.pose, plain.pose)
    d, length = plain.pose[:2], plain.distance
    expected = plain.covariance
    expected[:2, :2] += scale ** 2 * np.outer(d, d)
    expected[2, 2] += (climb * length) ** 2
    np.testing.assert_allclose(held.covariance, expected, rtol=1e-9, atol=1e-15)
    assert held.module_errors == (0.0, 0.0, 0.0)


def test_not_held_the_tracker_is_the_five_state_filter():
    tracker = FusionTracker()
    assert tracker.module_errors is None
    assert tracker.state_covariance.shape == (5, 5)
    held = FusionTracker(FusionSettings(module_errors=ModuleErrors(0.001, 0.001)))
    assert held.state_covariance.shape == (8, 8)


def test_a_straight_walk_is_uncertain_along_its_length_a_loop_is_not():
    errors = ModuleErrors(0.002, 0.0)
    walks = {"straight": 0.0, "loop": 2 * math.pi / 40}  # the loop: a circle back to the start
    for name, turn in walks.items():
        held, plain = FusionTracker(FusionSettings(module_errors=errors)), StepTracker()
        for k in range(40):
            for t in (held, plain):
                t.add_step([0.75, 0.0, 0.0, turn], DP, k + 1)
        extra = held.covariance[:2, :2] - plain.covariance[:2, :2]
        if name == "straight":
            assert math.sqrt(extra[0, 0]) == pytest.approx(0.002 * 30.0)
            assert abs(extra[1, 1]) < 1e-12
        else:
            assert np.abs(extra).max() < 1e-9


def test_gps_teaches_the_step_length_scale_and_the_steps_after_are_corrected():
    """A module whose steps are 3 % short walks 400 m north with fixes of the truth: the filter
    learns s ≈ +3 %, and ends closer to the truth than one that does not hold the scale."""
    gps = dict(gps=True, gps_sigma_m=5.0, gps_interval_s=5.0, gps_align_distance_m=20.0)
    held = FusionTracker(FusionSettings(module_errors=ModuleErrors(0.02, 0.001), **gps))
    plain = FusionTracker(FusionSettings(**gps))
    rng = np.random.default_rng(3)
    step, dt = 0.8, 0.5
    fix_times = np.arange(0.0, 500 * dt, 1.0)
    truth = np.column_stack([fix_times / dt * step, np.zeros_like(fix_times)])
    fixes = truth + rng.normal(0, 1.0, (len(fix_times), 2))
    for t in (held, plain):
        t.add_fixes(fix_times, fixes)
    for k in range(500):
        for t in (held, plain):
            t.add_step([step * 0.97, 0.0, 0.0, 0.0], DP, k + 1, time_s=(k + 1) * dt)
    s, _c, _k = held.module_errors
    assert s == pytest.approx(1 / 0.97 - 1, abs=0.005)
    truth = 500 * step
    assert abs(held.pose[0] - truth) < abs(plain.pose[0] - truth)


def test_error_jacobian_is_the_rotated_step_its_length_and_its_turn():
    j = error_jacobian(math.pi / 2, np.array([3.0, 4.0, 1.0, 0.2]))
    np.testing.assert_allclose(j[:, 0], [-4.0, 3.0, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(j[:, 1], [0.0, 0.0, 5.0, 0.0])
    np.testing.assert_allclose(j[:, 2], [0.0, 0.0, 0.0, 0.2])


def test_the_turn_scale_widens_the_heading_by_the_angle_turned():
    """A walk round a circle twice: the heading's variance grows by σ_k² (4π)², and the positions
    it carried are less certain than the plain sum says; a straight walk's heading is untouched."""
    errors = ModuleErrors(0.0, 0.0, 0.01)
    for turn, turned in ((2 * math.pi / 40, 4 * math.pi), (0.0, 0.0)):
        held, plain = FusionTracker(FusionSettings(module_errors=errors)), StepTracker()
        for k in range(80):
            for t in (held, plain):
                t.add_step([0.75, 0.0, 0.0, turn], DP, k + 1)
        extra = held.covariance - plain.covariance
        assert extra[3, 3] == pytest.approx((0.01 * turned) ** 2, abs=1e-15)
        if turned:
            assert np.trace(extra[:2, :2]) > 0.0
        else:
            assert np.abs(extra).max() < 1e-15


@pytest.mark.parametrize("bad", [-0.1, math.nan, math.inf])
def test_priors_must_be_finite_and_not_negative(bad):
    with pytest.raises(ValueError, match="step_scale_sigma"):
        ModuleErrors(bad, 0.0)


def test_the_heading_drift_widens_the_heading_by_the_time_walked():
    """Steps a second apart, straight: the heading's variance grows by σ_r² T², T the time the
    foot moved (the first step, without a time before it, and the resets while standing still
    add nothing); a step without a module time adds nothing either."""
    sigma_r = math.radians(20.0) / 3600.0  # 20 °/h
    held = FusionTracker(FusionSettings(module_errors=ModuleErrors(0.0, 0.0, 0.0, sigma_r)))
    plain = StepTracker()
    times = [1.0 + k for k in range(30)] + [31.5, 32.0] + [math.nan, 34.0]
    standing = {30, 31}
    for k, time_s in enumerate(times):
        dx = [0.0, 0.0, 0.0, 0.0] if k in standing else [0.75, 0.0, 0.0, 0.0]
        held.add_step(dx, DP, k + 1, time_s=time_s)
        plain.add_step(dx, DP, k + 1)
    # steps 2..30, a second each; the standing resets, the step without a time and the one after: 0
    walked = 29.0
    assert np.array_equal(held.pose, plain.pose)
    extra = held.covariance - plain.covariance
    assert extra[3, 3] == pytest.approx((sigma_r * walked) ** 2, rel=1e-9)
    assert extra[1, 1] > 0.0  # the drifting heading carried the positions after sideways
    assert held.module_errors == (0.0, 0.0, 0.0, 0.0)
    assert held.state_covariance.shape == (9, 9)


def test_without_a_drift_prior_the_errors_are_the_three_states():
    errors = ModuleErrors(0.001, 0.002, 0.003)
    assert errors == ModuleErrors(0.001, 0.002, 0.003, 0.0) and errors.states == 3 and not errors.holds_drift
    assert ModuleErrors(0.001, 0.002, 0.003, 1e-5).states == 4
    np.testing.assert_allclose(ModuleErrors(0.1, 0.2, 0.3, 0.4).prior, np.diag([0.01, 0.04, 0.09, 0.16]))
    tracker = FusionTracker(FusionSettings(module_errors=errors))
    tracker.add_step([0.7, 0.0, 0.0, 0.1], DP, 1, time_s=1.0)
    tracker.add_step([0.7, 0.0, 0.0, 0.1], DP, 2, time_s=2.0)
    assert tracker.state_covariance.shape == (8, 8) and len(tracker.module_errors) == 3


def test_error_jacobian_with_a_duration_turns_the_heading_by_it():
    dx = np.array([3.0, 4.0, 1.0, 0.2])
    j = error_jacobian(math.pi / 2, dx, 0.8)
    assert j.shape == (4, 4)
    np.testing.assert_array_equal(j[:, :3], error_jacobian(math.pi / 2, dx))
    np.testing.assert_array_equal(j[:, 3], [0.0, 0.0, 0.0, 0.8])


@pytest.mark.parametrize(("dx", "time_s", "previous", "expected"), [
    ([0.7, 0.0, 0.0, 0.0], 5.0, 4.2, 0.8),
    ([0.0, 0.0, 0.0, 0.0], 5.0, 4.2, 0.0),  # standing still: the module's ZARU holds the heading
    ([0.7, 0.0, 0.0, 0.0], math.nan, 4.2, 0.0),  # no module time in the packet
    ([0.7, 0.0, 0.0, 0.0], 5.0, math.nan, 0.0),  # the first step, or the step before had no time
    ([0.7, 0.0, 0.0, 0.0], 4.0, 4.2, 0.0),  # a clock that went back
])
def test_a_steps_duration_is_the_time_since_the_step_before_while_the_foot_moved(dx, time_s, previous,
                                                                                  expected):
    assert step_duration(np.array(dx), time_s, previous) == pytest.approx(expected)


def test_a_compass_teaches_the_heading_drift_and_the_steps_after_are_corrected():
    """A module whose heading drifts 60 °/h walks straight north for 20 minutes, a step a second,
    with a compass reading the true heading (north): the filter learns r ≈ −60 °/h, and the
    heading it ends with is nearer north than that of the filter that does not hold the drift
    (whose compass keeps pulling back a heading the steps keep turning)."""
    rate = math.radians(60.0) / 3600.0
    settings = FusionSettings(compass=True, compass_sigma_rad=math.radians(2.0),
                              module_errors=ModuleErrors(0.0, 0.0, 0.0, math.radians(100.0) / 3600.0))
    held, plain = FusionTracker(settings), FusionTracker(replace(settings, module_errors=None))
    for t in (held, plain):
        t.compass_heading = lambda reading: 0.0
        t.calibrated_reading = lambda reading: None  # no field to check
        for k in range(1200):
            t.add_step([0.75, 0.0, 0.0, rate], DP, k + 1, time_s=float(k + 1), reading=object())
    assert held.module_errors[3] == pytest.approx(-rate, rel=0.05)
    assert abs(held.pose[3]) < 0.1 * abs(plain.pose[3])


def test_the_drift_prior_must_be_finite_and_not_negative():
    with pytest.raises(ValueError, match="heading_drift_sigma"):
        ModuleErrors(0.0, 0.0, 0.0, -1e-5)
