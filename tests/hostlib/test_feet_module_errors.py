"""Two feet with the module's errors held: each foot's module has its own step-length scale, climb,
turn scale, heading drift and warm-up in the joint filter; without an aid they leave both feet's tracks and
widen each foot's covariance as one module's filter does, GPS of the body and the constraint
teach the module whose steps are short, and the joint covariance stays symmetric and positive."""

from __future__ import annotations

import io
import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hostlib.cli import main
from hostlib.cli.outputs import feet_summary
from hostlib.files.export import read_feet_csv
from hostlib.fusion.deviation import OUTDOORS, WHITE_SIGMA_RAD
from hostlib.fusion.feet import DISAGREEMENT_SIGMAS, FOOT_SIDES, FeetSettings, FootStep, TwoFeetTracker
from hostlib.fusion.gps_bias import GpsBias
from hostlib.fusion.module_errors import EMULATED_MODULE, ModuleErrors
from hostlib.fusion.tracker import FusionSettings, FusionTracker
from hostlib.track.steps import rotation_z

from .covariance_checks import assert_symmetric_psd, walk_two_feet_at_random
from .loops import fusion_capture, rectangle

DP = np.diag([1e-4, 1e-4, 1e-4, 1e-5])
STRIDE = 1.4
STEP_PERIOD = 0.55  # s between the two feet's steps
ERRORS = ModuleErrors(0.002, 0.003, 0.01, math.radians(20.0) / 3600.0)


def _errors(feet: TwoFeetTracker, side: str) -> slice:
    """Where *side*'s module's errors are in the joint state."""
    return feet.filter.slice(f"errors.{side}")


def _walk_steps(seed: int, strides: int = 60) -> list[tuple[str, np.ndarray, float]]:
    """A walk of both feet on an arc, 0.6° a step (the right foot's half stride first, the left's
    last, each turning half that), then standing still a few resets: (side, step, module time) in
    the order taken."""
    rng = np.random.default_rng(seed)
    steps = []
    for n in range(2 * strides + 7):
        side = FOOT_SIDES[(n + 1) % 2]
        half = 0.5 if n in (0, 2 * strides) else 1.0
        length = 0.0 if n > 2 * strides else STRIDE * half
        turn = 0.0 if length == 0.0 else 0.01 * half + 0.0005 * rng.standard_normal()
        dx = np.array([length + 0.01 * rng.standard_normal(), 0.01 * rng.standard_normal(),
                       0.005 * rng.standard_normal(), turn])
        steps.append((side, dx, STEP_PERIOD * (n + 1)))
    return steps


def _feed(feet: TwoFeetTracker, steps, after=None) -> None:
    """Each step to its foot's tracker, then *after()* (if given)."""
    counter = dict.fromkeys(FOOT_SIDES, 0)
    for side, dx, time_s in steps:
        counter[side] += 1
        feet.foot(side).add_step(dx, DP, counter[side], 0.4, time_s=time_s)
        if after is not None:
            after()


# -- without aids ---------------------------------------------------------------------------


@pytest.mark.parametrize("errors", [ERRORS, replace(ERRORS, heading_drift_sigma=0.0),
                                    replace(ERRORS, heading_warmup_sigma=math.radians(0.05))],
                         ids=["drift", "no drift", "drift and warm-up"])
def test_without_aids_the_errors_leave_both_feet_and_widen_each_as_its_single_module_filter(errors):
    """No aid, a walk whose feet never part by more than γ: both fused feet are where the plain
    joint filter puts them, bit for bit, and each foot's pose covariance after every step is
    that of one module's filter holding the same errors fed that foot's steps; the two modules'
    errors stay uncorrelated, each with its prior."""
    steps = _walk_steps(seed=5)
    held, plain = TwoFeetTracker(aids=FusionSettings(module_errors=errors)), TwoFeetTracker()
    covs = [held.covariance.copy()]  # the feet's poses' covariance after each step (row 0: the start)
    _feed(held, steps, after=lambda: covs.append(held.covariance.copy()))
    _feed(plain, steps)
    assert held.projections == plain.projections == 0 and len(held) == len(steps)
    assert held.filter.P.shape == (8 + 2 * errors.states + 1,) * 2
    for i, side in enumerate(FOOT_SIDES):
        assert np.array_equal(held.fused_foot(side), plain.fused_foot(side))
        single = FusionTracker(FusionSettings(module_errors=errors), position=plain.fused_foot(side)[0, :3])
        for k, (_, dx, time_s) in enumerate(s for s in steps if s[0] == side):
            single.add_step(dx, DP, k + 1, time_s=time_s)
        rows = [0] + [n + 1 for n, stepped in enumerate(held.sides) if stepped == side]  # row 0: the start
        np.testing.assert_allclose(np.array(covs)[rows][:, 4 * i: 4 * i + 4, 4 * i: 4 * i + 4],
                                   single.track.covariances, rtol=1e-12, atol=1e-18)
        e = _errors(held, side)
        np.testing.assert_allclose(held.filter.P[e, e], errors.prior, rtol=0,
                                   atol=0)
        assert held.module_errors(side) == (0.0,) * errors.states
        # the plain filter's covariance is narrower: the errors grow with the distance and the turns
        assert np.all(held.fused_foot_sigmas(side)[-1] > plain.fused_foot_sigmas(side)[-1])
    assert not held.filter.P[_errors(held, "left"), _errors(held, "right")].any()


