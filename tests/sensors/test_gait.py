"""Foot trajectories: exact, smooth, walking-like, and consistent with their own signals."""

from __future__ import annotations

import math

import numpy as np
import pytest

from firmware_sim.sensors.gait import (
    RUNNING,
    SHORT_STEPS,
    SHUFFLE,
    STAIRS_DOWN,
    STAIRS_UP,
    WALKING,
    WIGGLE,
    GaitParams,
)
from firmware_sim.sensors.gait_builder import GaitBuilder
from firmware_sim.sensors.scenarios import SCENARIOS, list_scenarios, trajectory
from firmware_sim.sensors.stance_sway import STANCE_SWAY
from firmware_sim.sensors.truth import strapdown_rk4

G = 9.81
#: How slowly a real foot may rotate in mid-swing [°/s]: over the 296 swings of the shared walks the
#: smallest |ω| in the middle 80 % of a swing is 2.9 °/s at the slowest, below this in 5 % of swings,
#: 25 °/s in the median one (tests/oracle/swing_rotation.py).
REAL_SWING_MIN_RATE_P5_DPS = 8.9
#: The slowest of those 296 real swings' smallest mid-swing |ω| [°/s].
REAL_SWING_MIN_RATE_FLOOR_DPS = 2.9


@pytest.fixture(scope="module")
def walk100():
    return trajectory("walk").sample(1000.0)


def test_strapdown_of_the_signals_retraces_100_m_of_walking_within_1_cm(walk100):
    gt = walk100
    assert gt.distance_m() == pytest.approx(100.0)
    p, v, q = strapdown_rk4(gt.f_b, gt.omega_b, 1e-3, gt.pos[0], gt.vel[0], gt.quat[0], gravity=G)
    ref = gt.pos[: 2 * len(p) : 2]
    err = np.linalg.norm(p - ref, axis=1)
    assert err.max() < 0.01, f"strapdown drifts {err.max() * 100:.2f} cm from the truth"
    assert np.linalg.norm(p[-1] - gt.pos[-1]) < 0.01
    assert np.abs(v[-1]).max() < 1e-3


def test_at_rest_the_accelerometer_feels_minus_g_on_z_and_the_gyro_nothing(walk100):
    gt = walk100
    still = gt.stance
    assert np.allclose(gt.f_b[still], [0.0, 0.0, -G], atol=1e-12)
    assert np.allclose(gt.omega_b[still], 0.0, atol=1e-12)
    assert np.allclose(gt.vel[still], 0.0, atol=1e-12)


def test_analytic_derivatives_match_finite_differences():
    gt = trajectory("stand:1+walk:3+arc:2:90+stairs_up:4+run:5+stand:1").sample(4000.0)
    dt = 1.0 / 4000.0
    inner = slice(2, -2)
    vel = np.gradient(gt.pos, dt, axis=0)
    acc = np.gradient(gt.vel, dt, axis=0)
    assert np.abs(vel - gt.vel)[inner].max() < 1e-3 * np.abs(gt.vel).max()
    assert np.abs(acc - gt.acc)[inner].max() < 1e-2 * np.abs(gt.acc).max()
    dR = np.gradient(gt.R, dt, axis=0)
    W = np.einsum("nji,njk->nik", gt.R, dR)  # Rᵀ Ṙ = [ω×]
    omega = np.stack([W[:, 2, 1], W[:, 0, 2], W[:, 1, 0]], axis=1)
    assert np.abs(omega - gt.omega_b)[inner].max() < 1e-3 * np.abs(gt.omega_b).max()
    alpha = np.gradient(gt.omega_b, dt, axis=0)
    assert np.abs(alpha - gt.alpha_b)[inner].max() < 1e-2 * np.abs(gt.alpha_b).max()


def test_motion_is_smooth_across_stance_and_swing_joints():
    tr = trajectory("walk")
    joints = tr._t0[1:]
    before, after = tr.evaluate(joints - 1e-7), tr.evaluate(joints + 1e-7)
    for name in ("pos", "vel", "acc", "omega_b", "alpha_b", "f_b"):
        jump = np.abs(getattr(after, name) - getattr(before, name)).max()
        assert jump < 1e-3, f"{name} jumps by {jump} at a joint"


