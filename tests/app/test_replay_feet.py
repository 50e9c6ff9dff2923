"""``openshoe-emu replay --scenario NAME --feet 2 --wire OUT``: a module on each foot of one walker,
each foot's capture and truth, and the body's truth."""

from __future__ import annotations

import numpy as np
import pytest

from firmware_sim.app import cli
from firmware_sim.app.batch import run_replay
from firmware_sim.mcu.module import ModuleConfig
from firmware_sim.sensors.imu_array import make_feet_sources
from firmware_sim.transports.factory import module_serial
from hostlib.files.replay import replay_session

RECIPE = "stand:2+walk:6+stand:2"
RATE = 250.0


def _feet(tmp_path, *argv: str):
    out = tmp_path / "walk.bin"
    code = cli.main(["replay", "--scenario", RECIPE, "--rate", str(RATE), "--feet", "2", "--host", "fusion",
                     "--seed", "3", *argv, "--wire", str(out), "--quiet"])
    return code, out


def test_each_foot_has_its_capture_truth_and_serial_number(tmp_path):
    code, out = _feet(tmp_path)
    assert code == 0
    sources = make_feet_sources(RECIPE, seed=3, rate_hz=RATE)
    serials = set()
    for side, source in sources.items():
        wire = out.with_name(f"walk.bin.{side}")
        config = ModuleConfig(rate_hz=RATE, mcu_serial=module_serial(source.module))
        assert wire.read_bytes() == bytes(run_replay(source, config=config, announce=None, host="fusion"))
        assert out.with_name(f"walk.bin.{side}.truth.csv").is_file()
        serials.add(replay_session(wire.read_bytes()).mcu_serial)
    assert len(serials) == 2 and None not in serials, "a host tells the feet apart by serial number"


def test_body_truth_is_the_feet_midpoint(tmp_path):
    _, out = _feet(tmp_path)
    body = np.loadtxt(out.with_name("walk.bin.body.truth.csv"), delimiter=",", skiprows=1)
    left, right = (np.loadtxt(out.with_name(f"walk.bin.{s}.truth.csv"), delimiter=",", skiprows=1)
                   for s in ("left", "right"))
    assert np.allclose(body[:, 1:4], 0.5 * (left[:, 1:4] + right[:, 1:4]), atol=1e-8)
    assert body[-1, 1] == pytest.approx(6.0, abs=1e-6)  # the walker stopped 6 m north, feet together


def test_feet_need_a_scenario_and_one_output(tmp_path, capsys):
    assert cli.main(["replay", str(tmp_path / "x.csv"), "--feet", "2", "--wire", str(tmp_path / "o")]) == 2
    assert "--feet 2 goes with --scenario and --wire" in capsys.readouterr().err


def test_a_running_walker_s_feet_fuse_without_being_pulled_back(tmp_path):
    """Running, each module resets every other stride (its resets are at least 0.75 s apart): the
    feet's steps span two strides, the constraint leaves them out, and the fused body ends where
    the two feet's average does instead of a metre short."""
    from hostlib.files.replay import replay_feet

    out = tmp_path / "run.bin"
    assert cli.main(["replay", "--scenario", "stand:3+run:30+stand:2", "--feet", "2", "--host", "fusion",
                     "--seed", "3", "--wire", str(out), "--quiet"]) == 0
    tracker, _ = replay_feet(*(out.with_name(f"run.bin.{side}").read_bytes() for side in ("left", "right")))
    assert tracker.long_steps >= 10 and tracker.projections <= 1
    body, average = tracker.body.final_pose, tracker.average.final_pose
    assert np.hypot(*(body[:2] - average[:2])) < 0.2
    assert body[0] == pytest.approx(30.0, abs=0.3)