def test_without_aids_the_modules_errors_stay_uncorrelated_through_the_constraint_and_restarts():
    """The constraint moves the estimate, not the covariance, and a restarted foot copies the
    other foot's pose, not its module's errors: with no aid nothing correlates the two modules."""
    feet = TwoFeetTracker(FeetSettings(max_separation_m=0.8), aids=FusionSettings(module_errors=ERRORS))
    walk_two_feet_at_random(feet, np.random.default_rng(8), steps=120)
    assert feet.projections > 0 and feet.restarts
    assert not feet.filter.P[_errors(feet, "left"), _errors(feet, "right")].any()
    for side in FOOT_SIDES:
        np.testing.assert_array_equal(feet.filter.P[_errors(feet, side), _errors(feet, side)], ERRORS.prior)


def test_not_held_the_joint_state_is_the_feet_and_the_aid_states():
    feet = TwoFeetTracker(aids=FusionSettings(gps=True, gps_bias=GpsBias(), compass=True,
                                              compass_deviation=OUTDOORS))
    assert feet.filter.P.shape == (12, 12) and feet.module_errors("left") is None
    assert feet.module_error_sigmas("right") is None


def test_the_errors_sit_after_both_feet_and_the_aid_states_last():
    """[L, R, s_L, c_L, k_L, r_L, s_R, c_R, k_R, r_R, b_n, b_e, d, D]: each module's priors where
    its errors are, the aid states after them (b, d, D: four), read back by the properties."""
    s = FusionSettings(compass=True, gps=True, gps_bias=GpsBias(sigma_m=2.0), compass_deviation=OUTDOORS,
                       module_errors=ERRORS, declination_rad=0.1, declination_sigma_rad=0.2)
    feet = TwoFeetTracker(aids=s)
    aid_states = 4  # b_n, b_e, d, D
    assert list(feet.filter.blocks) == ["left", "right", "errors.left", "errors.right",
                                        "gps_bias", "deviation", "declination"]
    assert feet.filter.P.shape == (8 + 8 + aid_states,) * 2
    assert _errors(feet, "left") == slice(8, 12) and _errors(feet, "right") == slice(12, 16)
    np.testing.assert_array_equal(feet.module_error_sigmas("left"),
                                  [0.002, 0.003, 0.01, ERRORS.heading_drift_sigma])
    assert feet.declination == 0.1 and feet.declination_sigma == 0.2
    assert feet.gps_bias_sigma[0] == 2.0 and feet.deviation_sigma == OUTDOORS.sigma_rad
    assert feet.state.shape == (8,) and feet.covariance.shape == (8, 8)
    # each foot's own tracker holds its module's errors on its own
    assert all(feet.foot(side).state_covariance.shape == (4 + 4 + aid_states,) * 2 for side in FOOT_SIDES)


# -- learned from the aids ------------------------------------------------------------------


