"""One walker, two feet: both feet come from one body path, alternate, keep a step apart and stop
side by side; each foot wears its own module."""

from __future__ import annotations

import numpy as np
import pytest

from firmware_sim.sensors.feet import SIDES, STEP_WIDTH_M, foot_module, foot_seed
from firmware_sim.sensors.gait import STAIRS_UP, WALKING
from firmware_sim.sensors.scenarios import feet, trajectory


def _swings(traj) -> np.ndarray:
    """(k, 2) start and end [s] of each swing of a trajectory."""
    truth = traj.sample(1000.0)
    return np.column_stack([truth.stance_end[:-1], truth.stance_start[1:]])


@pytest.mark.parametrize("scenario", ["walk", "default", "turn_on_spot", "stairs_up", "side_steps", "mixed"])
def test_feet_start_and_stop_side_by_side_one_step_width_apart(scenario):
    walked = feet(scenario)
    for t in (0.0, walked.duration):
        left, right = walked.left.evaluate([t]), walked.right.evaluate([t])
        apart = right.pos[0] - left.pos[0]
        assert np.hypot(*apart[:2]) == pytest.approx(STEP_WIDTH_M, abs=1e-9)
        assert left.euler[0, 2] == pytest.approx(right.euler[0, 2])


def test_the_feet_swing_in_turn_never_both_at_once_while_walking():
    walked = feet("walk")
    left, right = _swings(walked.left), _swings(walked.right)
    assert len(right) == len(left) + 1  # a half step to lead and a half step to close
    events = sorted([(a, b, "L") for a, b in left] + [(a, b, "R") for a, b in right])
    assert "".join(e[2] for e in events) == "R" + "LR" * len(left)
    for (_, end, _), (start, _, _) in zip(events, events[1:], strict=False):
        assert start >= end  # one foot always on the ground


def test_right_foot_rests_half_a_stride_from_the_left_while_walking():
    walked = feet("walk")
    left = walked.left.sample(100.0).stance_positions
    right = walked.right.sample(100.0).stance_positions
    # straight north: the right foot's rests lie midway between the left foot's, step width to the right
    assert np.allclose(right[1:-1, 0], 0.5 * (left[:-1, 0] + left[1:, 0]))
    assert np.allclose(right[:, 1] - left[0, 1], STEP_WIDTH_M)
    lead = np.diff(np.sort(np.concatenate([left[:, 0], right[:, 0]])))
    assert lead.max() == pytest.approx(0.5 * WALKING.stride_length, rel=0.02)


def test_each_foot_walks_the_body_path():
    body = trajectory("rectangle").sample(100.0)
    walked = feet("rectangle")
    for side in SIDES:
        foot = walked.foot(side).sample(100.0)
        assert foot.distance_m() == pytest.approx(body.distance_m(), rel=0.02)
        assert foot.heading_change() == pytest.approx(body.heading_change(), abs=1e-9)


def test_stairs_each_foot_climbs_two_stairs_a_stride_in_turn():
    walked = feet("stand:3+stairs_up:8+stand:2")
    heights = sorted(-np.concatenate([walked.left.sample(100.0).stance_positions[:, 2],
                                      walked.right.sample(100.0).stance_positions[:, 2]]))
    assert np.allclose(np.unique(np.round(heights, 6)), 0.17 * np.arange(9))


def test_on_stairs_the_left_foot_rolls_and_turns_as_the_mirror_of_the_right():
    """A stair swing turns the sole in and the toe out: right side down and toe right for the right
    foot, left side down and toe left for the left."""
    walked = feet("stand:3+stairs_up:8+stand:2")
    left, right = walked.left.sample(1000.0), walked.right.sample(1000.0)
    for truth, sign in ((left, -1.0), (right, 1.0)):
        roll, _, yaw = np.degrees(truth.euler).T
        assert np.all(sign * roll > -1e-6) and np.all(sign * yaw > -1e-6)
        assert np.abs(roll).max() == pytest.approx(STAIRS_UP.swing_roll_deg, rel=1e-3)
        assert np.abs(yaw).max() == pytest.approx(STAIRS_UP.swing_yaw_deg, rel=1e-3)


def test_body_is_the_feet_midpoint():
    walked = feet("walk")
    t = np.linspace(0.0, walked.duration, 50)
    pos, yaw = walked.body(t)
    assert np.allclose(pos, 0.5 * (walked.left.evaluate(t).pos + walked.right.evaluate(t).pos))
    assert np.allclose(pos[0], 0.0) and np.allclose(yaw, 0.0)


def test_each_foot_has_its_own_module_and_seed():
    assert {foot_seed(s, side) for s in range(5) for side in SIDES} == set(range(10))
    assert foot_module(3, "left") != foot_module(3, "right")
    with pytest.raises(ValueError):
        foot_seed(1, "middle")
    with pytest.raises(ValueError):
        feet("walk").foot("middle")


def test_feet_sources_draw_independent_errors():
    from firmware_sim.sensors.imu_array import make_feet_sources

    sources = make_feet_sources("stand:2+walk:3+stand:2", seed=4, walker=7)
    left, right = sources["left"], sources["right"]
    assert (left.module, right.module) == (14, 15) and (left.seed, right.seed) == (8, 9)
    assert "left foot" in left.name and "right foot" in right.name
    assert not np.array_equal(left.imu[:100], right.imu[:100])  # standing alike, read differently


def test_both_feet_of_a_walker_walk_through_one_building():
    """The building's deviation is the walker's, so the two feet see the same field at the same
    place (their shoes' iron and their noise stay their own); another walker is in another."""
    from firmware_sim.sensors.imu_array import make_feet_sources

    points = np.random.default_rng(0).uniform(-20, 20, (50, 3))
    sources = make_feet_sources("stand:2", seed=4, walker=7)
    left, right = sources["left"].magnetic, sources["right"].magnetic
    np.testing.assert_array_equal(left.deviation_ned(points), right.deviation_ned(points))
    assert np.abs(left.deviation_ned(points)).max() > 1.0  # a building, not open ground
    assert not np.array_equal(left.hard_iron, right.hard_iron)
    other = make_feet_sources("stand:2", seed=5, walker=7)["left"].magnetic
    assert not np.allclose(other.deviation_ned(points), left.deviation_ned(points))
