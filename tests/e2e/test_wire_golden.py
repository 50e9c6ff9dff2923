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
    "2": "098c1e0b2e96419b18e1e11d4d2deeedd469de05651360184bc533dabed7e587",
    "3": "2a3186e71bcdf7000a17df5beae16edce07e43c01c2ca85d60b9402104212435",
    "30": "6e3f75c58ba3e833379d080d3c9c492c15c875adac3e0858457d49928e67ee47",
    "31": "3f12cd2b9c71a8555f397565c4f622c854bd97cfacc12896242b66fb0abc94bb",
    "32": "d70c13ba37ab55cd1bc50a1260b09eb6defb2642299cc948d7960fda42f277d8",
    "33": "5834114f375058966b5b370c68dc5fa90b843f0aa95f1d3a4f7b503b625d07fd",
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
