"""Two feet on the host: without the constraint the joint filter is the two single-module tracks
bit for bit; with it the feet never end farther apart than a step; a silent foot never pulls the
walking one, and a foot that lost steps restarts at the other."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hostlib.fusion.feet import FOOT_SIDES, FeetSettings, FootTracker, TwoFeetTracker
from hostlib.track.steps import StepTracker

DP = np.diag([1e-4, 1e-4, 1e-4, 1e-5])


@dataclass
class _Step:
    dx: np.ndarray
    dp: np.ndarray
    counter: int


def _alternate(tracker: TwoFeetTracker, steps: list[tuple[str, np.ndarray]], dp=DP,
               counters_from: list[tuple[str, np.ndarray]] = ()) -> None:
    """Each foot's steps of *steps* added to *tracker*, counted on from *counters_from*'s."""
    counters = {side: sum(1 for s, _ in counters_from if s == side) for side in FOOT_SIDES}
    for side, dx in steps:
        counters[side] += 1
        tracker.foot(side).add(_Step(np.asarray(dx, dtype=float), dp, counters[side]))


def _walk(n: int, left_turn: float = 0.0, right_turn: float = 0.0, stride: float = 1.5):
    """A straight walk: the right foot leads with half a stride, then the feet alternate whole
    strides; each module adds its own heading error per step."""
    steps = [("right", [0.5 * stride, 0.0, 0.0, right_turn])]
    for _ in range(n):
        steps += [("left", [stride, 0.0, 0.0, left_turn]), ("right", [stride, 0.0, 0.0, right_turn])]
    return steps


step_rows = st.lists(st.tuples(st.sampled_from(FOOT_SIDES), st.floats(-1, 1), st.floats(-1, 1),
                               st.floats(-0.2, 0.2), st.floats(-0.3, 0.3)), min_size=1, max_size=40)


@settings(max_examples=60, deadline=None)
@given(step_rows)
def test_without_the_constraint_the_feet_are_the_single_tracks_bit_for_bit(rows):
    tracker = TwoFeetTracker(FeetSettings(constraint=False))
    singles = {side: StepTracker(position=tracker.foot(side).track.final_pose[:3]) for side in FOOT_SIDES}
    counters = {side: 0 for side in FOOT_SIDES}
    for side, *dx in rows:
        counters[side] += 1
        tracker.foot(side).add(_Step(np.array(dx), DP, counters[side]))
        singles[side].add_step(dx, DP, counters[side])
    for i, side in enumerate(FOOT_SIDES):
        assert np.array_equal(tracker.fused_foot(side)[-1], singles[side].pose)
        block = slice(4 * i, 4 * i + 4)
        assert np.array_equal(tracker.covariance[block, block], singles[side].covariance)
    assert np.array_equal(tracker.covariance[:4, 4:], np.zeros((4, 4)))
    assert np.array_equal(tracker.body.final_pose, tracker.average.final_pose)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.floats(-2, 2), st.floats(-2, 2), st.floats(-0.5, 0.5), st.floats(-0.3, 0.3)),
                min_size=1, max_size=30), st.floats(0.3, 2.0))
def test_with_the_constraint_feet_end_every_step_within_the_bound(moves, gamma):
    """... every step a foot can take while the other stands (at most 2γ); a longer one is fused
    without the constraint and counted."""
    tracker = TwoFeetTracker(FeetSettings(max_separation_m=gamma))
    _alternate(tracker, [(FOOT_SIDES[k % 2], m) for k, m in enumerate(moves)])
    long = np.array([np.linalg.norm(m[:3]) > 2 * gamma for m in moves])
    assert tracker.separation()[1:][~long].max(initial=0.0) <= gamma + 1e-6
    assert tracker.long_steps == long.sum()
    p = tracker.covariance
    assert np.allclose(p, p.T) and np.linalg.eigvalsh(p).min() > -1e-9


def test_the_constraint_bounds_the_heading_drift_between_the_feet():
    drift = math.radians(0.5)  # per step, opposite ways: the feet's tracks splay apart
    free = TwoFeetTracker(FeetSettings(constraint=False))
    held = TwoFeetTracker()
    for tracker in (free, held):
        _alternate(tracker, _walk(200, left_turn=drift, right_turn=-drift))
    free_split = abs(free.state[3] - free.state[7])
    held_split = abs(held.state[3] - held.state[7])
    assert math.degrees(free_split) == pytest.approx(200.5, abs=1.0)
    assert held_split < 0.5 * free_split  # the estimate projection turns them back part of the way
    assert free.separation().max() > 50 and held.separation().max() <= 1.0 + 1e-6
    assert held.projections > 0


def test_without_an_aid_the_constraint_turns_the_feet_towards_each_other_not_the_walker():
    """The bound does not change when both feet turn or move together, and without an aid nothing
    sees that: the projection turns the splaying feet towards each other and leaves their mean
    heading where the steps put it (the free feet's: 0)."""
    drift = math.radians(0.5)
    free = TwoFeetTracker(FeetSettings(constraint=False))
    held = TwoFeetTracker()
    for tracker in (free, held):
        _alternate(tracker, _walk(200, left_turn=drift, right_turn=-drift))
    assert held.projections > 0
    assert abs(held.state[3] - held.state[7]) < 0.5 * abs(free.state[3] - free.state[7])
    assert held.state[3] + held.state[7] == pytest.approx(free.state[3] + free.state[7], abs=1e-9)


def test_the_bound_holds_exactly_when_the_feet_are_uncertain_far_across_their_difference():
    """800 steps with 1.8° of heading σ each: the feet's lateral σ grows to about 190 m, and the
    left foot's steps, 10 % short, pull the feet apart along the walk. Projecting onto the bound
    by relinearising at the violation swung the feet round the sphere and left them up to 10 m
    apart; the exact projection keeps every step within it."""
    dp = np.diag([1e-4, 1e-4, 1e-4, 1e-3])
    turn = math.radians(0.3)
    steps = [(side, [dx[0] * (0.9 if side == "left" else 1.0), *dx[1:]])
             for side, dx in _walk(400, left_turn=turn, right_turn=-turn)]
    tracker = TwoFeetTracker()
    _alternate(tracker, steps, dp=dp)
    assert tracker.covariance[1, 1] > 100.0 ** 2
    assert tracker.projections > 300
    assert tracker.separation().max() <= 1.0 + 1e-9


def test_steps_of_two_strides_leave_the_constraint_out_and_the_body_is_the_average():
    """A running module resets every other stride: each foot's step spans two strides and the
    feet's reported rests lie alternately half and one and a half strides apart. Those steps are
    longer than twice the bound, so the constraint does not pull the feet together."""
    stride = 2.6
    steps = [("right", [0.5 * stride, 0.0, 0.0, 0.0]), ("left", [2 * stride, 0.0, 0.0, 0.0])]
    for _ in range(10):
        steps += [("right", [2 * stride, 0.0, 0.0, 0.0]), ("left", [2 * stride, 0.0, 0.0, 0.0])]
    tracker = TwoFeetTracker(FeetSettings(max_separation_m=1.5))
    _alternate(tracker, steps)
    assert tracker.long_steps == 21 and tracker.projections == 0
    assert np.array_equal(tracker.body.final_pose, tracker.average.final_pose)
    assert tracker.separation().max() == pytest.approx(1.5 * stride, abs=0.13)


def test_a_step_within_the_bound_changes_nothing():
    free, held = TwoFeetTracker(FeetSettings(constraint=False)), TwoFeetTracker()
    for tracker in (free, held):
        _alternate(tracker, _walk(10))
    assert held.projections == 0
    assert np.array_equal(free.state, held.state) and np.array_equal(free.covariance, held.covariance)


def test_body_is_the_feet_midpoint_with_its_covariance():
    tracker = TwoFeetTracker()
    _alternate(tracker, _walk(4))
    s, p = tracker.state, tracker.covariance
    m = np.hstack([0.5 * np.eye(4), 0.5 * np.eye(4)])
    assert np.allclose(tracker.body.final_pose, m @ s)
    assert np.allclose(tracker.body.final_covariance, m @ p @ m.T)
    assert tracker.body.poses[0] == pytest.approx([0, 0, 0, 0])  # the feet start a step width apart
    assert tracker.fused_foot("left")[0][1] == pytest.approx(-0.06)


def test_the_body_asked_after_every_step_is_the_body_asked_once_at_the_end():
    """A live page asks for the body after every step; each row is made once and kept, and is the
    row a replay asking once at the end gets (a stale foot's rows included)."""
    steps = _walk(6) + [("left", [1.5, 0.0, 0.0, 0.01])] * 4 + _walk(3)[1:]
    live, once = TwoFeetTracker(), TwoFeetTracker()
    for k in range(len(steps)):
        _alternate(live, steps[:k + 1][-1:], counters_from=steps[:k])
        poses, covs = live.body_poses()
        assert len(poses) == len(covs) == len(live) + 1
    _alternate(once, steps)
    np.testing.assert_allclose(live.body.poses, once.body.poses, rtol=0, atol=1e-12)
    np.testing.assert_allclose(live.body.covariances, once.body.covariances, rtol=0, atol=1e-12)


def test_a_silent_foot_does_not_pull_the_walking_one_and_the_body_follows_the_walking_foot():
    tracker = TwoFeetTracker()
    steps = _walk(5)
    steps += [("left", [1.5, 0.0, 0.0, 0.0])] * 20  # the right foot's link is down
    _alternate(tracker, steps)
    assert tracker.fused_foot("left")[-1][0] == pytest.approx(1.5 * 25, abs=1e-9)
    assert tracker.stale_steps == 19  # every left step after the first one without the right
    assert tracker.body.final_pose == pytest.approx(tracker.fused_foot("left")[-1])


def test_a_foot_that_lost_steps_restarts_at_the_other_and_the_gap_is_reported():
    tracker = TwoFeetTracker()
    _alternate(tracker, _walk(5))
    for k in range(20):
        tracker.left.add(_Step(np.array([1.5, 0.0, 0.0, 0.0]), DP, 6 + k))
    tracker.right.add(_Step(np.array([1.5, 0.0, 0.0, 0.0]), DP, 6 + 21))  # its steps 7 … 26 lost
    gap = tracker.right.gaps[0]
    assert (gap.missing, tracker.restarts) == (20, [("right", len(tracker))])
    left, right = tracker.fused_foot("left")[-1], tracker.fused_foot("right")[-1]
    assert np.linalg.norm(left[:3] - right[:3]) <= 1.0 + 1e-6  # restarted beside the left foot
    assert tracker.right.track.final_pose[0] == pytest.approx(0.75 + 1.5 * 6)  # its single track did not


def test_resends_are_dropped_per_foot():
    tracker = TwoFeetTracker()
    step = _Step(np.array([0.75, 0.0, 0.0, 0.0]), DP, 1)
    tracker.right.add(step)
    tracker.right.add(step)
    tracker.left.add(step)
    assert (len(tracker), tracker.right.duplicates, tracker.left.duplicates) == (2, 1, 0)


def test_deferred_steps_fuse_in_module_time_order_else_alternately():
    from hostlib.fusion.feet import FootStep, _time_order

    def fs(side, t):
        return FootStep(side, np.zeros(4), DP, t, False)

    timed = [fs("left", 1.0), fs("left", 2.0), fs("right", 0.5), fs("right", 1.5)]
    assert [(s.side, s.time_s) for s in _time_order(timed)] == [("right", 0.5), ("left", 1.0), ("right", 1.5),
                                                              ("left", 2.0)]
    untimed = [fs("left", math.nan), fs("left", math.nan), fs("right", math.nan)]
    assert [s.side for s in _time_order(untimed)] == ["left", "right", "left"]


def test_settings_and_sides_are_checked():
    with pytest.raises(ValueError, match="maximum separation"):
        FeetSettings(max_separation_m=0.0)
    with pytest.raises(ValueError, match="left or right"):
        FootTracker("middle")
    with pytest.raises(ValueError, match="left or right"):
        TwoFeetTracker().foot("middle")
