"""The slope height compensation (function 0x25, an emulator extension) and the states it comes with:
SWING_TIME (0x34), THETA_INIT (0x35), THETA_GROUND (0x36) — docs/protocol-extensions.md.

A host drives the module as a real one would: 0x34, then RUN_PROC(0x25, 10) once the first step packet
arrived (tests.nav.helpers.run_stepwise_host). The walks are simulated with the default sensor errors
(module identity, noise, drift, misalignment, ringing …); heights are compared with the simulation's
truth (z down: negative is up). Each run goes through the compiled path when numba is there.
"""

from __future__ import annotations

import numpy as np
import pytest

from firmware_sim.mcu.module import ModuleConfig
from firmware_sim.nav import config as cfg
from firmware_sim.nav.fastpath import TRACKING_HEIGHT_SLOTS
from firmware_sim.nav.firmware import OPENSHOE, build_module
from firmware_sim.nav.ins import HeightWork, clear_stance, learn_posture
from firmware_sim.sensors.imu_array import make_source
from protocol.codec import decode_states
from protocol.extensions import fusion_output_setup, fusion_step_ids
from protocol.frames import build_command
from protocol.ids import Command, ProcId, StateId
from tests.nav.helpers import run_stepwise_host, truth_height_change

SLOPE = "stand:3+walk:50:6+stand:2"
LEVEL = "stand:3+walk:50+stand:2"
STAIRS = "stand:3+walk:3+stairs_up:12+walk:3+stand:2"


def height_errors(recipe: str, seed: int = 1) -> tuple[float, float, np.ndarray]:
    """The summed dz of the step packets minus the truth's height change [m], without and with height
    compensation, and the slope learnt (THETA_GROUND)."""
    source = make_source(recipe, seed=seed)
    truth = truth_height_change(source)
    off = run_stepwise_host(source, compiled=None, height=False)
    on = run_stepwise_host(source, compiled=None, height=True)
    assert off.slots != on.slots == TRACKING_HEIGHT_SLOTS
    errors = off.height_change() - truth, on.height_change() - truth
    print(f"{recipe}: truth {truth:+.3f} m, error without {errors[0]:+.3f} m, with {errors[1]:+.3f} m")
    return *errors, on.module.memory[StateId.THETA_GROUND].copy()


# ------------------------------------------------------------------------------------- off by default
def test_height_compensation_is_in_no_default_sequence_and_fits_a_tick() -> None:
    module = build_module(ModuleConfig(compiled=False))
    assert OPENSHOE.functions[ProcId.HEIGHT_COMPENSATION].cycles == 3000
    for start in (Command.STEPWISE_DEAD_RECKONING, Command.RESET_ZUPT_AIDED_INS, Command.MIMU_FRONTEND):
        module.usb.port.host_write(build_command(start))
        module.run(3)
        assert ProcId.HEIGHT_COMPENSATION not in module.sequence.slots + module.sequence.storage
    module.sequence.slots[:] = TRACKING_HEIGHT_SLOTS
    budget = module.budget()
    assert budget["free"] > 0, budget


# --------------------------------------------------------------------------------------- the states
def test_swing_time_rides_in_the_step_packets_a_host_asks_for() -> None:
    """With the host-side aids' step output (protocol.extensions.fusion_output_setup) each step packet
    carries SWING_TIME: the time without ZUPT between the step's two resets — about the foot's swing
    (the detector holds ZUPT a little past the truth's stance), 0 for a reset while standing."""
    source = make_source("stand:3+walk:10+stand:2", seed=3)
    meaning, fields = fusion_output_setup()
    run = run_stepwise_host(source, compiled=None, height=False, setup=build_command(meaning, **fields))
    values = [decode_states(fusion_step_ids(), p.payload) for p in run.packets]
    swings = np.array([float(v[StateId.SWING_TIME]) for v in values])
    lengths = np.array([float(np.hypot(*v[StateId.DX][:2])) for v in values])
    truth = source.truth
    truth_swing = truth.stance_start[1:] - truth.stance_end[:-1]
    walking = lengths > 0.5
    assert walking.sum() >= 6 and swings[0] == 0 and swings[-1] == 0
    assert np.all(swings[lengths < 0.05] < 0.01), swings  # (a reset at the loop the foot lifts: its dt)
    assert np.all(np.abs(swings[walking] - np.median(truth_swing)) < 0.1), (swings, truth_swing)


