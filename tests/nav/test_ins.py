"""The float32 ZUPT-aided INS and the step-wise reset (firmware.md §4)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from firmware_sim.nav import config as cfg
from firmware_sim.nav import ins
from firmware_sim.nav import ins_arithmetic as arith
from protocol.states import DP_INDEX, P_INDEX

F32 = np.float32
#: The module's own noise figures, as the filter reads them.
NOISE = cfg.MODULE_INS_NOISE.as_array()
G = float(cfg.GRAVITY)


def level_quat() -> np.ndarray:
    return np.array([0, 0, 0, 1], dtype=np.float32)


def p45_diag(values) -> np.ndarray:
    pm = np.diag(np.asarray(values, dtype=np.float32))
    return pm[np.triu_indices(9)].astype(np.float32)


def test_float_constants_are_single_precision():
    """Every INS tuning constant is a numpy.float32, so none can promote the arithmetic to float64."""
    names = ["GRAVITY", "SIGMA_ACC", "SIGMA_GYRO", "SIGMA_ZUPT", "SIGMA_P0", "SIGMA_V0", "SIGMA_TH0",
             "RESET_COV_THRESHOLD", "MIN_TIME_BETWEEN_RESETS", "MAX_TIME_RESET_PENDING", "NOMINAL_PERIOD",
             "ACC_SCALE", "GYRO_SCALE", "CPU_HZ", "BIAS_P0", "BIAS_Q", "BIAS_R", "MIN_SLOPE_STANCE_S",
             "MIN_SLOPE_SWING_S", "SLOPE_LOWPASS", "SIGMA_SLOPE_HEIGHT", "SLOPE_GATE_M", "MIN_POSTURE_STEP_M",
             "POSTURE_STANCES", "MAX_POSTURE"]
    for n in names:
        assert type(getattr(cfg, n)) is np.float32, n


def test_kernels_keep_float32_throughout():
    """A float64 anywhere in the arithmetic would show up in these results' dtypes."""
    rng = np.random.default_rng(0)
    q = ins.alignment_quaternion(np.array([0.5, -0.3, -9.7], F32))
    assert q.dtype == np.float32
    assert arith.quat_to_rot(q).dtype == np.float32
    assert arith.quat_mul(q, q).dtype == np.float32
    assert arith.rot_to_yaw(arith.quat_to_rot(q)).dtype == np.float32
    s = rng.normal(size=(3, 3)).astype(F32)
    assert arith.inv3_sym(s @ s.T + np.eye(3, dtype=F32)).dtype == np.float32
    pos, vel = np.zeros(3, F32), np.array([0.1, 0.2, 0.0], F32)
    f_n = np.zeros(3, F32)
    p45 = p45_diag([1e-4] * 9)
    pm = np.zeros((9, 9), F32)
    u_k = np.array([0.3, 0.1, -9.8, 0.2, -0.1, 0.05], F32)
    # run every kernel on a private copy and check that the values equal a float32-only recomputation
    ins.mechanization(u_k, F32(0.001), False, pos, vel, q, f_n)
    fn = arith.quat_to_rot(q) @ u_k[0:3]
    assert fn.dtype == np.float32
    ins.time_update(f_n, F32(0.001), False, p45, pm, NOISE)
    ins.zupt_update(pos, vel, q, p45, pm, F32(0.001), NOISE)
    theta_init, theta_ground = np.zeros(2, F32), np.array([0.1, -0.02], F32)
    ins.slope_height_update(np.array([0.5, 0.1, -0.04], F32), vel, q, p45, pm, theta_ground)
    w = ins.HeightWork()
    for zupt in (True, True, False):
        ins.height_compensation(zupt, u_k[0:3], F32(0.03), w, pos, vel, q, p45, pm, theta_init, theta_ground)
    assert all(type(a) is np.float32 for a in ins.foot_angles(u_k[0:3]))
    assert type(arith._tanf(F32(0.1))) is np.float32
    for a in (pos, vel, q, f_n, p45, pm, theta_ground):
        assert a.dtype == np.float32


