"""Sensor profiles: a replay navigates with the recording's sensor's noise figures, says which, and a
module still boots with its own."""

from __future__ import annotations

import numpy as np
import pytest

from firmware_sim.app import cli
from firmware_sim.app.batch import run_replay
from firmware_sim.mcu.module import ModuleConfig
from firmware_sim.nav import ins
from firmware_sim.nav.config import MODULE_INS_NOISE
from firmware_sim.nav.firmware import build_module
from firmware_sim.nav.profiles import GX2_PROFILE, MODULE_PROFILE, PROFILES, profile_for, profile_named
from firmware_sim.sensors.imu_array import make_source
from firmware_sim.sensors.replay import ReplaySource, load_recording, save_csv
from tests.conftest import requires_walks, walk_path

RECIPE = "stand:3+walk:4+stand:2"


def test_a_module_boots_with_its_own_noise_figures():
    module = build_module()
    assert np.array_equal(ins.ins_work(module).noise, MODULE_INS_NOISE.as_array())


def test_a_module_given_a_profile_navigates_with_its_figures():
    module = build_module(ModuleConfig(ins=GX2_PROFILE.ins))
    assert np.array_equal(ins.ins_work(module).noise, GX2_PROFILE.ins.as_array())


def test_the_figures_are_the_modules_own_at_their_own_rate():
    """Per cycle of their own period: the 3DM-GX2's at 250 Hz are the published per-sample σ's."""
    assert MODULE_PROFILE.ins.period == pytest.approx(1e-3)
    assert GX2_PROFILE.ins.period == pytest.approx(1 / 250)
    assert GX2_PROFILE.ins.sigma_acc == 0.5 and GX2_PROFILE.ins.sigma_zupt == 0.01


def test_a_simulated_module_uses_its_own_profile_and_a_name_overrides_it():
    source = make_source(RECIPE, seed=0, rate_hz=250.0)
    assert profile_for(source) is MODULE_PROFILE
    assert profile_for(source, "3dm-gx2") is GX2_PROFILE


def test_an_unknown_profile_is_refused_naming_the_known_ones():
    with pytest.raises(KeyError, match="known: " + ", ".join(PROFILES)):
        profile_named("gx3")


def test_a_csv_recording_of_unknown_sensor_replays_with_the_modules_own_figures(tmp_path):
    rec = make_source(RECIPE, seed=0, rate_hz=250.0).to_recording()
    path = save_csv(rec, tmp_path / "walk.csv")
    source = ReplaySource.from_file(path)
    assert source.sensor is None and profile_for(source) is MODULE_PROFILE
    named = run_replay(source, config=ModuleConfig(rate_hz=250.0, ins=MODULE_PROFILE.ins), announce=None)
    assert bytes(run_replay(source, announce=None)) == bytes(named)


def test_the_profile_changes_the_navigation_and_is_printed_with_the_run(tmp_path, capsys):
    rec = make_source(RECIPE, seed=0, rate_hz=250.0).to_recording()
    path = save_csv(rec, tmp_path / "walk.csv")
    own, gx2 = tmp_path / "own.bin", tmp_path / "gx2.bin"
    assert cli.main(["replay", str(path), "--wire", str(own)]) == 0
    assert "sensor profile mimu22bt" in capsys.readouterr().err
    assert cli.main(["replay", str(path), "--wire", str(gx2), "--profile", "3dm-gx2"]) == 0
    err = capsys.readouterr().err
    assert "sensor profile 3dm-gx2: σ_acc 0.5 m/s²" in err and "no gyro bias estimate" in err
    assert own.read_bytes()[:4] == gx2.read_bytes()[:4]  # the same command ack
    assert own.read_bytes() != gx2.read_bytes()


def test_profile_goes_with_one_replay(tmp_path, capsys):
    rec = make_source(RECIPE, seed=0, rate_hz=250.0).to_recording()
    path = save_csv(rec, tmp_path / "walk.csv")
    assert cli.main(["replay", str(path), "--wire-dir", str(tmp_path / "w"), "--profile", "3dm-gx2"]) == 2
    assert "--profile goes with --wire" in capsys.readouterr().err


@requires_walks
def test_an_openshoe_walk_is_a_3dm_gx2_recording():
    rec = load_recording(walk_path("2"))
    assert rec.sensor == "3dm-gx2"
    assert profile_for(ReplaySource(rec)) is GX2_PROFILE


def test_a_3dm_gx2_recording_is_taken_as_bias_compensated_and_the_module_still_estimates_its_own():
    """BIASEST leaves a 3DM-GX2 profile's rates as they are while the foot is still; the module's
    own profile estimates the offset of its MPU9150s, as before."""
    from firmware_sim.nav import frontend as fe

    offset = np.array([0, 0, 0, 16400, -8200, 4100], dtype=np.int32) * 16384  # 1, −0.5, 0.25 °/s
    for profile, moves in ((GX2_PROFILE, False), (MODULE_PROFILE, True)):
        module = build_module(profile.configure(ModuleConfig()))
        w = fe.frontend_work(module)
        for _ in range(200):
            fe.biasest(offset, True, w.gyro_bias, w.bias_p, w.bias_q)
        assert bool(np.any(w.gyro_bias != 0)) == moves, profile.name


def test_a_3dm_gx2_replay_boots_with_the_profiles_zupt_threshold_and_a_module_with_its_own():
    from firmware_sim.nav.config import TH_ZUPT_DEFAULT
    from protocol.ids import StateId

    replayed = build_module(GX2_PROFILE.configure(ModuleConfig(rate_hz=250.0)))
    assert int(replayed.memory[StateId.TH_ZUPT]) == GX2_PROFILE.zupt_threshold != TH_ZUPT_DEFAULT
    booted = build_module(MODULE_PROFILE.configure(ModuleConfig()))
    assert int(booted.memory[StateId.TH_ZUPT]) == TH_ZUPT_DEFAULT
    assert "TH_ZUPT 18000" in GX2_PROFILE.summary()


def test_a_threshold_the_run_sets_itself_wins_over_the_profiles():
    """A sweep's ``frontend.zupt_threshold`` (an initial state) is what the replayed module uses."""
    from protocol.ids import StateId

    config = GX2_PROFILE.configure(ModuleConfig(rate_hz=250.0, initial_states={StateId.TH_ZUPT: 9000}))
    assert int(build_module(config).memory[StateId.TH_ZUPT]) == 9000