def test_a_walking_stride_has_foot_flat_stance_and_a_swing_of_the_spec():
    gt = trajectory("walk").sample(1000.0)
    stance_s = gt.stance_end - gt.stance_start
    assert np.all((stance_s[1:-1] >= 0.4) & (stance_s[1:-1] <= 0.6))
    strides = np.linalg.norm(np.diff(gt.stance_positions, axis=0), axis=1)
    assert np.all((strides >= 1.0) & (strides <= 1.6))
    swing_s = gt.stance_start[1:] - gt.stance_end[:-1]
    assert np.allclose(swing_s, WALKING.swing_s) and 0.35 <= WALKING.swing_s <= 0.5
    pitch = np.degrees(gt.euler[:, 1])
    assert pitch.min() < -20 and pitch.max() > 10  # toe-off and heel strike
    assert 2.0 < np.abs(gt.f_b).max() / 9.80665 < 16.0  # several g, no clipping while walking
    assert 1.3 < WALKING.speed < 1.8 and 100 < WALKING.cadence_steps_per_min < 130


def test_running_has_short_stance_and_heel_strikes_beyond_16_g():
    gt = trajectory("run").sample(1000.0)
    assert RUNNING.stance_s < 0.3
    assert np.abs(gt.f_b[:, 2]).max() / 9.80665 > 16.0


@pytest.mark.parametrize("name", ["default", "rectangle", "track400", "turn_on_spot", "side_steps"])
def test_closed_routes_end_where_they_started(name):
    tr = trajectory(name)
    end = tr.evaluate(np.array([tr.duration]))
    assert np.linalg.norm(end.pos[0]) < 1e-6


def test_the_default_scenario_aligns_then_walks_a_loop_with_stairs_and_turns():
    gt = trajectory("default").sample(100.0)
    first_stance = gt.stance_end[0] - gt.stance_start[0]
    assert first_stance >= 3.0
    assert gt.stance_end[-1] - gt.stance_start[-1] >= 3.0
    assert 200.0 < gt.distance_m() < 400.0
    assert gt.pos[:, 2].min() < -2.0  # up a staircase (z down)
    assert abs(gt.euler[-1, 2]) >= 2 * math.pi  # turned round (twice)


def test_stairs_slopes_side_and_back_steps_go_where_they_say():
    b = GaitBuilder().stand(1).stairs(4).stairs(4, up=False).walk(10, slope_deg=10)
    b.side_steps(2).back_steps(2)
    poses = b.build().stances
    z = [p.z for _, _, p in poses[:5]]
    assert z == pytest.approx([0.0, -0.34, -0.68, -0.34, 0.0])  # two stairs per stride
    last = poses[-1][2]
    assert last.z == pytest.approx(-10 * math.sin(math.radians(10)))
    assert last.y == pytest.approx(0.70)
    assert last.x == pytest.approx(8 * 0.28 + 10 * math.cos(math.radians(10)) - 1.0)
    assert poses[-5][2].pitch == pytest.approx(math.radians(10))  # foot flat on the slope


def test_a_stair_swing_keeps_rotating_through_mid_swing():
    """Up and down stairs the forefoot lands first (the foot is never toe up in the swing), and besides
    pitching the foot rolls its sole and turns its toe on the way, as real feet do: nowhere in the middle
    80 % of a stair swing does it come near to stopping — its slowest |ω| there is faster than 19 in 20
    real swings' (a stair swing that only pitched stopped, roll and yaw rates 0, where the pitch turned,
    and the module's detector took it for a stance). Walking, running, turning on the spot and the
    wiggle neither roll nor turn in the swing."""
    for recipe, gait in (("stand:2+stairs_up:8+stand:2", STAIRS_UP),
                         ("stand:2+stairs_down:8+stand:2", STAIRS_DOWN)):
        gt = trajectory(recipe).sample(1000.0)
        swings = list(zip(gt.stance_end[:-1], gt.stance_start[1:], strict=True))
        assert len(swings) == 4
        for lift_off, landing in swings:
            edge = 0.1 * (landing - lift_off)
            middle = (gt.t >= lift_off + edge) & (gt.t <= landing - edge)
            rate = np.degrees(np.linalg.norm(gt.omega_b[middle], axis=1))
            assert rate.min() > REAL_SWING_MIN_RATE_P5_DPS, (recipe, rate.min())
            swing = (gt.t > lift_off) & (gt.t < landing)
            roll, pitch, yaw = np.degrees(gt.euler[swing]).T
            assert pitch.max() < 1e-6 and pitch.min() < gait.heel_strike_pitch_deg < 0.0
            assert roll.max() == pytest.approx(gait.swing_roll_deg, rel=1e-3) and roll.min() > -1e-6
            assert yaw.max() == pytest.approx(gait.swing_yaw_deg, rel=1e-3) and yaw.min() > -1e-6
    for gait in (WALKING, RUNNING, SHUFFLE, WIGGLE):
        assert gait.swing_roll_deg == gait.swing_yaw_deg == 0.0