def test_float64_leak_detector_works():
    """The check above would catch a float64 constant (sanity of the method)."""
    x = np.array([1.0], F32)
    assert (x * np.float64(2.0)).dtype == np.float64
    assert (x * F32(2.0)).dtype == np.float32


def test_p24_is_var_vx_and_dp_picks_the_position_yaw_block():
    assert P_INDEX[ins.P24_INDEX] == (3, 3)
    assert list(ins.POS_YAW_TRIANGLE) == [0, 1, 2, 8, 9, 10, 16, 17, 23, 44]
    idx = (0, 1, 2, 8)
    for k, (r, c) in enumerate(DP_INDEX):
        assert P_INDEX[ins.POS_YAW_TRIANGLE[k]] == (idx[r], idx[c])


@pytest.mark.parametrize("roll,pitch", [(0.0, 0.0), (0.3, -0.2), (-1.0, 0.7), (2.5, 0.1)])
def test_alignment_recovers_roll_and_pitch(roll, pitch):
    from firmware_sim.sensors.truth import euler_to_matrix

    r = euler_to_matrix(np.array([roll]), np.array([pitch]), np.array([0.0]))[0]
    f_b = (r.T @ np.array([0, 0, -G])).astype(F32)
    q = ins.alignment_quaternion(f_b)
    np.testing.assert_allclose(arith.quat_to_rot(q), r, atol=2e-6)


def test_alignment_needs_256_consecutive_stationary_samples():
    w = ins.InsWork()
    w.t_swing[0] = F32(0.5)
    pos, vel, q, p45 = np.ones(3, F32), np.ones(3, F32), level_quat(), np.zeros(45, F32)
    angles = np.ones(2, F32), np.ones(2, F32)  # THETA_INIT, THETA_GROUND
    pitch, roll = 0.05, -0.02
    f = (np.array([math.sin(pitch), -math.cos(pitch) * math.sin(roll), -math.cos(pitch) * math.cos(roll)])
         * G).astype(F32)
    for _ in range(200):
        assert not ins.initial_alignment(f, True, w, pos, vel, q, p45, *angles)
    assert not ins.initial_alignment(f, False, w, pos, vel, q, p45, *angles)  # motion restarts the count
    done = [ins.initial_alignment(f, True, w, pos, vel, q, p45, *angles)
            for _ in range(cfg.ALIGNMENT_SAMPLES)]
    assert done == [False] * (cfg.ALIGNMENT_SAMPLES - 1) + [True]
    assert not pos.any() and not vel.any()
    np.testing.assert_allclose(angles[0], [pitch, roll], atol=1e-6)  # THETA_INIT: the foot at rest
    assert not angles[1].any() and w.t_swing[0] == 0  # THETA_GROUND level, no swing
    pm = np.zeros((9, 9), F32)
    arith.unpack_p(p45, pm)
    np.testing.assert_allclose(np.diag(pm), [1e-10] * 3 + [1e-4] * 3 + [0.00174**2] * 3, rtol=1e-5)


def test_mechanization_at_rest_stays_put_and_turns_with_the_gyro():
    pos, vel, q, f_n = np.zeros(3, F32), np.zeros(3, F32), level_quat(), np.zeros(3, F32)
    u = np.array([0, 0, -G, 0, 0, 0.5], F32)
    for _ in range(1000):
        ins.mechanization(u, F32(0.001), False, pos, vel, q, f_n)
    assert np.abs(vel).max() < 1e-5 and np.abs(pos).max() < 1e-5
    assert float(arith.rot_to_yaw(arith.quat_to_rot(q))) == pytest.approx(0.5, abs=1e-4)


def test_zaru_freezes_heading_and_position():
    pos, vel, q, f_n = np.zeros(3, F32), np.array([0.1, 0, 0], F32), level_quat(), np.zeros(3, F32)
    u = np.array([0, 0, -G, 0.0, 0.0, 0.5], F32)
    ins.mechanization(u, F32(0.01), True, pos, vel, q, f_n)
    assert not pos.any()
    assert float(arith.rot_to_yaw(arith.quat_to_rot(q))) == 0.0
    p45 = p45_diag([1e-4] * 9)
    pm = np.zeros((9, 9), F32)
    ins.time_update(f_n, F32(0.01), True, p45, pm, NOISE)
    arith.unpack_p(p45, pm)
    assert pm[0, 0] == F32(1e-4) and pm[8, 8] == F32(1e-4)
    assert pm[3, 3] > F32(1e-4) and pm[6, 6] > F32(1e-4)


