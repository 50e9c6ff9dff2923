"""The wire bytes of batch replays, pinned: refactoring must not change one byte.

SHA-256 of what ``openshoe-emu replay --scenario default --wire OUT`` and
``openshoe-emu replay WALK --wire OUT`` write, recorded from the emulator as it
was before the packages were reorganised into layers. Each is checked through
the compiled path and through the pure-Python reference.

A change that is *meant* to change the module's bytes (new navigation, new
sensor errors) updates these figures in the same commit and says why:

* the default scenario's bytes changed with the realistic sensor errors (module
  identity, g-sensitivity, misalignment, bias instability, heel-strike ringing,
  scale residuals: ``docs/sensor-errors.md``);
* the error-free default scenario (``SensorConfig.ideal()``) is pinned too, at
  the figure it had before those errors came: error-free replays do not depend
  on the sensor error model, nor on the seed.
"""

from __future__ import annotations

import hashlib

import pytest

from firmware_sim.app.batch import run_replay
from firmware_sim.mcu.module import ModuleConfig
from firmware_sim.nav import fastpath
from firmware_sim.sensors.config import IDEAL_CONFIG
from firmware_sim.sensors.imu_array import make_source
from firmware_sim.sensors.replay import ReplaySource
from tests.conftest import WALK_IDS, requires_walks, walk_path

DEFAULT_SCENARIO_SHA256 = "1b5c5f1f25bd0f427dca5311c033b15cb03bdbab2da9c0fd0745fa96741c2f85"
IDEAL_DEFAULT_SCENARIO_SHA256 = "c8179aaa1ac593496a9330a894fa8689445b0d1fccaec0e539d2c10fd455f433"
WALK_SHA256 = {
    "2": "6a31bb16278aca13ea81cdec6d22820b5e955c7fa400e463d735aee223dea2c0",
    "3": "6724288fcd471990b62796ecc81376ff90ae0ffe5de413bc870e3fb9e672fdb1",
    "30": "74beebb33f92da02331099965331bc1d234dbe973f63829f36c590a0d5068e1e",
    "31": "9a8fc00d986152d22dc3e23db4241f6dc60bc52318d9f7352ecd2d162970b09a",
    "32": "5b5b0d5235b5f0058437e45ab68ef056ffa27604419cb5605475a7a8a18215dc",
    "33": "bc141038c7e9a8c4fbfe5df29ae4340ed9a274c8e895dceea736a5ede91f458d",
}

PATHS = [
    pytest.param(False, id="pure"),
    pytest.param(True, id="compiled", marks=pytest.mark.skipif(
        not fastpath.available(), reason=f"compiled path unavailable: {fastpath.reason_unavailable()}")),
]


def sha256_of_replay(source, compiled: bool) -> str:
    config = ModuleConfig(rate_hz=float(source.rate_hz), compiled=compiled)
    return hashlib.sha256(run_replay(source, config=config, announce=None)).hexdigest()


@pytest.mark.slow
@pytest.mark.parametrize("compiled", PATHS)
def test_default_scenario_replay_is_byte_identical(compiled):
    source = make_source("default", seed=0, rate_hz=1000.0)
    assert sha256_of_replay(source, compiled) == DEFAULT_SCENARIO_SHA256


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 7])
def test_error_free_default_scenario_is_byte_identical_for_any_seed(seed):
    source = make_source("default", seed=seed, rate_hz=1000.0, config=IDEAL_CONFIG)
    assert sha256_of_replay(source, compiled=fastpath.available()) == IDEAL_DEFAULT_SCENARIO_SHA256


@requires_walks
@pytest.mark.slow
@pytest.mark.parametrize("compiled", PATHS)
@pytest.mark.parametrize("walk", WALK_IDS)
def test_walk_replay_is_byte_identical(walk, compiled):
    assert sha256_of_replay(ReplaySource.from_file(walk_path(walk)), compiled) == WALK_SHA256[walk]
