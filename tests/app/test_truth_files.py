"""What a replay of a simulated walk writes beside its capture: the ground truth and the shoe's iron
as the host's calibration of that module, which ``openshoe-host replay --mag-cal`` takes for that
module and refuses for another, in one replay, many and a walker's two feet."""

from __future__ import annotations

import io

import numpy as np

from firmware_sim.app import cli
from firmware_sim.app.truth_files import shoe_iron
from firmware_sim.sensors.imu_array import make_feet_sources, make_source
from hostlib.calibration.magcal import MagCalibration
from hostlib.cli import main as host_main

RECIPE = "stand:2+walk:4+stand:1"
RATE = ("--rate", "250")


def _replay(tmp_path, name: str, *argv: str):
    out = tmp_path / name
    assert cli.main(["replay", "--scenario", RECIPE, *RATE, *argv, "--wire", str(out), "--quiet"]) == 0
    return out


def test_a_scenario_replay_writes_the_shoes_iron_as_the_modules_calibration(tmp_path):
    out = _replay(tmp_path, "w.bin", "--seed", "2", "--module", "4", "--host", "fusion")
    assert out.with_name("w.bin.truth.csv").is_file()
    iron = MagCalibration.load(out.with_name("w.bin.iron.json"))
    source = make_source(RECIPE, seed=2, rate_hz=250.0, module=4)
    assert iron.module_serial == "OSEMU-M00000004"
    np.testing.assert_array_equal(iron.hard_iron, source.magnetic.hard_iron)
    np.testing.assert_allclose(iron.soft_iron @ source.magnetic.soft_iron, np.eye(3), atol=1e-12)
    # the calibration undoes the simulated iron: a field seen through the shoe comes back
    field = np.array([15.0, 3.0, 48.0])
    seen = source.magnetic.soft_iron @ field + source.magnetic.hard_iron
    np.testing.assert_allclose(iron.apply(seen), field)
    assert shoe_iron(source).module_serial == ""


def test_the_host_takes_the_iron_for_its_module_and_refuses_it_for_another(tmp_path, capsys):
    out = _replay(tmp_path, "w.bin", "--seed", "2", "--module", "4", "--host", "fusion")
    other = _replay(tmp_path, "o.bin", "--seed", "2", "--module", "5", "--host", "fusion")
    said = io.StringIO()
    assert host_main(["replay", str(out), "--compass", "--mag-cal", str(out.with_name("w.bin.iron.json"))],
                     said) == 0
    assert "(calibrated)" in said.getvalue()
    assert host_main(["replay", str(out), "--compass", "--mag-cal", str(other.with_name("o.bin.iron.json"))],
                     io.StringIO()) != 0
    assert "OSEMU-M00000005" in capsys.readouterr().err


def test_many_seeds_and_two_feet_write_each_runs_iron(tmp_path):
    wire = tmp_path / "many"
    assert cli.main(["replay", "--scenario", RECIPE, *RATE, "--seeds", "1:3", "--wire-dir", str(wire),
                     "--quiet"]) == 0
    for seed in (1, 2):
        iron = MagCalibration.load(wire / f"stand_2_walk_4_stand_1_seed{seed}.bin.iron.json")
        simulated = make_source(RECIPE, seed=seed, rate_hz=250.0).magnetic
        np.testing.assert_array_equal(iron.hard_iron, simulated.hard_iron)
    feet = _replay(tmp_path, "walk.bin", "--seed", "3", "--feet", "2")
    sources = make_feet_sources(RECIPE, seed=3, rate_hz=250.0)
    serials = set()
    for side, source in sources.items():
        iron = MagCalibration.load(feet.with_name(f"walk.bin.{side}.iron.json"))
        np.testing.assert_array_equal(iron.hard_iron, source.magnetic.hard_iron)
        serials.add(iron.module_serial)
    assert len(serials) == 2, "each foot's iron is its own module's"