def test_inv3_sym_inverts():
    rng = np.random.default_rng(1)
    a = rng.normal(size=(3, 3))
    s = (a @ a.T + np.eye(3)).astype(F32)
    np.testing.assert_allclose(arith.inv3_sym(s) @ s, np.eye(3), atol=1e-5)


def test_zupts_remove_a_tilt_error():
    """Sign check of F and of the attitude correction: a wrong tilt at rest is estimated and removed."""
    true_roll = 0.02
    from firmware_sim.sensors.truth import euler_to_matrix

    r = euler_to_matrix(np.array([true_roll]), np.array([0.0]), np.array([0.0]))[0]
    u = np.concatenate([(r.T @ np.array([0, 0, -G])), np.zeros(3)]).astype(F32)
    pos, vel, q, f_n = np.zeros(3, F32), np.zeros(3, F32), level_quat(), np.zeros(3, F32)  # roll error 0.02
    p45 = p45_diag([1e-10] * 3 + [1e-4] * 3 + [0.05**2] * 3)
    pm = np.zeros((9, 9), F32)
    for _ in range(2000):
        ins.mechanization(u, F32(0.001), False, pos, vel, q, f_n)
        ins.time_update(f_n, F32(0.001), False, p45, pm, NOISE)
        ins.zupt_update(pos, vel, q, p45, pm, F32(0.001), NOISE)
    rr = arith.quat_to_rot(q)
    assert math.atan2(rr[2, 1], rr[2, 2]) == pytest.approx(true_roll, abs=1e-3)


def _reset_state():
    w = ins.InsWork()
    pos = np.array([0.7, 0.1, -0.01], F32)
    yaw = 0.3
    q = arith.quat_mul(np.array([0, 0, math.sin(yaw / 2), math.cos(yaw / 2)], F32),
                     ins.alignment_quaternion(np.array([1.0, -0.5, -9.7], F32)))
    p45 = np.arange(1, 46, dtype=F32) * F32(1e-6)
    p45[ins.P24_INDEX] = F32(5e-5)
    return w, pos, q, p45, np.zeros(4, F32), np.zeros(10, F32), np.zeros(1, F32)


def test_reset_waits_for_0_75_s_then_for_the_end_of_the_stance():
    w, pos, q, p45, dx, dp, swing = _reset_state()
    dt = F32(0.004)
    fired = [ins.stepwise_reset(True, dt, w, pos, q, p45, dx, dp, swing) for _ in range(190)]  # 0.76 s stance
    assert not any(fired)
    assert bool(w.pending[0])  # pending from > 0.75 s on
    assert ins.stepwise_reset(False, dt, w, pos, q, p45, dx, dp, swing)  # end of stance → reset
    assert swing[0] == dt and w.t_swing[0] == 0  # the reset's own loop, without ZUPT, counts


def test_pending_reset_happens_after_0_25_s_of_stance():
    w, pos, q, p45, dx, dp, swing = _reset_state()
    dt = F32(0.004)
    n = 0
    while not ins.stepwise_reset(True, dt, w, pos, q, p45, dx, dp, swing):
        n += 1
    assert (n + 1) * 0.004 == pytest.approx(0.752 + 0.252, abs=0.0041)


def test_no_reset_while_var_vx_is_above_the_threshold():
    w, pos, q, p45, dx, dp, swing = _reset_state()
    p45[ins.P24_INDEX] = F32(2e-4)
    assert not any(ins.stepwise_reset(False, F32(0.004), w, pos, q, p45, dx, dp, swing) for _ in range(1000))


