"""The foot on sloped ground: flat on the road during stance, and signals consistent with it.

The foot-angle height method (aids.md §5) reads the ground's slope from the foot's attitude
while it rests, so the simulated foot must lie flat on the plane it walks on: pitch (and, on a
ramp walked at an angle to its fall line, roll) of the plane, and heights on the plane.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from firmware_sim.sensors.gait import flat_on, ramp_normal
from firmware_sim.sensors.gait_builder import GaitBuilder
from firmware_sim.sensors.scenarios import SCENARIOS, trajectory
from firmware_sim.sensors.truth import euler_to_matrix, strapdown_rk4

G = 9.81
ROADS = {"ramp_0": 0.0, "ramp_2.5": 2.5, "ramp_6": 6.1, "ramp_7.5": 7.5}
DIAGONAL_DEG, DIAGONAL_ACROSS_DEG = 7.8, 45.0


def sole_normals(poses: np.ndarray) -> np.ndarray:
    """(m, 3) the z axis of the foot (NED) at each stance pose (x y z roll pitch yaw)."""
    return euler_to_matrix(poses[:, 3], poses[:, 4], poses[:, 5])[:, :, 2]


@pytest.fixture(scope="module", params=sorted(ROADS))
def road(request):
    return request.param, ROADS[request.param], trajectory(request.param).sample(100.0)


@pytest.fixture(scope="module")
def diagonal():
    return trajectory("ramp_diagonal").sample(100.0)


def test_walking_up_a_slope_the_foot_lands_nose_up_and_coming_down_nose_down():
    poses = trajectory("walk:20:6+turn:180+walk:20:-6").sample(100.0).stance_poses
    up = (np.abs(poses[:, 5]) < 1e-12) & (np.arange(len(poses)) > 0)
    down = np.abs(poses[:, 5] - math.pi) < 1e-12
    assert up.sum() == 13 and down.sum() == 14  # 13 strides up, the last turn stride and 13 down
    assert np.allclose(poses[up, 4], math.radians(6.0), atol=1e-12)
    assert np.allclose(poses[down, 4], -math.radians(6.0), atol=1e-12)
    assert np.allclose(poses[up | down, 3], 0.0, atol=1e-12)  # no roll along the fall line
    # from stance to stance the foot rises tan(slope) × the horizontal distance
    d = np.diff(poses[:, :3], axis=0)  # uphill is north: the run is the step's x, signed
    assert np.allclose(-d[:, 2], math.tan(math.radians(6.0)) * d[:, 0], atol=1e-12)
    assert np.allclose(d[:, 1], 0.0, atol=1e-12)
    assert poses[-1, 2] == pytest.approx(0.0, abs=1e-12)


def test_a_half_turn_on_a_slope_keeps_the_sole_on_the_plane():
    poses = GaitBuilder().stand(1).walk(6, slope_deg=7.5).turn_on_spot(180).build().stances
    turning = np.array([p.as_array() for _, _, p in poses[-5:]])
    assert np.allclose(sole_normals(turning), ramp_normal(7.5, 0.0), atol=1e-12)
    assert np.allclose(np.degrees(turning[:, 4]), [7.5, 5.3185, 0.0, -5.3185, -7.5], atol=1e-4)
    assert np.degrees(turning[2, 3]) == pytest.approx(7.5)  # side-on to the slope: right side down
    assert np.allclose(turning[:, :3], turning[0, :3], atol=0.0)  # on the spot


def test_on_each_road_the_foot_rests_flat_on_the_plane_and_climbs_its_height(road):
    name, deg, gt = road
    poses = gt.stance_poses
    slope = math.radians(deg)
    normal = ramp_normal(deg, 0.0)
    on_road = np.arange(1, len(poses))  # the first stance is on the level ground before the road
    assert np.allclose(sole_normals(poses[on_road]), normal, atol=1e-9)
    assert np.allclose(poses[:, :3] @ normal, 0.0, atol=1e-9)  # every rest on the plane through the start
    heading_up = np.abs(poses[on_road, 5]) < 1e-12
    heading_down = np.abs(poses[on_road, 5] - math.pi) < 1e-12
    assert np.allclose(poses[on_road][heading_up, 4], slope, atol=1e-9)
    assert np.allclose(poses[on_road][heading_down, 4], -slope, atol=1e-9)
    assert np.allclose(poses[on_road][heading_up | heading_down, 3], 0.0, atol=1e-9)
    top = poses[np.argmin(poses[:, 2])]
    assert -top[2] == pytest.approx(50.0 * math.sin(slope), abs=1e-9)  # 50 m along the road
    assert -top[2] == pytest.approx(math.tan(slope) * top[0], abs=1e-9)  # tan(slope) × horizontal
    assert np.allclose(poses[-1, :3], 0.0, atol=1e-9)  # back where the road began
    assert gt.stance_end[0] - gt.stance_start[0] >= 3.0 and gt.stance_end[-1] - gt.stance_start[-1] >= 2.0


def test_on_level_ground_the_resting_foot_is_exactly_level():
    gt = trajectory("ramp_0").sample(100.0)
    assert np.all(gt.stance_poses[:, 2:5] == 0.0)
    assert np.all(gt.f_b[gt.stance] == [0.0, 0.0, -G])


def test_while_the_foot_rests_it_feels_gravity_in_its_own_frame_and_no_rotation(road):
    _, deg, gt = road
    still = gt.stance
    f_expected = np.einsum("nji,j->ni", gt.R[still], [0.0, 0.0, -G])
    assert np.allclose(gt.f_b[still], f_expected, atol=1e-12)
    assert np.allclose(gt.omega_b[still], 0.0, atol=1e-12)
    assert np.allclose(gt.vel[still], 0.0, atol=1e-12)
    # the foot's tilt from the vertical is the road's slope
    tilt = np.degrees(np.arccos(np.clip(-gt.f_b[still, 2] / G, -1.0, 1.0)))
    assert tilt.max() == pytest.approx(deg, abs=1e-6)


def test_across_a_ramp_the_foot_takes_the_pitch_and_roll_of_the_plane(diagonal):
    poses = diagonal.stance_poses
    a, b = math.radians(DIAGONAL_DEG), math.radians(DIAGONAL_ACROSS_DEG)
    pitch = math.atan(math.tan(a) * math.cos(b))
    roll = math.atan(math.tan(a) * math.sin(b) * math.cos(pitch))
    assert math.degrees(pitch) == pytest.approx(5.5325, abs=1e-4)
    assert math.degrees(roll) == pytest.approx(5.5069, abs=1e-4)
    normal = ramp_normal(DIAGONAL_DEG, -b)  # uphill 45° to the left of north
    assert np.allclose(sole_normals(poses[1:]), normal, atol=1e-9)
    up = (np.abs(poses[:, 5]) < 1e-12) & (np.arange(len(poses)) > 0)
    down = np.abs(poses[:, 5] - math.pi) < 1e-12
    assert np.allclose(poses[up, 3:5], [roll, pitch], atol=1e-9)  # right side down, nose up
    assert np.allclose(poses[down, 3:5], [-roll, -pitch], atol=1e-9)  # coming back: mirrored
    assert np.allclose(poses[:, 1], 0.0, atol=1e-9)  # straight along the walking line
    top = poses[np.argmin(poses[:, 2])]
    assert -top[2] == pytest.approx(math.tan(a) * math.cos(b) * top[0], abs=1e-9)
    assert -top[2] == pytest.approx(50.0 * math.sin(pitch), abs=1e-9)
    assert np.allclose(poses[-1, :3], 0.0, atol=1e-9)


def test_across_a_ramp_gravity_in_the_resting_foot_is_the_plane_normal_seen_from_the_foot(diagonal):
    gt = diagonal
    rest = gt.stance & (gt.t > gt.stance_end[0])
    normal_b = np.einsum("nji,j->ni", gt.R[rest], ramp_normal(DIAGONAL_DEG, -math.radians(45.0)))
    assert np.allclose(normal_b, [0.0, 0.0, 1.0], atol=1e-9)  # the sole lies on the plane
    gravity_b = -gt.f_b[rest] / G  # down, in the foot's frame
    vertical_b = np.einsum("nji,j->ni", gt.R[rest], [0.0, 0.0, 1.0])
    assert np.allclose(gravity_b, vertical_b, atol=1e-12)
    tilt = np.degrees(np.arccos(gravity_b[:, 2]))
    assert np.allclose(tilt, DIAGONAL_DEG, atol=1e-9)
    assert np.allclose(gt.omega_b[rest], 0.0, atol=1e-12)


def test_the_ramp_piece_follows_the_fall_line_the_contour_and_walk():
    straight = trajectory("ramp:12:6:0").stances
    walked = trajectory("walk:12:6").stances
    assert np.allclose([p.as_array() for *_, p in straight], [p.as_array() for *_, p in walked], atol=1e-12)
    contour = trajectory("ramp:12:6:90").sample(100.0).stance_poses
    assert np.allclose(contour[1:, 2:5], [0.0, math.radians(6.0), 0.0], atol=1e-12)  # level, rolled right
    left = trajectory("ramp:12:6:-90").sample(100.0).stance_poses
    assert np.allclose(left[1:, 3], -math.radians(6.0), atol=1e-12)
    assert flat_on(np.array([0.0, 0.0, 1.0]), 1.234) == (0.0, 0.0)
    assert math.copysign(1.0, flat_on(np.array([-0.0, -0.0, 1.0]), 0.5)[1]) == 1.0  # never −0


def test_the_road_names_are_scenarios_and_keep_their_dot():
    for name in (*ROADS, "ramp_diagonal"):
        assert name in SCENARIOS
        assert trajectory(name).duration > 60.0
    from firmware_sim.app.runs import scenario_runs

    assert scenario_runs(["ramp_2.5"], [0])[0].name == "ramp_2.5_seed0"


def test_strapdown_of_the_signals_retraces_a_diagonal_ramp_and_a_turn_on_it():
    gt = trajectory("stand:1+ramp:9:7.8:45+turn:180+ramp:9:7.8:-135+stand:1").sample(1000.0)
    p, v, _ = strapdown_rk4(gt.f_b, gt.omega_b, 1e-3, gt.pos[0], gt.vel[0], gt.quat[0], gravity=G)
    err = np.linalg.norm(p - gt.pos[: 2 * len(p) : 2], axis=1)
    assert err.max() < 0.005, f"strapdown drifts {err.max() * 100:.2f} cm from the truth"
    pitch = math.atan(math.tan(math.radians(7.8)) * math.cos(math.radians(45.0)))
    assert gt.stance_poses[:, 2].min() == pytest.approx(-9.0 * math.sin(pitch), abs=1e-9)
    assert np.abs(v[-1]).max() < 1e-3


def test_analytic_derivatives_match_finite_differences_on_a_ramp():
    gt = trajectory("stand:1+ramp:4:7.8:45+turn:-90+ramp:3:6:30+stand:1").sample(4000.0)
    dt = 1.0 / 4000.0
    inner = slice(2, -2)
    assert np.abs(np.gradient(gt.pos, dt, axis=0) - gt.vel)[inner].max() < 1e-3 * np.abs(gt.vel).max()
    assert np.abs(np.gradient(gt.vel, dt, axis=0) - gt.acc)[inner].max() < 1e-2 * np.abs(gt.acc).max()
    W = np.einsum("nji,njk->nik", gt.R, np.gradient(gt.R, dt, axis=0))  # Rᵀ Ṙ = [ω×]
    omega = np.stack([W[:, 2, 1], W[:, 0, 2], W[:, 1, 0]], axis=1)
    assert np.abs(omega - gt.omega_b)[inner].max() < 1e-3 * np.abs(gt.omega_b).max()


def _ideal_replay_heights(name: str) -> tuple[np.ndarray, np.ndarray]:
    """(track, truth) heights [m, up] after every step of the ideal module walking *name*."""
    from firmware_sim.app.batch import run_replay
    from firmware_sim.mcu.module import ModuleConfig
    from firmware_sim.sensors.config import IDEAL_CONFIG
    from firmware_sim.sensors.imu_array import make_source
    from hostlib.files.replay import replay_bytes
    from hostlib.track.steps import is_motion_step

    source = make_source(name, seed=0, rate_hz=1000.0, config=IDEAL_CONFIG)
    track, _ = replay_bytes(run_replay(source, config=ModuleConfig(rate_hz=1000.0), announce=None))
    moved = np.array([is_motion_step(dx) for dx in track.steps])
    truth = source.truth.stances_in_start_frame()[1:, 2]
    assert moved.sum() == len(truth)
    return -track.positions[1:][moved, 2], -truth


def test_the_ideal_module_climbs_and_descends_a_6_degree_road_with_the_foot():
    up6, truth6 = _ideal_replay_heights("ramp_6")
    assert truth6.max() == pytest.approx(50.0 * math.sin(math.radians(6.1)))
    top = int(np.argmax(truth6))
    assert abs(up6[top] - truth6[top]) < 0.05  # measured 3.0 cm low at 5.31 m
    assert abs(up6[-1] - truth6[-1]) < 0.10  # measured 7.8 cm low after 100 m
    # the module's own height drift on level ground (≈ 0.7 mm a step, ideal sensors) cancels:
    # the slope itself adds under a centimetre anywhere on the road
    up0, truth0 = _ideal_replay_heights("ramp_0")
    slope_error = (up6 - truth6) - (up0 - truth0)
    assert np.abs(slope_error).max() < 0.01  # measured 0.65 cm at the top
