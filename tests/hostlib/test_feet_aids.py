"""Two feet with the other aids: each foot's per-step compass holds both headings, the first
reading turns both feet onto north, a GPS fix places the body, and each module's drift
calibration moves only its own foot's steps."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hostlib.aids.compass import StanceReading
from hostlib.calibration.drift import DriftCalibration
from hostlib.calibration.magcal import MagCalibration
from hostlib.fusion.constraint import project_separation
from hostlib.fusion.feet import FOOT_SIDES, FeetSettings, TwoFeetTracker
from hostlib.fusion.tracker import FusionSettings
from hostlib.track.steps import rotation_z

DP = np.diag([1e-4, 1e-4, 1e-4, 1e-5])
FIELD_NED = 51.5 * np.array([math.cos(math.radians(72.5)), 0.0, math.sin(math.radians(72.5))])
STRIDE = 1.4
SWING = 0.4  # s
STEP_PERIOD = 0.55  # s between the two feet's steps


def _reading(true_heading: float, deviation: float = 0.0) -> StanceReading:
    """A level board facing *true_heading* in a field whose magnetic north is *deviation* east of
    true north; the module's quaternion has yaw 0 (just reset)."""
    return StanceReading(rotation_z(true_heading).T @ rotation_z(deviation) @ FIELD_NED, np.eye(3), 3)


def _walk(tracker: TwoFeetTracker, strides: int, *, heading: float = 0.0, turn: dict | None = None,
          moved: dict | None = None, deviation_sigma: float = 0.0, swing: float = SWING,
          seed: int = 0) -> None:
    """The walker goes straight at *heading* [rad] (true); each module reports its steps in its own
    frame (starting at 0), forward, with a heading error *turn[side]* per step, and *moved[side]*
    [m] in its start frame added to each step (a drifting module); the right foot leads with half
    a stride."""
    rng = np.random.default_rng(seed)
    turn, moved = turn or {}, moved or {}
    chi = {side: 0.0 for side in FOOT_SIDES}
    counter = {side: 0 for side in FOOT_SIDES}
    order = [("right", 0.5)] + [(side, 1.0) for _ in range(strides) for side in FOOT_SIDES]
    for n, (side, length) in enumerate(order):
        dx = np.zeros(4)
        dx[:3] = [STRIDE * length, 0.0, 0.0]
        dx[:3] += rotation_z(-chi[side]) @ np.asarray(moved.get(side, np.zeros(3)))
        dx[3] = turn.get(side, 0.0)
        chi[side] += dx[3]
        counter[side] += 1
        tracker.foot(side).add_step(dx, DP, counter[side], swing,
                                    reading=_reading(heading, rng.normal(0.0, deviation_sigma)),
                                    time_s=STEP_PERIOD * (n + 1))
    if tracker._deferred:
        tracker.fuse_in_time_order()


def _heading_error(chi: float, truth: float) -> float:
    return abs(math.degrees(math.remainder(chi - truth, 2 * math.pi)))


def test_each_foots_compass_holds_both_headings_its_module_lets_drift():
    truth = 0.4
    drift = {"left": math.radians(0.05), "right": math.radians(-0.05)}  # 15° each over the walk
    aided = TwoFeetTracker(aids=FusionSettings(compass=True, compass_sigma_rad=math.radians(10.0)))
    plain = TwoFeetTracker()
    for tracker in (aided, plain):
        _walk(tracker, 150, heading=truth, turn=drift, deviation_sigma=math.radians(10.0))
    for i in (0, 1):
        assert _heading_error(aided.state[4 * i + 3], truth) < 3.0
        assert _heading_error(plain.state[4 * i + 3], truth) > 15.0  # the modules' own frame, not north
    assert aided.fusion.heading_aligned_by == "compass"
    # every step moved; the first one aligned; the gate rejects the few readings beyond 3σ
    assert aided.fusion.compass_updates + aided.fusion.compass_rejected == len(aided) - 1
    assert aided.fusion.compass_rejected <= 0.02 * len(aided)
    # each foot's own tracker (the baseline) took its own readings
    assert all(aided.foot(side).fusion.compass_updates > 100 for side in FOOT_SIDES)
    end = aided.body.final_pose[:2]
    assert np.hypot(*(end - rotation_z(truth)[:2, :2] @ [150 * STRIDE + 0.25 * STRIDE, 0.0])) < 5.0