def test_reset_hands_over_dx_dp_and_zeroes_position_yaw_and_their_covariance():
    w, pos, q, p45, dx, dp, swing = _reset_state()
    w.t_since_reset[0] = F32(1.0)
    r0 = arith.quat_to_rot(q)
    roll0, pitch0 = math.atan2(r0[2, 1], r0[2, 2]), -math.asin(r0[2, 0])
    p_before = p45.copy()
    assert ins.stepwise_reset(False, F32(0.004), w, pos, q, p45, dx, dp, swing)
    np.testing.assert_allclose(dx, [0.7, 0.1, -0.01, 0.3], atol=1e-6)
    assert list(dp) == list(p_before[ins.POS_YAW_TRIANGLE])
    assert not pos.any()
    r = arith.quat_to_rot(q)
    assert abs(float(arith.rot_to_yaw(r))) < 1e-6
    assert math.atan2(r[2, 1], r[2, 2]) == pytest.approx(roll0, abs=1e-5)
    assert -math.asin(r[2, 0]) == pytest.approx(pitch0, abs=1e-5)
    for k, (i, j) in enumerate(P_INDEX):
        if i in (0, 1, 2, 8) or j in (0, 1, 2, 8):
            assert p45[k] == 0
        else:
            assert p45[k] == p_before[k]


def _step_on_a_slope(p_z: float, slope_deg: float, heading: float = 0.4):
    """A step of 1.4 m along the heading, its height p_z (z down), the ground sloping slope_deg along
    the foot; P as after a swing."""
    pos = np.array([1.4 * math.cos(heading), 1.4 * math.sin(heading), p_z], F32)
    q = np.array([0, 0, math.sin(heading / 2), math.cos(heading / 2)], F32)
    p45 = p45_diag([1e-3] * 3 + [1e-4] * 3 + [1e-5] * 3)
    return pos, np.zeros(3, F32), q, p45, np.zeros((9, 9), F32), np.array([math.radians(slope_deg), 0], F32)


def test_slope_measurement_pulls_the_step_height_onto_the_slope():
    """Walking forward on a nose-up slope climbs (z down): a step of 1.4 m up 3° rises 7.3 cm; an
    INS height of 3 cm is pulled most of the way there (σ 1 cm against the swing's 3 cm), the step's
    length and heading stay, and the height's variance shrinks."""
    pos, vel, q, p45, pm, slope = _step_on_a_slope(-0.03, 3.0)
    before = pos.copy()
    ins.slope_height_update(pos, vel, q, p45, pm, slope)
    rise = 1.4 * math.tan(math.radians(3))
    assert -rise < pos[2] < -0.03 - 0.8 * (rise - 0.03)
    assert np.hypot(*pos[:2]) == pytest.approx(1.4, abs=0.01)
    assert math.atan2(pos[1], pos[0]) == pytest.approx(math.atan2(before[1], before[0]), abs=1e-3)
    arith.unpack_p(p45, pm)
    assert pm[2, 2] < 1e-4


@pytest.mark.parametrize("p_z", [-0.17, 0.12])
def test_slope_measurement_skips_a_stair(p_z):
    """A step whose height is more than 10 cm off the slope's (a stair) is left alone."""
    pos, vel, q, p45, pm, slope = _step_on_a_slope(p_z, 0.0)
    before = pos.copy(), p45.copy()
    ins.slope_height_update(pos, vel, q, p45, pm, slope)
    assert np.array_equal(pos, before[0]) and np.array_equal(p45, before[1])


def test_height_compensation_measures_once_per_stance():
    """The slope measurement comes at a stance's first loop after a swing of 50 ms or more: not at a
    stance resumed after a detector blip, nor at the first stance the function sees."""
    f = np.array([0, 0, -G], F32)
    w, theta_init, slope = ins.HeightWork(), np.zeros(2, F32), np.zeros(2, F32)
    pos, vel, q, p45, pm, _ = _step_on_a_slope(-0.05, 0.0)  # 5 cm high on level ground
    state = (pos, vel, q, p45, pm, theta_init, slope)
    dt = F32(0.004)

    def loops(zupt: bool, n: int) -> None:
        for _ in range(n):
            ins.height_compensation(zupt, f, dt, w, *state)

    loops(True, 10)
    assert pos[2] == F32(-0.05), "no swing seen before this stance"
    loops(False, 100)
    loops(True, 1)
    measured = pos.copy()
    assert -0.02 < measured[2] < 0, "a stance after a swing: pulled towards the level ground"
    loops(True, 50)
    loops(False, 3)  # a 12 ms blip of the detector
    loops(True, 50)
    assert np.array_equal(pos, measured), "the same stance, measured already"


