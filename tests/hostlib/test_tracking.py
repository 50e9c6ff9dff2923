"""Step-wise dead-reckoning summation: golden tracks, covariance vs Monte-Carlo, resends, gaps."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hostlib.events import GapEvent, StepOutcome
from hostlib.track.step_checks import step_problem
from hostlib.track.steps import (
    StepTracker,
    counter_delta,
    is_motion_step,
    propagate,
    rotation_z,
)


@dataclass(frozen=True)
class S:
    """A stand-in with the attributes of protocol.codec.Step."""

    dx: np.ndarray
    dp: np.ndarray
    counter: int


def step(dx, counter, dp=None):
    return S(np.asarray(dx, dtype=np.float32), np.zeros((4, 4)) if dp is None else np.asarray(dp), counter)


# -- golden tracks --------------------------------------------------------------------------


def test_straight_walk_north_sums_positions_and_distance():
    t = StepTracker()
    for k in range(1, 4):
        assert t.add(step([1.0, 0, 0, 0], k)) is StepOutcome.SUMMED
    np.testing.assert_allclose(t.pose, [3.0, 0, 0, 0])
    assert t.distance == pytest.approx(3.0)
    assert len(t) == 3
    np.testing.assert_array_equal(t.track.counters, [1, 2, 3])
    assert t.track.poses.shape == (4, 4)


def test_heading_turns_later_steps_east():
    # x north, y east, z down: a +90° heading change turns a forward step to the east.
    t = StepTracker()
    t.add(step([1.0, 0, 0, math.pi / 2], 1))
    t.add(step([1.0, 0, 0, 0], 2))
    np.testing.assert_allclose(t.position, [1.0, 1.0, 0.0], atol=1e-7)
    assert t.heading == pytest.approx(math.pi / 2, abs=1e-7)


def test_square_loop_closes():
    t = StepTracker()
    for k in range(1, 5):
        t.add(step([2.0, 0, 0.01, math.pi / 2], k))
    assert t.track.closure_error() == pytest.approx(0.0, abs=1e-6)
    assert t.track.closure_error(horizontal=False) == pytest.approx(0.04, abs=1e-6)
    assert t.distance == pytest.approx(8.0)
    assert t.track.relative_closure_error() == pytest.approx(0.0, abs=1e-6)


def test_initial_pose_and_heading_are_respected():
    t = StepTracker(position=(10.0, 20.0, -1.0), heading=math.pi)
    t.add(step([1.0, 0.5, 0, 0], 1))
    np.testing.assert_allclose(t.position, [9.0, 19.5, -1.0], atol=1e-7)
    assert t.track.error_to((9.0, 19.5)) == pytest.approx(0.0, abs=1e-7)


def test_covariance_golden_two_steps():
    a, b = 1e-4, 1e-5
    dp = np.diag([a, a, a, b])
    t = StepTracker()
    t.add(step([0, 0, 0, 0], 1, dp))
    np.testing.assert_allclose(t.covariance, dp)
    t.add(step([1.0, 0, 0, 0], 2, dp))
    # F has ∂y/∂χ = 1: the heading uncertainty of step 1 leaks into y.
    expected = np.diag([2 * a, 2 * a + b, 2 * a, 2 * b])
    expected[1, 3] = expected[3, 1] = b
    np.testing.assert_allclose(t.covariance, expected, rtol=1e-12, atol=1e-18)
    np.testing.assert_allclose(t.track.sigmas[-1], np.sqrt(np.diag(expected)))


def test_initial_covariance_is_propagated():
    cov0 = np.diag([0.01, 0.02, 0.0, 0.001])
    t = StepTracker(covariance=cov0)
    t.add(step([0, 0, 0, 0], 1))
    np.testing.assert_allclose(t.covariance, cov0)
    with pytest.raises(ValueError, match="symmetric"):
        StepTracker(covariance=np.triu(np.ones((4, 4))))
    with pytest.raises(ValueError, match="4×4"):
        StepTracker(covariance=np.eye(3))


def test_rotation_is_about_z_and_proper():
    r = rotation_z(0.3)
    np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-15)
    assert np.linalg.det(r) == pytest.approx(1.0)
    np.testing.assert_allclose(r[2], [0, 0, 1])


# -- covariance against a Monte-Carlo of the summation map ----------------------------------


def _summation_map(pose: np.ndarray, dx: np.ndarray) -> np.ndarray:
    """The nonlinear map, vectorised over rows, written independently of propagate()."""
    chi = pose[:, 3]
    c, s = np.cos(chi), np.sin(chi)
    out = np.empty_like(pose)
    out[:, 0] = pose[:, 0] + c * dx[:, 0] - s * dx[:, 1]
    out[:, 1] = pose[:, 1] + s * dx[:, 0] + c * dx[:, 1]
    out[:, 2] = pose[:, 2] + dx[:, 2]
    out[:, 3] = chi + dx[:, 3]
    return out


def test_covariance_matches_monte_carlo_of_the_summation_map():
    rng = np.random.default_rng(20140527)
    n = 400_000
    pose0 = np.array([3.0, -2.0, 0.1, 0.7])
    a = rng.normal(size=(4, 4)) * np.array([0.05, 0.05, 0.02, 0.01])[:, None]
    cov0 = a @ a.T + np.diag([1e-3, 1e-3, 1e-4, 1e-4])
    dx = np.array([0.8, 0.15, -0.02, 0.05])
    b = rng.normal(size=(4, 4)) * np.array([0.02, 0.02, 0.01, 0.01])[:, None]
    dp = b @ b.T + np.diag([1e-4, 1e-4, 1e-5, 1e-5])

    _, lin = propagate(pose0, cov0, dx, dp)

    poses = rng.multivariate_normal(pose0, cov0, size=n)
    steps = rng.multivariate_normal(dx, dp, size=n)
    mc = np.cov(_summation_map(poses, steps), rowvar=False)

    # Standard error of a sample covariance entry: sqrt((Σii Σjj + Σij²) / n).
    d = np.diag(lin)
    se = np.sqrt((np.outer(d, d) + lin**2) / n)
    # Linearisation error is second order in σ_χ ≈ 0.03: allow 2 % of the entry scale.
    tol = 5 * se + 0.02 * np.sqrt(np.outer(d, d))
    assert np.all(np.abs(mc - lin) <= tol), f"max excess {np.max(np.abs(mc - lin) - tol)}"
    np.testing.assert_allclose(lin, lin.T)
    assert np.all(np.linalg.eigvalsh(lin) > 0)


def test_multi_step_covariance_matches_monte_carlo():
    rng = np.random.default_rng(7)
    n = 200_000
    steps_mean = np.array([[0.7, 0.0, 0.0, 0.1], [0.7, 0.05, 0.0, -0.2], [0.6, -0.05, 0.01, 0.3]])
    dp = np.diag([4e-4, 4e-4, 1e-4, 1e-4])
    t = StepTracker()
    for k, m in enumerate(steps_mean, start=1):
        t.add_step(m, dp, k)
    pose = np.zeros((n, 4))
    for m in steps_mean:
        pose = _summation_map(pose, rng.multivariate_normal(m, dp, size=n))
    mc = np.cov(pose, rowvar=False)
    lin = t.covariance
    d = np.diag(lin)
    tol = 5 * np.sqrt((np.outer(d, d) + lin**2) / n) + 0.02 * np.sqrt(np.outer(d, d))
    assert np.all(np.abs(mc - lin) <= tol)
    np.testing.assert_allclose(pose.mean(axis=0), t.pose, atol=5e-3)


# -- resends and gaps -----------------------------------------------------------------------


def test_resent_step_is_not_summed_twice():
    t = StepTracker()
    s1 = step([1.0, 0, 0, 0], 1)
    assert t.add(s1) is StepOutcome.SUMMED
    assert t.add(s1) is StepOutcome.DUPLICATE
    assert t.add(step([1.0, 0, 0, 0], 2)) is StepOutcome.SUMMED
    assert t.add(s1) is StepOutcome.DUPLICATE  # an older one arriving late
    assert len(t) == 2 and t.duplicates == 2
    assert t.distance == pytest.approx(2.0)


def test_gap_is_recorded_with_the_missing_count():
    t = StepTracker()
    t.add(step([1.0, 0, 0, 0], 1))
    assert t.add(step([1.0, 0, 0, 0], 5)) is StepOutcome.SUMMED_AFTER_GAP
    assert t.gaps == [GapEvent(after=1, counter=5, missing=3, index=2)]
    assert t.missing == 3
    assert "3 step(s) missing" in str(t.gaps[0])


def test_first_step_after_start_is_one_unless_attaching():
    t = StepTracker()
    t.add(step([1.0, 0, 0, 0], 3))
    assert t.missing == 2 and t.gaps[0].after == 0
    attached = StepTracker(last_counter=None)
    assert attached.add(step([1.0, 0, 0, 0], 1234)) is StepOutcome.SUMMED
    assert attached.gaps == []
    assert attached.add(step([1.0, 0, 0, 0], 1234)) is StepOutcome.DUPLICATE


def test_counter_wraps_at_uint16():
    t = StepTracker(last_counter=65534)
    for c in (65535, 0, 1):
        assert t.add(step([0.5, 0, 0, 0], c)) is StepOutcome.SUMMED
    assert t.add(step([0.5, 0, 0, 0], 65535)) is StepOutcome.DUPLICATE
    assert t.add(step([0.5, 0, 0, 0], 3)) is StepOutcome.SUMMED_AFTER_GAP
    assert t.missing == 1 and t.gaps[0].after == 1


def test_restart_counter_after_a_new_start_command():
    t = StepTracker()
    for c in (1, 2, 3):
        t.add(step([1.0, 0, 0, 0], c))
    t.restart_counter()
    assert t.add(step([1.0, 0, 0, 0], 1)) is StepOutcome.SUMMED
    assert len(t) == 4 and t.gaps == []


def test_bad_steps_are_refused_clearly():
    t = StepTracker()
    with pytest.raises(ValueError, match="uint16"):
        t.add_step(np.zeros(4), np.zeros((4, 4)), 70000)
    with pytest.raises(ValueError, match="dx"):
        t.add_step(np.zeros(3), np.zeros((4, 4)), 1)


@given(st.integers(0, 65535), st.integers(-32768, 32767))
def test_counter_delta_inverts_modular_offset(prev, delta):
    assert counter_delta(prev, (prev + delta) % 65536) == delta


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.integers(1, 6), min_size=1, max_size=40),
    st.lists(st.integers(0, 2), min_size=40, max_size=40),
)
def test_resends_and_gaps_never_change_the_sum(increments, repeats):
    """Summing a stream with resends equals summing each distinct step once; gaps add up."""
    counters, c = [], 0
    for inc in increments:
        c = (c + inc) % 65536
        counters.append(c)
    rng = np.random.default_rng(len(counters))
    dxs = {k: rng.normal(size=4) * [0.7, 0.1, 0.01, 0.2] for k in counters}
    clean = StepTracker()
    noisy = StepTracker()
    for i, k in enumerate(counters):
        clean.add_step(dxs[k], np.eye(4) * 1e-4, k)
        for _ in range(1 + repeats[i]):
            noisy.add_step(dxs[k], np.eye(4) * 1e-4, k)
    np.testing.assert_array_equal(noisy.track.poses, clean.track.poses)
    np.testing.assert_array_equal(noisy.track.covariances, clean.track.covariances)
    assert noisy.duplicates == sum(repeats[: len(counters)])
    assert noisy.missing == sum(increments) - len(increments)


def test_track_copy_is_independent():
    t = StepTracker()
    t.add(step([1.0, 0, 0, 0], 1))
    snap = t.track.copy()
    t.add(step([1.0, 0, 0, 0], 3))
    assert len(snap) == 1 and snap.distance == pytest.approx(1.0) and snap.gaps == []
    np.testing.assert_array_equal(snap.poses, t.track.poses[:2])


# -- steps with motion ----------------------------------------------------------------------


def test_a_reset_while_standing_is_not_a_step_with_motion():
    assert not is_motion_step([0.004, -0.002, 0.001, 0.0003])
    assert is_motion_step([0.28, 0.0, -0.17, 0.0]), "a stair tread"
    assert is_motion_step([0.0, 0.0, 0.0, math.radians(-40.0)]), "a turn on the spot"
    t = StepTracker()
    for k, dx in enumerate([[1.2, 0, 0, 0], [0.003, 0, 0, 0], [1.1, 0.1, 0, 0.2]], start=1):
        t.add(step(dx, k))
    assert len(t) == 3 and t.track.motion_steps == 2


# -- impossible steps -----------------------------------------------------------------------


@pytest.mark.parametrize(("dx", "dp", "why"), [
    ([0.5, math.inf, 0.0, 0.0], np.eye(4) * 1e-4, "dx"),
    ([0.5, 0.0, 0.0, 0.0], np.diag([1e-4, 1e-4, math.nan, 1e-5]), "not finite"),
    ([0.5, 0.0, 0.0, 0.0], np.diag([1e-4, -1e-4, 1e-4, 1e-5]), "positive semi-definite"),
    ([0.5, 0.0, 0.0, 0.0], np.array([[1e-4, 1e-3, 0, 0], [1e-3, 1e-4, 0, 0], [0, 0, 1e-4, 0],
                                     [0, 0, 0, 1e-5]]), "positive semi-definite"),
])
def test_a_step_with_impossible_numbers_is_counted_and_never_summed(dx, dp, why):
    t = StepTracker()
    t.add_step([1.0, 0.0, 0.0, 0.0], np.eye(4) * 1e-4, 1)
    before = (t.pose, t.covariance, t.distance)
    assert t.add_step(dx, dp, 2) is StepOutcome.REJECTED
    assert t.rejected == 1 and why in t.rejections[0][1] and t.rejections[0][0] == 2
    assert np.array_equal(t.pose, before[0]) and np.array_equal(t.covariance, before[1])
    assert t.distance == before[2] and len(t) == 1
    assert t.add_step(dx, dp, 2) is StepOutcome.DUPLICATE  # its resend is a resend
    assert t.add_step([1.0, 0.0, 0.0, 0.0], np.eye(4) * 1e-4, 3) is StepOutcome.SUMMED  # no gap: it was seen
    assert t.pose[0] == 2.0 and not t.gaps


def _verdict_by_eigenvalues(dx: np.ndarray, dp: np.ndarray) -> bool:
    """Whether a step may be summed by the definition: finite, dP symmetric (relative 1e-5), its
    symmetric part's smallest eigenvalue not below −1e-5 of the largest in size."""
    if not (np.isfinite(dx).all() and np.isfinite(dp).all()):
        return False
    if not (np.abs(dp - dp.T) <= 1e-5 * np.abs(dp.T)).all():
        return False
    with np.errstate(over="ignore"):
        eig = np.linalg.eigvalsh(0.5 * (dp + dp.T))
    return not eig[0] < -1e-5 * max(abs(eig[-1]), abs(eig[0]))