def _gps_walk(errors: ModuleErrors | None, constraint: bool = True, short: float = 0.97,
              strides: int = 300) -> TwoFeetTracker:
    """Two feet walk 420 m north, the left foot's module's steps *short* of the truth, with fixes
    of the body every second (1 m noise) used every 5 s with σ 5 m."""
    gps = dict(gps=True, gps_sigma_m=5.0, gps_interval_s=5.0, gps_align_distance_m=20.0)
    feet = TwoFeetTracker(FeetSettings(constraint=constraint),
                          aids=FusionSettings(module_errors=errors, **gps))
    rng = np.random.default_rng(3)
    n = 2 * strides + 1
    times = np.arange(0.0, n * STEP_PERIOD, 1.0)
    body = times * STRIDE / (2 * STEP_PERIOD)
    feet.add_fixes(times, np.column_stack([body, np.zeros_like(body)]) + rng.normal(0, 1.0, (times.size, 2)))
    counter = dict.fromkeys(FOOT_SIDES, 0)
    for k in range(n):
        side = FOOT_SIDES[(k + 1) % 2]
        counter[side] += 1
        length = STRIDE * (0.5 if k == 0 else 1.0) * (short if side == "left" else 1.0)
        feet.foot(side).add_step([length, 0.0, 0.0, 0.0], DP, counter[side], 0.4,
                                 time_s=STEP_PERIOD * (k + 1))
    return feet


def test_gps_of_the_body_and_the_constraint_teach_the_short_modules_step_length_scale():
    """The left module's steps are 3 % short: GPS of the body teaches the two scales' sum, the
    constraint (which keeps the feet together) their difference, so the filter learns s ≈ +3 % for
    the left module and ≈ 0 for the right, and the body ends nearer the truth than without them."""
    errors = ModuleErrors(0.02, 0.001)
    held, plain = _gps_walk(errors), _gps_walk(None)
    s_left, s_right = held.module_errors("left")[0], held.module_errors("right")[0]
    assert s_left == pytest.approx(1 / 0.97 - 1, abs=0.005)
    assert s_right == pytest.approx(0.0, abs=0.005)
    truth = 300 * STRIDE
    assert abs(held.body.final_pose[0] - truth) < 0.5 < abs(plain.body.final_pose[0] - truth)
    # GPS measures the sum: the two modules' scales are now correlated, negatively
    e_l, e_r = _errors(held, "left").start, _errors(held, "right").start
    assert held.filter.P[e_l, e_r] < 0.0
    # without the constraint nothing tells the feet apart: each learns half
    apart = _gps_walk(errors, constraint=False)
    s = [apart.module_errors(side)[0] for side in FOOT_SIDES]
    assert sum(s) == pytest.approx(1 / 0.97 - 1, abs=0.005) and s[0] == pytest.approx(s[1], abs=0.005)


def test_each_foots_compass_teaches_its_own_modules_heading_drift():
    """The left module's heading drifts 60 °/h, the right one's not at all; the walker goes north
    for ten minutes with each foot's compass reading north: the left module learns r ≈ −60 °/h,
    the right ≈ 0."""
    rate = math.radians(60.0) / 3600.0
    errors = ModuleErrors(0.0, 0.0, 0.0, math.radians(100.0) / 3600.0)
    feet = TwoFeetTracker(aids=FusionSettings(compass=True, compass_sigma_rad=math.radians(2.0),
                                              module_errors=errors))
    for side in FOOT_SIDES:
        feet.foot(side).compass_heading = lambda reading: 0.0
        feet.foot(side).calibrated_reading = lambda reading: None  # no field to check
    counter = dict.fromkeys(FOOT_SIDES, 0)
    for k in range(1100):
        side = FOOT_SIDES[(k + 1) % 2]
        counter[side] += 1
        drift = 2 * STEP_PERIOD * rate if side == "left" and k > 0 else 0.0
        feet.foot(side).add_step([STRIDE * (0.5 if k == 0 else 1.0), 0.0, 0.0, drift], DP, counter[side], 0.4,
                                 reading=object(), time_s=STEP_PERIOD * (k + 1))
    assert feet.module_errors("left")[3] == pytest.approx(-rate, rel=0.1)
    assert abs(feet.module_errors("right")[3]) < 0.1 * rate