def test_height_compensation_learns_the_slope_from_stances():
    """Stances on a 6° slope (THETA_INIT level): THETA_GROUND goes half way per stance; a blip of ZUPT
    shorter than 50 ms learns nothing."""
    a = math.radians(6)
    f = np.array([G * math.sin(a), 0, -G * math.cos(a)], F32)
    w, theta_init, slope = ins.HeightWork(), np.zeros(2, F32), np.zeros(2, F32)
    pos, vel, q, p45, pm, _ = _step_on_a_slope(0.0, 0.0)
    state = (pos, vel, q, p45, pm, theta_init, slope)
    dt = F32(0.004)
    for _ in range(10):  # a blip: 40 ms of ZUPT
        ins.height_compensation(True, f, dt, w, *state)
    ins.height_compensation(False, f, dt, w, *state)
    assert not slope.any()
    learnt = []
    for _ in range(3):
        for _ in range(100):  # swing
            ins.height_compensation(False, f, dt, w, *state)
        for _ in range(100):  # stance
            ins.height_compensation(True, f, dt, w, *state)
        ins.height_compensation(False, f, dt, w, *state)
        learnt.append(float(slope[0]))
    np.testing.assert_allclose(learnt, [a / 2, 3 * a / 4, 7 * a / 8], rtol=1e-5)
    assert slope[1] == 0


def _walk_stances(foot_deg: float, rise_deg: float, n: int):
    """*n* steps of 1.4 m: in each the INS climbs *rise_deg* (z down) and the foot then stands
    *foot_deg* nose-up in its stance; THETA_INIT level at first. Returns THETA_INIT and THETA_GROUND
    [deg] after each stance."""
    a = math.radians(foot_deg)
    f = np.array([G * math.sin(a), 0, -G * math.cos(a)], F32)
    w, theta_init, slope = ins.HeightWork(), np.zeros(2, F32), np.zeros(2, F32)
    dt, out = F32(0.004), []
    for _ in range(n):
        pos, vel, q, p45, pm, _ = _step_on_a_slope(-1.4 * math.tan(math.radians(rise_deg)), 0.0, heading=0.0)
        state = (pos, vel, q, p45, pm, theta_init, slope)
        for _ in range(100):  # swing
            ins.height_compensation(False, f, dt, w, *state)
        for _ in range(100):  # stance
            ins.height_compensation(True, f, dt, w, *state)
        ins.height_compensation(False, f, dt, w, *state)
        out.append((math.degrees(theta_init[0]), math.degrees(slope[0])))
    return np.array(out)


def test_height_compensation_learns_the_walking_posture_on_level_ground():
    """The foot stands 1.4° nose-up in its walking stances while the INS's steps stay level: THETA_INIT
    takes that as the foot's walking posture from the second such stance on, judged at the third (the
    first with a stance on either side of one), and from then on the ground reads level: the slope
    read before (the posture, as a climb) decays by SLOPE_LOWPASS per stance."""
    out = _walk_stances(1.4, 0.0, 5)
    np.testing.assert_allclose(out[:, 0], [0.0, 0.0, 1.4, 1.4, 1.4], atol=1e-3)
    np.testing.assert_allclose(out[:, 1], [0.7, 1.05, 0.525, 0.2625, 0.13125], atol=1e-3)


def test_height_compensation_keeps_the_posture_on_a_ramp():
    """On a 2.5° ramp the INS's steps climb as the foot reads: that is ground, not posture — THETA_INIT
    stays and the slope is learnt. A reading steeper than MAX_POSTURE on steps the INS finds level
    is not taken as posture either."""
    out = _walk_stances(2.5, 2.5, 5)
    assert not out[:, 0].any()
    assert out[-1, 1] == pytest.approx(2.5 * (1 - 0.5 ** 5), abs=1e-3)
    assert not _walk_stances(6.0, 0.0, 3)[:, 0].any()
