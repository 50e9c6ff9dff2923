"""A module is a device: its systematic errors stay with it from walk to walk; a walk brings new noise.

The walk's seed draws the noise, drift, heel-strike ringing and the building's
field; the module's number draws what belongs to the hardware (offsets, scale,
misalignment, g-sensitivity, temperature coefficients, the shoe's iron). The
ground truth gives the track a user compares against in the frame the module
starts in.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from firmware_sim.sensors.config import DEFAULT_CONFIG, IDEAL_CONFIG
from firmware_sim.sensors.gait import WALKING, Pose
from firmware_sim.sensors.gait_builder import GaitBuilder
from firmware_sim.sensors.imu_array import SimulatedSource, make_source, module_rng
from firmware_sim.sensors.mpu9150 import ChipErrors

RECIPE = "stand:1+walk:2"
CHIP_FIELDS = ("acc_matrix", "acc_offset_g", "acc_offset_tempco_g", "acc_sens_tempco", "gyro_matrix",
               "gyro_offset", "gyro_offset_tempco", "gyro_sens_tempco", "gyro_g_matrix")
BUILDING_FIELDS = ("wave_vectors", "wave_amplitudes", "wave_phases")
SHOE_FIELDS = ("hard_iron", "soft_iron")
REGISTERS = ("imu", "temp", "mag")


def same_chips(a: list[ChipErrors], b: list[ChipErrors], fields=CHIP_FIELDS) -> bool:
    pairs = zip(a, b, strict=True)
    return all(np.array_equal(getattr(x, f), getattr(y, f)) for x, y in pairs for f in fields)


def same_fields(a, b, fields) -> bool:
    return all(np.array_equal(getattr(a, f), getattr(b, f)) for f in fields)


def test_one_module_keeps_its_errors_and_its_shoe_across_walks_but_each_walk_has_new_noise():
    first = make_source(RECIPE, seed=1, module=7)
    second = make_source(RECIPE, seed=2, module=7)
    assert first.module == second.module == 7
    assert same_chips(first.chips, second.chips)
    assert [c.temp_offset_c for c in first.chips] == [c.temp_offset_c for c in second.chips]
    assert same_fields(first.magnetic, second.magnetic, SHOE_FIELDS)
    # the errors are there (not trivially equal because absent)
    assert np.abs(first.chips[0].gyro_offset).min() > 0 and np.abs(first.magnetic.hard_iron).min() > 0
    # a new walk: new noise, and a new building
    assert not np.array_equal(first.imu, second.imu)
    assert not np.array_equal(first.mag, second.mag)
    assert not same_fields(first.magnetic, second.magnetic, BUILDING_FIELDS)
    diff = first.imu.astype(int) - second.imu.astype(int)
    assert diff.std(axis=0).min() > 0.5  # every register's noise differs sample by sample


def test_without_a_module_number_each_seed_is_a_new_module():
    one, two = make_source(RECIPE, seed=1), make_source(RECIPE, seed=2)
    assert (one.module, two.module) == (1, 2)
    for a, b in zip(one.chips, two.chips, strict=True):
        for f in CHIP_FIELDS:
            assert not np.array_equal(getattr(a, f), getattr(b, f)), f
    assert not same_fields(one.magnetic, two.magnetic, SHOE_FIELDS)


def test_the_default_module_is_the_seeds_own_bit_for_bit():
    implicit = make_source(RECIPE, seed=5)
    explicit = make_source(RECIPE, seed=5, module=5)
    assert implicit.module == explicit.module == 5
    for name in REGISTERS:
        assert np.array_equal(getattr(implicit, name), getattr(explicit, name)), name
    assert not np.array_equal(implicit.imu, make_source(RECIPE, seed=5, module=6).imu)


def test_different_modules_on_the_same_walk_differ_in_errors_but_share_the_building():
    a = make_source(RECIPE, seed=3, module=1)
    b = make_source(RECIPE, seed=3, module=2)
    for x, y in zip(a.chips, b.chips, strict=True):
        for f in CHIP_FIELDS:
            assert not np.array_equal(getattr(x, f), getattr(y, f)), f
    assert same_fields(a.magnetic, b.magnetic, BUILDING_FIELDS)
    assert np.array_equal(a.magnetic.earth_ned, b.magnetic.earth_ned)
    assert not same_fields(a.magnetic, b.magnetic, SHOE_FIELDS)
    assert not np.array_equal(a.imu, b.imu)


def test_a_module_number_draws_its_own_errors_apart_from_the_walk_of_the_same_number():
    src = make_source(RECIPE, seed=4, module=4)
    device = module_rng(4)
    assert same_chips(src.chips, [ChipErrors.draw(device, DEFAULT_CONFIG) for _ in src.chips])
    # not the walk's generator reused: the module's offsets do not move in step with its noise
    walk = np.random.default_rng(4)
    assert not same_chips(src.chips, [ChipErrors.draw(walk, DEFAULT_CONFIG) for _ in src.chips])
    assert not np.array_equal(src.chips[0].acc_offset_g, src.chips[1].acc_offset_g)  # each chip its own


def test_the_error_free_module_does_not_depend_on_seed_or_module():
    a = make_source(RECIPE, seed=1, module=2, config=IDEAL_CONFIG)
    b = make_source(RECIPE, seed=3, module=9, config=IDEAL_CONFIG)
    assert np.array_equal(a.imu, b.imu)
    assert np.array_equal(a.mag, b.mag)
    for chip in a.chips:
        assert np.array_equal(chip.acc_matrix, np.eye(3)) and np.array_equal(chip.gyro_matrix, np.eye(3))
        assert not np.any(chip.gyro_g_matrix) and not np.any(chip.acc_offset_g)


SWITCHES = {
    "offsets": ("acc_offset_g", "gyro_offset"),
    "scale_errors": (),  # scale shares acc_matrix / gyro_matrix with misalignment
    "temperature_effects": ("acc_offset_tempco_g", "acc_sens_tempco", "gyro_offset_tempco",
                            "gyro_sens_tempco"),
    "g_sensitivity": ("gyro_g_matrix",),
    "misalignment": (),
    "mag_disturbance": (),
}


@pytest.mark.parametrize("switch", sorted(SWITCHES))
def test_switching_one_error_off_leaves_the_other_errors_of_the_module_as_they_were(switch):
    on = make_source(RECIPE, seed=1, module=11)
    off = make_source(RECIPE, seed=1, module=11, config=replace(DEFAULT_CONFIG, **{switch: False}))
    own = set(SWITCHES[switch])
    if switch in ("scale_errors", "misalignment"):
        own |= {"acc_matrix", "gyro_matrix"}
    others = tuple(f for f in CHIP_FIELDS if f not in own)
    assert same_chips(on.chips, off.chips, others)
    for chip in off.chips:
        for f in SWITCHES[switch]:
            assert not np.any(getattr(chip, f)), f
    if switch == "mag_disturbance":
        assert np.array_equal(off.magnetic.hard_iron, np.zeros(3))
        assert np.array_equal(off.magnetic.soft_iron, np.eye(3))
    else:
        assert same_fields(on.magnetic, off.magnetic, SHOE_FIELDS + BUILDING_FIELDS)


def test_without_g_sensitivity_the_gyro_feels_no_acceleration_and_the_rest_is_unchanged():
    on = make_source(RECIPE, seed=1, module=3)
    off = make_source(RECIPE, seed=1, module=3, config=replace(DEFAULT_CONFIG, g_sensitivity=False))
    for a, b in zip(on.chips, off.chips, strict=True):
        assert np.array_equal(a.acc_matrix, b.acc_matrix) and np.array_equal(a.gyro_matrix, b.gyro_matrix)
        assert np.array_equal(a.acc_offset_g, b.acc_offset_g) and np.array_equal(a.gyro_offset, b.gyro_offset)
        assert np.array_equal(b.gyro_g_matrix, np.zeros((3, 3))) and np.any(a.gyro_g_matrix)
    # the accelerometers do not care: the same registers bit for bit
    assert np.array_equal(on.imu[..., :3], off.imu[..., :3])


def test_separate_scale_and_misalignment_switches_compose_into_the_same_matrix():
    def chips(**switch):
        return make_source(RECIPE, seed=1, module=8, config=replace(DEFAULT_CONFIG, **switch)).chips

    both, scale_only, tilt_only = chips(), chips(misalignment=False), chips(scale_errors=False)
    for b, s, m in zip(both, scale_only, tilt_only, strict=True):
        np.testing.assert_allclose(b.acc_matrix, s.acc_matrix @ m.acc_matrix, atol=1e-15)
        np.testing.assert_allclose(b.gyro_matrix, s.gyro_matrix @ m.gyro_matrix, atol=1e-15)


# --- ground truth in the frame a track starts in --------------------------------------------------


def test_stances_in_the_start_frame_start_at_the_origin_along_the_initial_heading():
    start = Pose(x=3.0, y=-2.0, z=0.5, yaw=math.radians(120.0))
    src = SimulatedSource(GaitBuilder(WALKING, start=start).stand(1.0).walk(4.0).stand(1.0).build(),
                          config=IDEAL_CONFIG)
    track = src.truth.stances_in_start_frame()
    assert len(track) >= 3
    np.testing.assert_array_equal(track[0], np.zeros(3))
    np.testing.assert_allclose(track[:, 1:], 0.0, atol=1e-12)  # straight ahead is the x axis
    assert np.all(np.diff(track[:, 0]) > 0)
    assert track[-1, 0] == pytest.approx(4.0, abs=1e-9)
    # the navigation-frame stances are not already in that frame
    assert np.abs(src.truth.stance_positions[-1, :2] - src.truth.stance_positions[0, :2]).min() > 1.0


def test_a_right_turn_then_a_walk_ends_to_the_right_of_the_start():
    track = make_source("turn:90+walk:5", config=IDEAL_CONFIG).truth.stances_in_start_frame()
    np.testing.assert_allclose(track[0], 0.0, atol=0)
    np.testing.assert_allclose(track[-1], [0.0, 5.0, 0.0], atol=1e-9)
    start = Pose(yaw=math.radians(-135.0))
    built = GaitBuilder(WALKING, start=start).stand(1.0).turn_on_spot(90.0).walk(3.0).stand(1.0).build()
    np.testing.assert_allclose(built.sample(100.0).stances_in_start_frame()[-1], [0.0, 3.0, 0.0], atol=1e-9)


@pytest.mark.parametrize(("recipe", "expected_deg"), [
    ("stand:2+turn:90+stand:2", 90.0),
    ("stand:2+turn:-90+stand:2", -90.0),
    ("stand:2+turn:270+stand:1", -90.0),  # wrapped: three right quarters are one left quarter
    ("stand:2+turn:-315+stand:1", 45.0),
])
def test_heading_change_is_right_positive_and_wrapped(recipe, expected_deg):
    change = make_source(recipe, config=IDEAL_CONFIG).truth.heading_change()
    assert -math.pi <= change <= math.pi
    assert change == pytest.approx(math.radians(expected_deg), abs=1e-9)