def test_with_each_modules_drift_held_the_constraint_keeps_two_drifting_feet_parallel():
    """Without an aid, the left module's heading drifts +90 °/h and the right one's −45 °/h for
    twenty minutes north: alone the feet part by 45°; the constraint alone leaves 18° between
    them; with each module's drift held it learns the rates' difference and keeps them within 2°
    (docs/two-feet.md, the 22-minute walk)."""
    rates = {"left": math.radians(90.0) / 3600.0, "right": math.radians(-45.0) / 3600.0}
    errors = ModuleErrors(0.0, 0.0, 0.0, math.radians(100.0) / 3600.0)

    def walk(feet: TwoFeetTracker) -> float:
        counter = dict.fromkeys(FOOT_SIDES, 0)
        for k in range(2200):
            side = FOOT_SIDES[(k + 1) % 2]
            counter[side] += 1
            drift = 2 * STEP_PERIOD * rates[side] if k > 0 else 0.0
            feet.foot(side).add_step([STRIDE * (0.5 if k == 0 else 1.0), 0.0, 0.0, drift], DP, counter[side],
                                     0.4, time_s=STEP_PERIOD * (k + 1))
        return math.degrees(abs(feet.state[3] - feet.state[7]))

    free = walk(TwoFeetTracker(FeetSettings(constraint=False)))
    constrained_feet = TwoFeetTracker()
    constrained = walk(constrained_feet)
    held_feet = TwoFeetTracker(aids=FusionSettings(module_errors=errors))
    held = walk(held_feet)
    assert free == pytest.approx(45.4, abs=0.5)
    assert 10.0 < constrained < 0.5 * free
    assert held < 2.0
    # the constraint alone turns the walker away from the average (within the covariances twenty
    # minutes without an aid leave: no warning yet); holding the drift keeps the body with it
    assert held_feet.disagreement()[1] < 1.0 < constrained_feet.disagreement()[1] < DISAGREEMENT_SIGMAS


def test_feet_whose_headings_drift_apart_unheld_pull_the_body_from_the_average_and_it_is_reported():
    """Modules that send tiny covariances while one foot's heading turns 0.5° a step: the
    constraint holds the feet together by turning the walker, and the fused body ends tens of
    metres from the average, hundreds of σ of what the steps' covariances allow — reported."""
    feet = TwoFeetTracker()
    counter = dict.fromkeys(FOOT_SIDES, 0)
    dp = np.diag([1e-6, 1e-6, 1e-6, 1e-8])
    for k in range(400):
        side = FOOT_SIDES[(k + 1) % 2]
        counter[side] += 1
        turn = 0.01 if side == "left" else 0.0
        feet.foot(side).add_step([STRIDE * (0.5 if k == 0 else 1.0), 0.0, 0.0, turn], dp, counter[side])
    apart, sigmas = feet.disagreement()
    assert apart > 10.0 and sigmas > 100 * DISAGREEMENT_SIGMAS
    lines = feet_summary(feet, {})
    assert any(line.startswith("warning: the fused body and the average end") for line in lines)


# -- the covariance stays a covariance ------------------------------------------------------


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2 ** 16), compass=st.booleans(), gps=st.booleans(), deviation=st.booleans(),
       bias=st.booleans(), drift=st.booleans(), scale=st.floats(1e-4, 0.05), turn=st.floats(0.0, 0.05))
def test_two_feet_covariance_with_the_module_errors_stays_symmetric_and_positive_semi_definite(
        seed, compass, gps, deviation, bias, drift, scale, turn):
    """Random walks of two feet (stands, gaps, missing readings) with each module's errors held,
    with and without the compass, GPS, the local deviation and the receiver's bias: the joint
    covariance stays symmetric and positive semi-definite, and no module's error is ever less
    certain than its prior."""
    rng = np.random.default_rng(seed)
    errors = ModuleErrors(scale, 0.002, turn, 3e-5 if drift else 0.0)
    feet = TwoFeetTracker(aids=FusionSettings(compass=compass, gps=gps, module_errors=errors,
                                              compass_sigma_rad=WHITE_SIGMA_RAD if deviation else 0.2,
                                              compass_deviation=OUTDOORS if deviation else None,
                                              gps_bias=GpsBias() if bias else None, gps_align_distance_m=5.0))
    if gps:
        times = np.arange(0.0, 40.0, 1.0)
        path = np.column_stack([0.6 * times, 0.1 * times])
        feet.add_fixes(times, path + rng.normal(0.0, 2.0, (times.size, 2)))
    walk_two_feet_at_random(feet, rng)
    prior = np.sqrt(np.diag(errors.prior))
    for side in FOOT_SIDES:
        assert np.all(feet.module_error_sigmas(side) <= prior * (1 + 1e-9) + 1e-15)