def test_the_first_reading_turns_both_feet_about_the_body_start():
    tracker = TwoFeetTracker(aids=FusionSettings(compass=True, compass_sigma_rad=math.radians(10.0)))
    _walk(tracker, 0, heading=1.0)  # the right foot's half step alone
    x, p = tracker.state, tracker.covariance
    assert x[3] == pytest.approx(1.0) and x[7] == pytest.approx(1.0)
    # the right foot's half stride now points at 1 rad; the left foot still rests at its start,
    # 6 cm to the left of the origin, turned with the frame
    assert x[4:6] == pytest.approx(rotation_z(1.0)[:2, :2] @ [0.5 * STRIDE, 0.06])
    assert x[0:2] == pytest.approx(rotation_z(1.0)[:2, :2] @ [0.0, -0.06])
    # the right foot's heading is the reading's; the left foot's follows it, plus what the two
    # headings were apart (the right foot's one step of heading noise)
    assert p[7, 7] == pytest.approx(math.radians(10.0) ** 2)
    assert p[3, 3] == pytest.approx(math.radians(10.0) ** 2 + DP[3, 3])
    assert p[3, 7] == pytest.approx(math.radians(10.0) ** 2)
    assert np.all(np.linalg.eigvalsh(p) > -1e-12)


def test_gps_fixes_of_the_body_turn_the_walk_onto_its_course_and_hold_it():
    truth = 1.0
    tracker = TwoFeetTracker(aids=FusionSettings(gps=True))
    rng = np.random.default_rng(4)
    times = np.arange(0.0, 200.0, 1.0)
    body_speed = STRIDE / (2 * STEP_PERIOD)
    course = rotation_z(truth)[:2, :2] @ [1.0, 0.0]
    fixes = np.outer(np.clip(times * body_speed, 0, None), course) + rng.normal(0.0, 1.0, (times.size, 2))
    tracker.add_fixes(times, fixes)
    _walk(tracker, 150, heading=truth, turn={"left": math.radians(0.05), "right": math.radians(0.05)})
    assert tracker.fusion.heading_aligned_by == "gps" and tracker.fusion.gps_updates >= 10
    assert _heading_error(tracker.body.final_pose[3], truth) < 5.0
    assert all(tracker.foot(side).fusion.gps_updates >= 10 for side in FOOT_SIDES)  # each foot's own


class _AskedAfterEveryStep(TwoFeetTracker):
    """A tracker whose body a live page asks for after every fused step."""

    def take(self, step) -> None:
        super().take(step)
        self.body_poses()


def test_a_body_asked_after_every_step_is_turned_with_the_walk_when_gps_aligns_it():
    times = np.arange(0.0, 60.0, 1.0)
    fixes = np.outer(times * STRIDE / (2 * STEP_PERIOD), [0.0, 1.0])  # due east
    bodies = []
    for kind in (_AskedAfterEveryStep, TwoFeetTracker):
        tracker = kind(aids=FusionSettings(gps=True))
        tracker.add_fixes(times, fixes)
        _walk(tracker, 40)
        assert tracker.fusion.heading_aligned_by == "gps"
        bodies.append(tracker.body)
    np.testing.assert_allclose(bodies[0].poses, bodies[1].poses, rtol=0, atol=1e-9)
    np.testing.assert_allclose(bodies[0].covariances, bodies[1].covariances, rtol=0, atol=1e-12)
    assert abs(bodies[0].final_pose[1]) > 10.0  # walked east, in the turned frame