def test_side_and_back_steps_keep_rotating_through_mid_swing():
    """A side or back step rolls its sole and turns its toe on the way as a stair swing does: it never
    comes near to stopping in mid-swing (a side step that only pitched stopped, |ω| 0.8 °/s, at 38 %
    of its swing and the module's detector took it for a stance). A back step is a forward step
    reversed in time: it lifts off toe up and lands toe first."""
    for recipe, back in (("stand:2+side:3:1+side:3:-1+stand:2", False), ("stand:2+back:4+stand:2", True)):
        gt = trajectory(recipe).sample(1000.0)
        swings = list(zip(gt.stance_end[:-1], gt.stance_start[1:], strict=True))
        assert len(swings) == (4 if back else 6)
        rate = np.degrees(np.linalg.norm(gt.omega_b, axis=1))
        for lift_off, landing in swings:
            edge = 0.1 * (landing - lift_off)
            middle = (gt.t >= lift_off + edge) & (gt.t <= landing - edge)
            assert rate[middle].min() > REAL_SWING_MIN_RATE_FLOOR_DPS, (recipe, rate[middle].min())
            inner = (gt.t >= lift_off + 2 * edge) & (gt.t <= landing - 2 * edge)
            assert rate[inner].min() > 5 * REAL_SWING_MIN_RATE_P5_DPS, (recipe, rate[inner].min())
            swing = (gt.t > lift_off) & (gt.t < landing)
            roll, pitch, yaw = np.degrees(gt.euler[swing]).T
            assert roll.max() == pytest.approx(SHORT_STEPS.swing_roll_deg, rel=1e-3)
            assert yaw.max() == pytest.approx(SHORT_STEPS.swing_yaw_deg, rel=1e-3)
            if back:
                half = 0.5 * (lift_off + landing)
                first, last = swing & (gt.t < half), swing & (gt.t > half)
                assert np.degrees(gt.euler[first, 1]).max() > 0.5 * SHUFFLE.heel_strike_pitch_deg > 0.0
                assert np.degrees(gt.euler[last, 1]).min() < 0.5 * SHUFFLE.toe_off_pitch_deg < 0.0


def test_scenarios_are_registered_and_composable():
    names = list_scenarios()
    for required in ("default", "stand", "walk", "rectangle", "track400", "turn_on_spot", "stairs_up",
                     "stairs_down", "slope", "side_steps", "back_steps", "run", "ramp_0", "ramp_2.5",
                     "ramp_6", "ramp_7.5", "ramp_diagonal"):
        assert required in names
    tr = trajectory("walk:5+turn:90")  # stands added at both ends
    assert tr.stances[0][1] - tr.stances[0][0] == pytest.approx(3.0)
    assert tr.evaluate(np.array([tr.duration])).euler[0, 2] == pytest.approx(math.pi / 2)
    with pytest.raises(KeyError, match="unknown scenario"):
        trajectory("moonwalk")
    with pytest.raises(KeyError, match="unknown piece"):
        trajectory("stand:1+moonwalk")
    with pytest.raises(ValueError, match="must be numbers"):
        trajectory("stand:x")
    assert set(SCENARIOS) == set(names)


def test_speed_and_cadence_parametrise_the_stride():
    p = WALKING.with_speed(2.0, cadence_steps_per_min=120)
    assert p.stride_s == pytest.approx(1.0) and p.stride_length == pytest.approx(2.0)
    with pytest.raises(ValueError):
        GaitParams(swing_s=0.4).with_speed(1.0, cadence_steps_per_min=400)


def test_ground_truth_exports_per_sample_and_per_stance_csv(tmp_path):
    gt = trajectory("walk:3").sample(100.0)
    lines = gt.to_csv(tmp_path / "truth.csv").read_text().splitlines()
    assert lines[0] == "t,x,y,z,vx,vy,vz,qw,qx,qy,qz,roll,pitch,yaw,stance"
    assert len(lines) == len(gt) + 1
    table = np.loadtxt(tmp_path / "truth.csv", delimiter=",", skiprows=1)
    assert np.allclose(table[:, 1:4], gt.pos, atol=1e-8)
    assert np.allclose(np.linalg.norm(table[:, 7:11], axis=1), 1.0)
    st = np.loadtxt(gt.stances_to_csv(tmp_path / "stances.csv"), delimiter=",", skiprows=1)
    assert st.shape == (len(gt.stance_start), 8)
    assert np.allclose(st[-1, 2:5], gt.pos[-1], atol=1e-8)