def test_theta_init_is_the_standing_foot_angle_and_a_host_may_set_it() -> None:
    """THETA_INIT = the alignment's pitch and roll; THETA_GROUND starts at 0. A host's SET_STATE_12
    (the smallest set-state command an 8-byte state fits) overwrites THETA_INIT; walking on level
    ground the module takes it back to the foot's walking posture, and the ground reads level."""
    source = make_source("stand:3+walk:10+stand:1", seed=2)
    roll, pitch = source.truth.euler[0, 0], source.truth.euler[0, 1]
    module = build_module(ModuleConfig(compiled=None), sensors=source)
    module.usb.port.host_write(build_command(Command.STEPWISE_DEAD_RECKONING))
    module.run_until(lambda m: m.memory.flag(StateId.INIT_DONE), 4000)
    theta_init = module.memory[StateId.THETA_INIT].copy()
    assert np.all(np.abs(theta_init - [pitch, roll]) < 0.01), (theta_init, pitch, roll)
    assert module.memory.read_wire(StateId.THETA_GROUND) == bytes(8)

    probe = np.array([0.05, theta_init[1]], dtype=">f4").tobytes()
    setter = build_command(Command.SET_STATE_12, state_id=StateId.THETA_INIT, data=probe)
    run = run_stepwise_host(source, compiled=None, height=True, after_first_step=setter)
    learnt = run.module.memory[StateId.THETA_INIT]
    assert np.all(np.abs(learnt - theta_init) < 0.01), (learnt, theta_init)
    assert abs(run.module.memory[StateId.THETA_GROUND][0]) < 0.01


def test_the_walking_posture_is_learnt_from_stances_judged_by_their_neighbours() -> None:
    """THETA_INIT learns from level stances, each judged at the stance after it by the INS's slope of
    the step to it against the foot's readings at the stances either side (so that no stance's own
    reading decides whether it is learnt); a ramp's stances, where the INS climbs as the foot reads,
    are never learnt — the first and the last of them included."""
    w = HeightWork()
    clear_stance(w)
    theta_init = np.zeros(2, dtype=np.float32)
    w.step_dir[:] = (1.0, 0.0)  # steps along the foot's x: its pitch is the slope along the step

    def stance(pitch: float, ins_slope: float) -> float:
        w.step_slope[0] = ins_slope
        learn_posture(w, np.float32(pitch), np.float32(0.0), theta_init)
        return float(theta_init[0])

    ramp = float(np.tan(0.1))
    assert stance(0.021, 0.001) == stance(0.019, 0.0) == 0.0  # no stance on either side yet
    assert stance(0.022, 0.001) == pytest.approx(0.019, abs=1e-6)  # the 0.019 stance: level
    assert stance(0.119, ramp) == pytest.approx(0.0205, abs=1e-6)  # the 0.022 stance, level (n = 2)
    assert stance(0.120, ramp) == pytest.approx(0.0205, abs=1e-6)  # the first ramp stance: not learnt
    assert stance(0.020, 0.0) == pytest.approx(0.0205, abs=1e-6)  # nor the last
    assert stance(0.021, 0.0) == pytest.approx(0.0205 + (0.020 - 0.0205) / 3, abs=1e-6)  # level again
    assert int(w.posture_n[0]) == 3


# ------------------------------------------------------------------------------------ the height
@pytest.mark.slow
def test_height_compensation_keeps_the_climb_of_a_slope() -> None:
    """50 m up a 6° slope (5.2 m of climb): the slope is learnt, and the steps' summed height is within
    0.5 m of the truth with the compensation on."""
    without, with_, slope = height_errors(SLOPE)
    assert abs(with_) < 0.5
    assert abs(slope[0] - np.radians(6)) < np.radians(0.7) and abs(slope[1]) < np.radians(0.5)


@pytest.mark.slow
def test_height_compensation_does_not_spoil_level_walking() -> None:
    """50 m on level ground: the height gets no more than a few cm worse."""
    without, with_, slope = height_errors(LEVEL)
    assert abs(with_) <= abs(without) + 0.05
    assert np.all(np.abs(slope) < np.radians(0.7))


@pytest.mark.slow
def test_stairs_are_not_flattened() -> None:
    """Twelve stairs up (2.04 m): a stair's rise is beyond the gate, no measurement pulls it to the
    slope; the climb is what the INS alone gives."""
    without, with_, _ = height_errors(STAIRS)
    assert abs(with_ - without) < 0.02
    assert abs(with_) < 0.3


def test_the_gate_is_below_a_stair_s_rise_and_above_the_slope_model_s_error() -> None:
    """The constants' reasons: a stair rises ≥ 0.15 m; the model's own error over a 1.4 m step is
    about 0.4° (1 cm); a short ZUPT stretch is no stance."""
    assert cfg.SIGMA_SLOPE_HEIGHT < cfg.SLOPE_GATE_M < 0.15
    assert abs(1.4 * np.tan(np.radians(0.4)) - cfg.SIGMA_SLOPE_HEIGHT) < 0.001
    assert (1 - cfg.SLOPE_LOWPASS) ** 3 == 1 / 8
    assert cfg.MIN_SLOPE_STANCE_S == cfg.MIN_SLOPE_SWING_S == np.float32(0.05)
