"""`--module N`: one simulated module (its own systematic errors) walked with any seed, in
``openshoe-emu replay`` (one run and many), ``openshoe-emu serve`` and the demo."""

from __future__ import annotations

from dataclasses import fields

import numpy as np
import pytest

from firmware_sim.app import cli, demo
from firmware_sim.app.batch import run_replay
from firmware_sim.sensors.imu_array import make_source

from .serve_args import serve_args

RECIPE = "stand:1+walk:2"
STEM = "stand_1_walk_2"
RATE = ("--rate", "250")


def _replay(tmp_path, name: str, *argv: str) -> bytes:
    out = tmp_path / name
    assert cli.main(["replay", "--scenario", RECIPE, *RATE, *argv, "--wire", str(out), "--quiet"]) == 0
    return out.read_bytes()


def _same_chips(a, b) -> bool:
    return all(np.array_equal(getattr(ca, f.name), getattr(cb, f.name))
               for ca, cb in zip(a.chips, b.chips, strict=True) for f in fields(ca))


def test_one_module_keeps_its_errors_across_seeds():
    one, other = (make_source(RECIPE, seed=s, rate_hz=250.0, module=7) for s in (1, 2))
    assert (one.module, other.module) == (7, 7)
    assert _same_chips(one, other)
    assert not np.array_equal(one.imu, other.imu), "the walk's noise still follows the seed"
    assert not _same_chips(one, make_source(RECIPE, seed=1, rate_hz=250.0)), "module 7 is not seed 1's own"


def test_replay_of_one_module_with_two_seeds_writes_that_modules_walks(tmp_path):
    first = _replay(tmp_path, "a.bin", "--seed", "1", "--module", "7")
    second = _replay(tmp_path, "b.bin", "--seed", "2", "--module", "7")
    own = _replay(tmp_path, "own.bin", "--seed", "1")
    assert first == bytes(run_replay(make_source(RECIPE, seed=1, rate_hz=250.0, module=7), announce=None))
    assert second == bytes(run_replay(make_source(RECIPE, seed=2, rate_hz=250.0, module=7), announce=None))
    assert first != own, "module 7 walking seed 1 is not seed 1's own module"
    assert first != second
    assert (tmp_path / "a.bin.truth.csv").is_file()


def test_the_seeds_own_module_is_the_default(tmp_path):
    assert _replay(tmp_path, "own.bin", "--seed", "3") == _replay(tmp_path, "m3.bin", "--seed", "3",
                                                                  "--module", "3")


def test_many_seeds_of_one_module_are_named_by_module_and_seed(tmp_path, capsys):
    wire = tmp_path / "wire"
    args = ["replay", "--scenario", RECIPE, *RATE, "--seeds", "1:3", "--module", "7", "--wire-dir", str(wire),
            "--table", str(tmp_path / "runs.csv"), "--quiet"]
    assert cli.main(args) == 0
    names = sorted(p.name for p in wire.glob("*.bin"))
    assert names == [f"{STEM}_module7_seed1.bin", f"{STEM}_module7_seed2.bin"]
    single = _replay(tmp_path, "single.bin", "--seed", "2", "--module", "7")
    assert (wire / f"{STEM}_module7_seed2.bin").read_bytes() == single
    rows = (tmp_path / "runs.csv").read_text().splitlines()
    header = rows[0].split(",")
    assert [r.split(",")[header.index("module")] for r in rows[1:]] == ["7", "7"]
    assert "runs/s" in capsys.readouterr().out


@pytest.mark.parametrize("out", [("--wire", "o.bin"), ("--wire-dir", "d")])
def test_a_recording_refuses_a_module_identity(out, tmp_path, capsys):
    argv = ["replay", str(tmp_path / "walk.txt"), "--module", "3", *out, "--quiet"]
    assert cli.main(argv) == 2
    assert "--module goes with --scenario" in capsys.readouterr().err


def test_a_negative_module_is_refused_by_the_command_line(capsys):
    with pytest.raises(SystemExit) as caught:
        cli.main(["replay", "--scenario", RECIPE, "--module", "-1", "--wire", "o.bin"])
    assert caught.value.code == 2
    assert "--module" in capsys.readouterr().err


# --------------------------------------------------------------------------- serve and the demo


def test_serve_passes_the_module_identity_to_its_modules():
    from firmware_sim.app.serve import settings_from_args

    assert settings_from_args(serve_args("--tcp", "0", "--seed", "4", "--module", "9")).emulator.module == 9
    assert settings_from_args(serve_args("--tcp", "0")).emulator.module is None


def test_serve_refuses_a_module_identity_for_a_recording(capsys):
    from firmware_sim.app.serve import main

    assert main(serve_args("--tcp", "0", "--replay", "walk.txt", "--module", "1")) == 2
    assert capsys.readouterr().err == ("openshoe-emu serve: --module goes with a scenario, not --replay "
                                       "FILE: a recording carries its own sensors\n")


def test_serve_refuses_a_negative_module(capsys):
    with pytest.raises(SystemExit) as caught:
        serve_args("--tcp", "0", "--module", "-2")
    assert caught.value.code == 2 and "--module" in capsys.readouterr().err


def test_the_demo_takes_a_module_identity():
    assert demo.build_parser().parse_args(["--module", "4"]).module == 4
    assert demo.build_parser().parse_args([]).module is None