@settings(max_examples=400, deadline=None)
@given(a=st.lists(st.floats(-1.0, 1.0), min_size=16, max_size=16), shift=st.floats(-1.0, 1.0),
       asym=st.floats(-3e-5, 3e-5), dx=st.lists(st.floats(-2.0, 2.0), min_size=4, max_size=4),
       odd=st.one_of(st.none(), st.tuples(st.integers(0, 19), st.sampled_from([math.nan, math.inf, -math.inf,
                                                                             1e300, 0.0]))))
def test_a_step_is_summed_exactly_when_its_numbers_are_possible(a, shift, asym, dx, odd):
    """The quick test of every step (finite, symmetric, positive definite) never passes a step the
    definition refuses, and refuses none it passes: indefinite, near-singular, barely asymmetric
    and non-finite dPs included."""
    dp = np.array(a).reshape(4, 4) @ np.array(a).reshape(4, 4).T + shift * np.eye(4)
    dp[1, 2] *= 1.0 + asym
    dxa = np.array(dx)
    if odd is not None:
        k, value = odd
        (dxa if k >= 16 else dp.reshape(-1))[k % 16 if k < 16 else k - 16] = value
    assert (step_problem(dxa, dp) is None) == _verdict_by_eigenvalues(dxa, dp)


def test_a_float32_covariance_rounded_below_zero_is_still_summed():
    """The module's dP is float32: a direction known exactly can come out a few ε below zero."""
    dp = np.diag([1e-4, 1e-4, 1e-4, 1e-5]).astype(np.float32)
    dp[3, 3] = np.float32(-1e-12)
    t = StepTracker()
    assert t.add_step([0.5, 0.0, 0.0, 0.0], dp, 1) is StepOutcome.SUMMED and t.rejected == 0


@given(chi=st.floats(-1e4, 1e4))
def test_the_track_prints_its_heading_in_0_to_360_degrees_as_the_live_line_does(chi):
    t = StepTracker(heading=chi)
    shown = float(repr(t.track).split("χ=")[1].split("°")[0])
    assert 0.0 <= shown < 360.0
    assert shown == pytest.approx(math.degrees(chi) % 360.0, abs=0.051) or abs(shown) < 0.051 or shown > 359.9
