"""The wiggle of the in-situ magnetometer calibration: turns of the foot in place through many
orientations, held still between turns, ending where it began; the module sees every hold as a
stance and reports steps of a few centimetres, never one long enough to end the calibration."""

from __future__ import annotations

import math

import numpy as np
import pytest

from firmware_sim.app.batch import run_replay
from firmware_sim.mcu.module import ModuleConfig
from firmware_sim.sensors.gait import WIGGLE, WIGGLE_LEVER_M, Pose
from firmware_sim.sensors.gait_builder import GaitBuilder
from firmware_sim.sensors.imu_array import make_source
from firmware_sim.sensors.scenarios import environment, feet, trajectory
from firmware_sim.sensors.truth import strapdown_rk4
from hostlib.calibration.wiggle import STOP_STEP_M
from hostlib.files.replay import replay_session

CALIBRATION = "navshoe-calibration"


@pytest.fixture(scope="module")
def wiggle_truth():
    """A 30 s wiggle from a foot standing facing 30°, and its truth at 1 kHz."""
    builder = GaitBuilder(start=Pose(yaw=math.radians(30.0))).stand(2.0).wiggle(30.0).stand(2.0)
    return builder, builder.build().sample(1000.0)


def test_the_wiggle_turns_through_many_orientations_and_ends_flat_where_it_began(wiggle_truth):
    builder, gt = wiggle_truth
    assert builder.t == pytest.approx(34.0, abs=0.6), "about the seconds asked for, between two stands"
    end = gt.euler[-1]
    assert np.allclose(gt.pos[-1], gt.pos[0], atol=1e-12)
    assert end[0] == pytest.approx(0.0, abs=1e-12) and end[1] == pytest.approx(0.0, abs=1e-12)
    assert math.cos(end[2] - math.radians(30.0)) == pytest.approx(1.0)
    roll, pitch, yaw = np.degrees(gt.euler.T)
    turned = yaw - 30.0
    assert turned.min() < -170 and turned.max() > 170, "the heading goes all round"
    assert pitch.min() < -80 and pitch.max() > 80 and roll.min() < -80 and roll.max() > 80
    # the module turns about the ankle: it never strays farther from its start than the lever's reach
    reach = 2 * np.linalg.norm(WIGGLE_LEVER_M)
    assert np.linalg.norm(gt.pos - gt.pos[0], axis=1).max() <= reach + 1e-9


def test_every_turn_is_held_still_long_enough_for_a_stance(wiggle_truth):
    builder, gt = wiggle_truth
    holds = gt.stance_end - gt.stance_start
    assert len(holds) >= 25 and np.all(holds[1:-1] >= WIGGLE.stance_s - 1e-9)
    omega = np.degrees(np.linalg.norm(gt.omega_b, axis=1))
    assert omega.max() < 400, "well inside the gyro's ±2000 °/s"
    assert np.abs(gt.f_b).max() < 3 * 9.81, "no impacts: the foot turns, it does not land"


def test_the_wiggle_signals_integrate_back_to_its_motion(wiggle_truth):
    _, gt = wiggle_truth
    p, v, q = strapdown_rk4(gt.f_b, gt.omega_b, 1e-3, gt.pos[0], gt.vel[0], gt.quat[0], gravity=9.81)
    ref = gt.pos[: 2 * len(p) : 2]
    assert np.linalg.norm(p - ref, axis=1).max() < 0.005


def test_a_recipe_wiggles_with_the_tilt_it_asks_for():
    gt = trajectory("stand:1+wiggle:12:40+stand:1").sample(100.0)
    tilt = np.degrees(np.abs(gt.euler[:, :2])).max()
    assert 35.0 < tilt <= 40.0 + 1e-9
    assert environment(CALIBRATION).outdoors


def test_a_wiggle_is_one_foot_and_refused_as_a_walkers_step():
    with pytest.raises(ValueError, match="one foot's magnetometer calibration"):
        feet(CALIBRATION)


@pytest.mark.parametrize("seed", range(4))
def test_on_the_default_sensors_no_step_of_the_wiggle_ends_the_calibration(seed):
    source = make_source(CALIBRATION, seed=seed)
    data = run_replay(source, config=ModuleConfig(rate_hz=1000.0), announce=None, host="fusion")
    poses = replay_session(bytes(data)).tracker.track.poses
    lengths = np.hypot(*np.diff(poses[:, :2], axis=0).T)
    first_long = int(np.argmax(lengths > STOP_STEP_M))
    strides = np.hypot(*np.diff(source.truth.stance_positions[:, :2], axis=0).T)
    first_stride = strides[np.argmax(strides > STOP_STEP_M)]
    wiggle_steps = lengths[:first_long]
    assert len(wiggle_steps) >= 25, "a reset at every hold"
    assert wiggle_steps.max() < 0.25, f"a wiggle step of {wiggle_steps.max():.2f} m"
    assert lengths[first_long] == pytest.approx(first_stride, abs=0.05), "the first stride ends it"