def test_gps_and_the_compass_together_learn_the_declination():
    tracker = TwoFeetTracker(aids=FusionSettings(compass=True, gps=True, declination_rad=math.radians(8.0),
                                                 compass_sigma_rad=math.radians(5.0)))
    times = np.arange(0.0, 200.0, 1.0)
    tracker.add_fixes(times, np.outer(times * STRIDE / (2 * STEP_PERIOD), [1.0, 0.0]))
    _walk(tracker, 150, heading=0.0, deviation_sigma=0.0)  # magnetic north is true north: D = 0
    assert abs(math.degrees(tracker.declination)) < 3.0
    assert tracker.declination_sigma < math.radians(8.0)


@pytest.mark.parametrize("defer", [False, True])
def test_each_modules_drift_calibration_moves_only_its_own_foots_steps(defer):
    biases = {"left": np.array([0.0, 0.02, 0.0]), "right": np.array([0.0, -0.03, 0.01])}  # m per step
    calibrations = {side: DriftCalibration(tuple(-biases[side] / SWING), 100.0, 100, 1)
                    for side in FOOT_SIDES}
    free = FeetSettings(constraint=False)
    corrected = TwoFeetTracker(free, drift=calibrations, defer=defer)
    drifting = TwoFeetTracker(free, defer=defer)
    clean = TwoFeetTracker(free, defer=defer)
    _walk(corrected, 100, moved=biases)
    _walk(drifting, 100, moved=biases)
    _walk(clean, 100)
    for side in FOOT_SIDES:
        assert corrected.fused_foot(side)[-1] == pytest.approx(clean.fused_foot(side)[-1], abs=1e-9)
        assert np.linalg.norm(drifting.fused_foot(side)[-1] - clean.fused_foot(side)[-1]) > 1.0
    # the baseline: each single-module track corrected with its own module's calibration
    assert corrected.average.final_pose == pytest.approx(clean.average.final_pose, abs=1e-9)
    assert corrected.drift_uncorrected == 0


def test_a_step_without_a_swing_time_is_fused_uncorrected_and_counted():
    tracker = TwoFeetTracker(drift={"left": DriftCalibration((0.0, 0.1, 0.0), 10.0, 10, 1)})
    _walk(tracker, 3, swing=math.nan)
    assert tracker.drift_uncorrected == 3  # the left foot's three steps; the right has no calibration
    assert tracker.fused_foot("left")[-1][1] == pytest.approx(-0.06)


def test_calibrations_name_a_foot_and_belong_to_one_module():
    cal = MagCalibration(np.zeros(3), np.eye(3))
    with pytest.raises(ValueError, match="belongs to one module"):
        TwoFeetTracker(aids=FusionSettings(compass=True, mag_calibration=cal))
    with pytest.raises(ValueError, match="a foot is left or right"):
        TwoFeetTracker(mag_calibrations={"middle": cal})
    tracker = TwoFeetTracker(aids=FusionSettings(compass=True), mag_calibrations={"right": cal})
    assert tracker.right.settings.mag_calibration is cal and tracker.left.settings.mag_calibration is None


def test_a_projection_onto_the_bound_moves_the_estimate_and_keeps_the_covariance():
    tracker = TwoFeetTracker(aids=FusionSettings(compass=True, compass_sigma_rad=math.radians(10.0)))
    _walk(tracker, 3, heading=0.3)
    before, p = tracker.filter.x.copy(), tracker.filter.P.copy()
    right = tracker.filter.index("right")
    tracker.filter.x[right:right + 2] += [2.0, 0.5]  # the right foot's estimate now 2 m ahead of the left
    assert project_separation(tracker.filter, "left", "right", tracker.settings.max_separation_m)
    apart = tracker.filter.mean("left")[:3] - tracker.filter.mean("right")[:3]
    assert np.linalg.norm(apart) == pytest.approx(1.0)
    assert np.array_equal(tracker.filter.P, p)
    assert not np.array_equal(tracker.filter.x, before)
