"""`--stance-sway`: the walking stances sway and vibrate as a real foot's do (stance_sway.StanceSway), in
``openshoe-emu replay`` (one run, both feet, many), ``openshoe-emu serve`` and the demo. It is the
default; ``--no-stance-sway`` gives every capture the bytes of the still stances of before."""

from __future__ import annotations

import pytest

from firmware_sim.app import cli, demo
from firmware_sim.app.batch import run_replay
from firmware_sim.mcu.module import ModuleConfig
from firmware_sim.sensors.imu_array import make_feet_sources, make_source
from firmware_sim.transports.factory import module_serial
from hostlib.files.replay import replay_bytes

from .serve_args import serve_args

RECIPE = "stand:2+walk:6+stand:2"
STEM = "stand_2_walk_6_stand_2"
RATE = 250.0


def _replay(tmp_path, name: str, *argv: str, quiet: bool = True) -> bytes:
    out = tmp_path / name
    args = ["replay", "--scenario", RECIPE, "--rate", str(RATE), "--seed", "3", *argv, "--wire", str(out)]
    assert cli.main([*args, "--quiet"] if quiet else args) == 0
    return out.read_bytes()


def _steps(data: bytes) -> tuple[int, int]:
    track, _stats = replay_bytes(data)
    return len(track), track.motion_steps


def test_stance_sway_changes_the_capture_not_the_steps(tmp_path):
    swaying = _replay(tmp_path, "sway.bin", "--stance-sway")
    still = _replay(tmp_path, "still.bin", "--no-stance-sway")
    assert swaying == bytes(run_replay(make_source(RECIPE, seed=3, rate_hz=RATE, stance_sway=True),
                                       announce=None))
    assert swaying != still, "the swaying foot's sensors and the module's output differ"
    assert _steps(swaying) == _steps(still), "the walker took the same steps"


def test_by_default_the_stances_sway_and_without_it_the_bytes_are_those_of_before(tmp_path):
    swaying = bytes(run_replay(make_source(RECIPE, seed=3, rate_hz=RATE), announce=None))
    assert _replay(tmp_path, "default.bin") == swaying == _replay(tmp_path, "on.bin", "--stance-sway")
    still = bytes(run_replay(make_source(RECIPE, seed=3, rate_hz=RATE, stance_sway=False), announce=None))
    assert _replay(tmp_path, "off.bin", "--no-stance-sway") == still != swaying


def test_the_announcement_says_how_the_stances_move(tmp_path, capsys):
    _replay(tmp_path, "sway.bin", quiet=False)
    assert f"scenario {RECIPE!r} (seed 3, 250 Hz, stance sway): " in capsys.readouterr().err
    _replay(tmp_path, "still.bin", "--no-stance-sway", quiet=False)
    err = capsys.readouterr().err
    assert f"scenario {RECIPE!r} (seed 3, 250 Hz, still stances): " in err and "stance sway" not in err


def test_each_foot_sways_with_its_own_walk(tmp_path, capsys):
    out = tmp_path / "walk.bin"
    assert cli.main(["replay", "--scenario", RECIPE, "--rate", str(RATE), "--feet", "2", "--seed", "3",
                     "--wire", str(out)]) == 0
    assert "left foot (module 6, seed 6, 250 Hz, stance sway): " in capsys.readouterr().err
    swaying = make_feet_sources(RECIPE, seed=3, rate_hz=RATE, stance_sway=True)
    still = make_feet_sources(RECIPE, seed=3, rate_hz=RATE, stance_sway=False)
    for side, source in swaying.items():
        config = ModuleConfig(rate_hz=RATE, mcu_serial=module_serial(source.module))
        wire = out.with_name(f"walk.bin.{side}").read_bytes()
        assert wire == bytes(run_replay(source, config=config, announce=None))
        assert wire != bytes(run_replay(still[side], config=config, announce=None))


def test_many_seeds_sway_as_one_replay_each(tmp_path):
    wire = tmp_path / "wire"
    assert cli.main(["replay", "--scenario", RECIPE, "--rate", str(RATE), "--seeds", "3:5", "--stance-sway",
                     "--wire-dir", str(wire), "--quiet"]) == 0
    assert (wire / f"{STEM}_seed3.bin").read_bytes() == _replay(tmp_path, "single.bin", "--stance-sway")


@pytest.mark.parametrize("out", [("--wire", "o.bin"), ("--wire-dir", "d")])
def test_a_recording_refuses_the_stance_sway(out, tmp_path, capsys):
    argv = ["replay", str(tmp_path / "walk.txt"), "--stance-sway", *out, "--quiet"]
    assert cli.main(argv) == 2
    assert "--stance-sway goes with --scenario" in capsys.readouterr().err


# --------------------------------------------------------------------------- serve and the demo


def test_serve_passes_the_stance_sway_to_its_modules():
    from firmware_sim.app.serve import settings_from_args

    assert settings_from_args(serve_args("--tcp", "0", "--stance-sway")).emulator.stance_sway is True
    assert settings_from_args(serve_args("--tcp", "0", "--no-stance-sway")).emulator.stance_sway is False
    assert settings_from_args(serve_args("--tcp", "0")).emulator.stance_sway is None


def test_serve_refuses_the_stance_sway_for_a_recording(capsys):
    from firmware_sim.app.serve import main

    assert main(serve_args("--tcp", "0", "--replay", "walk.txt", "--stance-sway")) == 2
    assert capsys.readouterr().err == ("openshoe-emu serve: --stance-sway goes with a scenario, not --replay "
                                       "FILE: a recording carries its own foot's motion\n")


def test_the_demo_takes_the_stance_sway_and_keeps_its_default():
    assert demo.build_parser().parse_args(["--stance-sway"]).stance_sway is True
    assert demo.build_parser().parse_args([]).stance_sway is None