def test_the_first_reading_keeps_each_headings_covariance_with_the_turn_scales_relative_to_it():
    """After a turn the two headings carry their modules' turn scales; the first reading sets the
    right foot's heading, and the left foot's keeps what it was relative to it: its covariance
    with each module's k is that of χ_L − χ_R."""
    errors = ModuleErrors(0.0, 0.0, 0.05)
    feet = TwoFeetTracker(aids=FusionSettings(compass=True, compass_sigma_rad=math.radians(5.0),
                                              module_errors=errors))
    feet.take(FootStep("right", np.array([0.7, 0.0, 0.0, 1.0]), DP, 0.55, False, compass=None))
    feet.take(FootStep("left", np.array([1.4, 0.0, 0.0, 0.5]), DP, 1.1, False, compass=None))
    before = feet.filter.P.copy()
    feet.take(FootStep("right", np.zeros(4), DP, 1.65, False, compass=0.2))
    assert feet.fusion.heading_aligned_by == "compass"
    k_left, k_right = _errors(feet, "left").start + 2, _errors(feet, "right").start + 2
    for k in (k_left, k_right):
        assert feet.filter.P[3, k] == pytest.approx(before[3, k] - before[7, k])
        assert feet.filter.P[7, k] == 0.0
    assert feet.filter.P[3, k_left] == pytest.approx(0.5 * 0.05 ** 2)
    assert feet.filter.P[3, k_right] == pytest.approx(-1.0 * 0.05 ** 2)
    assert_symmetric_psd(feet.filter.P)
    assert feet.state[3] == pytest.approx(0.2 - 1.0 + 0.5) and feet.state[7] == pytest.approx(0.2)
    assert np.allclose(feet.state[4:6], rotation_z(0.2 - 1.0)[:2, :2] @ [0.7, 0.06])


# -- the command line -----------------------------------------------------------------------


def test_replay_of_two_captures_holds_each_modules_errors_and_leaves_the_body(tmp_path):
    """``replay LEFT RIGHT --module-errors`` runs: the body and both feet are where they are
    without them (``--no-module-errors``), each foot's height 1σ is its single module's, grown by the
    climb over its path, and the summary says the errors are held."""
    left, right = tmp_path / "left.bin", tmp_path / "right.bin"  # the same walk, on each foot
    for capture in (left, right):
        capture.write_bytes(fusion_capture(rectangle((0.0, 0.0, 0.0)), b"OSEMU-M00000003"))
    plain_csv, held_csv = tmp_path / "plain.csv", tmp_path / "held.csv"
    two = ["replay", str(left), str(right)]
    assert main([*two, "--no-module-errors", "--csv", str(plain_csv)], io.StringIO()) == 0
    out = io.StringIO()
    assert main([*two, "--module-errors", "0.001,0.002", "--csv", str(held_csv)], out) == 0
    text = out.getvalue()
    assert "module errors held: step-length scale σ 0.001, climb σ 0.002 m/m, turn scale σ 0" in text
    assert "fusion: 0 compass updates" in text and "restarts: none" in text
    plain, held = read_feet_csv(plain_csv), read_feet_csv(held_csv)
    np.testing.assert_array_equal(held.body.poses, plain.body.poses)
    path = rectangle((0.0, 0.0, 0.0)).dx[:, :2]
    walked = float(np.hypot(path[:, 0], path[:, 1]).sum())
    for side in FOOT_SIDES:
        np.testing.assert_array_equal(held.feet[side], plain.feet[side])
        extra = held.sigmas[side][-1, 2] ** 2 - plain.sigmas[side][-1, 2] ** 2
        assert extra == pytest.approx((0.002 * walked) ** 2, rel=1e-3)
    assert main([*two, "--module-errors", "emulated"], io.StringIO()) == 0


def test_track_with_two_devices_holds_the_module_errors_live(tmp_path):
    import serial

    serial.protocol_handler_packages.append("tests.hostlib")
    try:
        out, csv_path = io.StringIO(), tmp_path / "live.csv"
        argv = ["track", "fakeshoe://4", "fakeshoe://4/module2", "--fusion", "--steps", "4",
                "--duration", "30", "--module-errors", "emulated-still", "--csv", str(csv_path)]
        assert main(argv, out) == 0
    finally:
        serial.protocol_handler_packages.remove("tests.hostlib")
    drift = math.degrees(EMULATED_MODULE.heading_drift_sigma) * 3600
    assert (f"module errors held (emulated-still): step-length scale σ {EMULATED_MODULE.step_scale_sigma:g}"
            in out.getvalue())
    assert f"heading drift σ {drift:.3g} °/h" in out.getvalue()
    feet = read_feet_csv(csv_path)
    assert feet.sides.count("left") == 4 and feet.sides.count("right") == 4