# ---------------------------------------------------------------------------------------------
# the walking stances' residual motion (StanceSway, off by default)


def test_a_swaying_stance_turns_the_foot_and_shakes_the_module_in_place_and_nothing_else():
    """In a walking stance the foot turns by a few °/s and the sole vibrates (tests/oracle/stance_motion.py
    has the real feet's figures), the module staying within a tenth of a millimetre of its pose and
    within the ZUPT's σ_v (10 mm/s) of rest; the swings and the stands (≥ 1 s) are exactly as without."""
    plain = trajectory("walk:30+turn:90")
    still, swayed = plain.sample(1000.0), plain.with_stance_sway(seed=7).sample(1000.0)
    assert plain.stance_sway is None and plain.with_stance_sway(seed=7).stance_sway == STANCE_SWAY
    walking = np.zeros(len(still), bool)
    for t0, t1 in zip(still.stance_start, still.stance_end, strict=True):
        if t1 - t0 < STANCE_SWAY.longest_stance_s:
            walking[int(np.ceil(t0 * 1000)):int(np.ceil(t1 * 1000))] = True
    assert walking.sum() > 10000 and np.array_equal(swayed.stance, still.stance)
    for name in ("pos", "vel", "acc", "euler", "omega_b", "alpha_b", "f_b"):
        assert np.array_equal(getattr(swayed, name)[~walking], getattr(still, name)[~walking]), name
    rate = np.degrees(np.sqrt(np.mean(swayed.omega_b[walking] ** 2, axis=0)))
    assert rate == pytest.approx(STANCE_SWAY.rate_rms_dps, rel=0.15)
    assert np.abs(swayed.pos - still.pos).max() < 1e-4
    assert np.abs(swayed.vel[walking]).max() < 0.01  # the ZUPT's σ_v; rms about 1 mm/s
    assert np.abs(np.degrees(swayed.euler - still.euler)).max() < 1.0
    assert np.array_equal(trajectory("walk:30+turn:90").with_stance_sway(seed=7).sample(1000.0).omega_b,
                          swayed.omega_b)  # the walk's seed draws it
    assert not np.array_equal(plain.with_stance_sway(seed=8).sample(1000.0).omega_b, swayed.omega_b)


def test_a_swaying_stance_keeps_the_analytic_derivatives_and_the_strapdown_retraces_it():
    gt = trajectory("stand:1+walk:6+stand:1").with_stance_sway(seed=0).sample(4000.0)
    dt = 1.0 / 4000.0
    inner = slice(2, -2)
    for value, derivative in ((gt.pos, gt.vel), (gt.vel, gt.acc), (gt.omega_b, gt.alpha_b)):
        fd = np.gradient(value, dt, axis=0)
        assert np.abs(fd - derivative)[inner].max() < 1e-2 * np.abs(derivative).max()
    dR = np.gradient(gt.R, dt, axis=0)
    W = np.einsum("nji,njk->nik", gt.R, dR)
    omega = np.stack([W[:, 2, 1], W[:, 0, 2], W[:, 1, 0]], axis=1)
    assert np.abs(omega - gt.omega_b)[inner].max() < 1e-3 * np.abs(gt.omega_b).max()
    walk = trajectory("walk").with_stance_sway(seed=0).sample(1000.0)
    p, _, _ = strapdown_rk4(walk.f_b, walk.omega_b, 1e-3, walk.pos[0], walk.vel[0], walk.quat[0], gravity=G)
    assert np.linalg.norm(p[-1] - walk.pos[-1]) < 0.01


@pytest.mark.parametrize("name", ["stairs_up", "side_steps", "run"])
def test_the_rate_alone_is_the_evaluated_rate_bit_for_bit(name):
    # a gyro's delay evaluates a walk earlier only for its rate: the same numbers as the whole kinematics
    for walk in (trajectory(name), trajectory(name).with_stance_sway(seed=2)):
        t = np.arange(0.0, walk.duration, 1.0 / 997.0) - 7e-4
        assert walk.body_rate(t).tobytes() == walk.evaluate(t).omega_b.tobytes()
