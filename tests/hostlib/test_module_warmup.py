"""The gyros' warm-up held as a state: each step turns the heading by w times the warm-up ramp
integrated over the step, less what the module re-learned the last time it stood still; without an
aid the track stays and the heading widens by that integral, a compass teaches w, and the option
and the summary name it."""

from __future__ import annotations

import argparse
import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hostlib.cli.options import module_errors_type as _module_errors
from hostlib.fusion.module_errors import (
    EMULATED_MODULE,
    EMULATED_MODULE_SWAYING,
    DriftClock,
    ModuleErrors,
    error_jacobian,
)
from hostlib.fusion.tracker import FusionSettings, FusionTracker
from hostlib.track.steps import StepTracker

DP = np.diag([1e-4, 1e-4, 1e-4, 1e-5])
WALK = np.array([0.75, 0.0, 0.0, 0.0])
STILL = np.zeros(4)
TAU = 120.0


def _ramp_integral(t0: float, t1: float, still: float, tau: float = TAU, n: int = 20001) -> float:
    """∫ (e^(−still/τ) − e^(−t/τ)) dt from t0 to t1, numerically (the trapezoid rule)."""
    t = np.linspace(t0, t1, n)
    rate = math.exp(-still / tau) - np.exp(-t / tau)
    return float(np.sum((rate[1:] + rate[:-1]) * np.diff(t)) / 2.0)


def test_a_steps_warmup_span_is_the_ramp_integrated_since_the_module_last_stood_still():
    """Steps from module time 10 s (the first step: the ramp's t = 0), a still stand at 70–72 s,
    a packet without a time, then walking on: each walking step's W is the ramp's rise since
    the last still reset integrated over the step; still resets, the first step and the step
    after a missing time add nothing."""
    clock = DriftClock(TAU)
    times = [10.0 + k for k in range(61)] + [71.0, 72.0] + [math.nan] + [74.0 + k for k in range(30)]
    still = {61, 62}
    expected_still = 0.0
    previous = math.nan
    for k, time_s in enumerate(times):
        dx = STILL if k in still else WALK
        span = clock.span(dx, time_s)
        t1 = time_s - 10.0
        if k in still or k == 0 or not math.isfinite(time_s) or not math.isfinite(previous):
            assert span.warmup_s == 0.0 and span.duration_s == 0.0
        else:
            assert span.duration_s == pytest.approx(time_s - previous)
            assert span.warmup_s == pytest.approx(_ramp_integral(t1 - span.duration_s, t1, expected_still),
                                                  rel=1e-6, abs=1e-12)
        if k in still:
            expected_still = t1
        previous = time_s


@settings(max_examples=60, deadline=None)
@given(gaps=st.lists(st.floats(0.2, 5.0), min_size=1, max_size=80), tau=st.floats(10.0, 600.0))
def test_without_a_stand_the_spans_sum_to_the_ramps_integral_over_the_walk(gaps, tau):
    """However the walk is cut into steps, the spans add up to ∫₀ᵀ (1 − e^(−t/τ)) dt =
    T − τ(1 − e^(−T/τ)): the heading the warm-up turns does not depend on where the resets fall."""
    clock = DriftClock(tau)
    time_s, total = 3.0, 0.0
    clock.span(WALK, time_s)
    for gap in gaps:
        time_s += gap
        total += clock.span(WALK, time_s).warmup_s
    walked = time_s - 3.0
    assert total == pytest.approx(walked - tau * (1.0 - math.exp(-walked / tau)), rel=1e-9, abs=1e-12)


def test_packets_lost_make_the_next_span_unknown():
    clock = DriftClock(TAU)
    clock.span(WALK, 1.0)
    assert clock.span(WALK, 2.0).warmup_s > 0.0
    clock.lose_previous()
    span = clock.span(WALK, 3.0)
    assert span.duration_s == 0.0 and span.warmup_s == 0.0
    assert clock.span(WALK, 4.0).warmup_s > 0.0


def test_without_aids_the_warmup_widens_the_heading_by_the_summed_spans_and_leaves_the_track():
    """No aid, straight steps a second apart for five minutes: the track is the plain sum, bit for
    bit, and the heading's variance is the plain one plus σ_w² (ΣW)², ΣW = T − τ(1 − e^(−T/τ))."""
    sigma_w = math.radians(0.05)
    errors = ModuleErrors(0.0, 0.0, 0.0, heading_warmup_sigma=sigma_w)
    held = FusionTracker(FusionSettings(module_errors=errors))
    plain = StepTracker()
    for k in range(301):
        held.add_step(WALK, DP, k + 1, time_s=5.0 + k)
        plain.add_step(WALK, DP, k + 1)
    assert np.array_equal(held.pose, plain.pose)
    walked = 300.0
    summed = walked - TAU * (1.0 - math.exp(-walked / TAU))
    extra = held.covariance - plain.covariance
    assert extra[3, 3] == pytest.approx((sigma_w * summed) ** 2, rel=1e-9)
    assert extra[1, 1] > 0.0  # the heading the warm-up turned carried the positions after sideways
    assert held.module_errors == (0.0, 0.0, 0.0, 0.0)  # s, c, k and w (no drift rate held)
    assert held.state_covariance.shape == (9, 9)


def test_a_compass_teaches_the_warmup_and_the_steps_after_are_corrected():
    """A module whose vertical rate's bias rises by 0.05 °/s with τ 120 s walks straight north for
    ten minutes, a step a second, with a compass reading the true heading: the filter learns
    w ≈ 0.05 °/s, and ends nearer north than the filter that holds only a constant drift rate."""
    warmup = math.radians(0.05)
    constant = ModuleErrors(0.0, 0.0, 0.0, math.radians(100.0) / 3600.0)
    settings = FusionSettings(compass=True, compass_sigma_rad=math.radians(2.0),
                              module_errors=replace(constant, heading_warmup_sigma=math.radians(0.1)))
    held, rate_only = FusionTracker(settings), FusionTracker(replace(settings, module_errors=constant))
    for t in (held, rate_only):
        t.compass_heading = lambda reading: 0.0
        t.calibrated_reading = lambda reading: None  # no field to check
        for k in range(600):
            # the true turn over the step from t to t + 1: w ∫ (1 − e^(−t/τ)) dt
            turn = warmup * (1.0 - TAU * (math.exp(-k / TAU) - math.exp(-(k + 1) / TAU)))
            t.add_step([0.75, 0.0, 0.0, turn], DP, k + 1, time_s=float(k), reading=object())
    assert held.module_errors[4] == pytest.approx(-warmup, rel=0.1)
    assert abs(held.pose[3]) < 0.5 * abs(rate_only.pose[3])


def test_the_warmup_is_the_last_error_state_with_or_without_the_drift_rate():
    both = ModuleErrors(0.1, 0.2, 0.3, 0.4, 0.5)
    assert both.states == 5 and both.holds_drift and both.holds_warmup
    np.testing.assert_allclose(both.prior, np.diag([0.01, 0.04, 0.09, 0.16, 0.25]))
    warmup_only = ModuleErrors(0.1, 0.2, 0.3, heading_warmup_sigma=0.5)
    assert warmup_only.states == 4 and not warmup_only.holds_drift
    np.testing.assert_allclose(warmup_only.prior, np.diag([0.01, 0.04, 0.09, 0.25]))
    dx = np.array([3.0, 4.0, 1.0, 0.2])
    j = error_jacobian(math.pi / 2, dx, 0.8, 2.5)
    np.testing.assert_array_equal(j[:, :4], error_jacobian(math.pi / 2, dx, 0.8))
    np.testing.assert_array_equal(j[:, 4], [0.0, 0.0, 0.0, 2.5])
    np.testing.assert_array_equal(error_jacobian(math.pi / 2, dx, None, 2.5)[:, 3], [0.0, 0.0, 0.0, 2.5])
    assert not EMULATED_MODULE.holds_warmup and EMULATED_MODULE.states == 4  # its figures unchanged


@pytest.mark.parametrize(("field", "value"), [("heading_warmup_sigma", -1e-4),
                                              ("heading_warmup_sigma", math.nan),
                                              ("warmup_tau_s", 0.0), ("warmup_tau_s", math.inf)])
def test_the_warmup_prior_and_time_constant_are_checked(field, value):
    with pytest.raises(ValueError, match=field):
        ModuleErrors(0.0, 0.0, **{field: value})


def test_the_module_errors_option_takes_the_warmup_and_its_time_constant():
    errors = _module_errors("0.001,0.002,0.01,20,0.05,90")
    assert errors.heading_drift_sigma == pytest.approx(math.radians(20.0) / 3600.0)
    assert errors.heading_warmup_sigma == pytest.approx(math.radians(0.05))
    assert errors.warmup_tau_s == 90.0
    assert _module_errors("0.001,0.002,0.01,20,0.05").warmup_tau_s == TAU
    assert _module_errors("Emulated-Sway") is EMULATED_MODULE_SWAYING and EMULATED_MODULE_SWAYING.holds_warmup
    # 'emulated' is the emulated module as it walks by default, on swaying stances
    assert _module_errors("emulated") is EMULATED_MODULE_SWAYING
    assert _module_errors("emulated-still") is EMULATED_MODULE and not EMULATED_MODULE.holds_warmup
    for bad in ("0.001,0.002,0.01,20,0.05,0", "1,2,3,4,5,6,7"):
        with pytest.raises(argparse.ArgumentTypeError, match="WARMUP_DEG_PER_S"):
            _module_errors(bad)


def test_the_swaying_modules_warmup_prior_is_the_simulated_sensors_physics():
    """The emulated module's warm-up prior follows from its sensor model, not from any walk: each
    chip's gyro offset moves by a uniform ±c per °C on each axis (1σ c/√3), the module averages
    four chips (÷2), and the dies warm by ΔT with the model's time constant."""
    from firmware_sim.sensors.config import SensorConfig

    sensors = SensorConfig()
    sigma = sensors.gyro.offset_tempco_rad_s_per_c / math.sqrt(3.0) / 2.0 * sensors.temperature.warmup_c
    assert EMULATED_MODULE_SWAYING.heading_warmup_sigma == pytest.approx(sigma, rel=2e-3)
    assert EMULATED_MODULE_SWAYING.warmup_tau_s == sensors.temperature.warmup_tau_s
