"""The wire bytes of batch replays, pinned: refactoring must not change one byte.

SHA-256 of what ``openshoe-emu replay --scenario default --wire OUT`` and
``openshoe-emu replay WALK --wire OUT`` write, recorded from the emulator as it
was before the packages were reorganised into layers. Each is checked through
the compiled path and through the pure-Python reference (the recordings' pure-path
bytes in tests/nav/test_fastpath.py, which replays them on both paths anyway).

A change that is *meant* to change the module's bytes (new navigation, new
sensor errors) updates these figures in the same commit and says why:

* the default scenario's bytes changed with the realistic sensor errors (module
  identity, g-sensitivity, misalignment, bias instability, heel-strike ringing,
  scale residuals: ``docs/sensor-errors.md``);
* the error-free default scenario (``SensorConfig.ideal()``) is pinned too, at
  the figure it had before those errors came: error-free replays do not depend
  on the sensor error model, nor on the seed;
* both changed again with the stair gait (the forefoot lands first, the sole
  rolls and the toe turns out in the swing: ``firmware_sim.sensors.gait``'s
  STAIRS_UP / STAIRS_DOWN): the default route climbs and descends four flights.
  Every scenario without stairs, and the recordings, kept their bytes;
* the default scenario's bytes changed once more when its walking stances began to sway as
  a real foot's do (``stance_sway.STANCE_SWAY_DEFAULT``). Its still-stance bytes stay pinned
  (``stance_sway=False``), and so does the error-free figure, for still stances: a swaying
  walk's sway is drawn from its seed, so only the still walk is the same for every seed.
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

DEFAULT_SCENARIO_SHA256 = "35b3a5f664101887d89c7c14da72e90065a182ab54d4e04f4f922afe5c999ec1"
STILL_DEFAULT_SCENARIO_SHA256 = "b8412bebadfa21944cb962386706a1174e1dac0c642a1e26b3df94c47c15dc33"
IDEAL_DEFAULT_SCENARIO_SHA256 = "5a36645691251faf37e08f3b0a5148cbbb02d49d55aa895088c29e3bde347a6b"
WALK_SHA256 = {
    "2": "928af80cfaf2a785580fae9d97a52b6311d0afb135a655fa77a03b196700972f",
    "3": "07672250d6133425ac8a116b51d4ce10f418611fd18fd87e5611716bb6bc05f6",
    "30": "92fe7154f41e3ba21089c1471806f8de32b79d17b93e7c00fe24b16f566409fa",
    "31": "f663a543733f9512cd8585f48ae9a2b92b23f92897607c9026c78195ea1ae321",
    "32": "b972b02461958b3f68693055eb0fa64591aa1546a6befe4371958c785dbeb16b",
    "33": "20c935ac61200e517ba08eaa20a98a803c7364dffd0d5778b73e9a20f69e900e",
}

needs_compiled = pytest.mark.skipif(not fastpath.available(),
                                    reason=f"compiled path unavailable: {fastpath.reason_unavailable()}")
PATHS = [pytest.param(False, id="pure"), pytest.param(True, id="compiled", marks=needs_compiled)]


def sha256_of_replay(source, compiled: bool) -> str:
    config = ModuleConfig(rate_hz=float(source.rate_hz), compiled=compiled)
    return hashlib.sha256(run_replay(source, config=config, announce=None)).hexdigest()


@pytest.fixture(scope="module")
def default_source():
    """The default scenario (seed 0, 1000 Hz), made once for both paths (a replay leaves it as it was)."""
    return make_source("default", seed=0, rate_hz=1000.0)


@pytest.mark.slow
@pytest.mark.parametrize("compiled", PATHS)
def test_default_scenario_replay_is_byte_identical(compiled, default_source):
    assert sha256_of_replay(default_source, compiled) == DEFAULT_SCENARIO_SHA256


@pytest.mark.slow
def test_default_scenario_with_still_stances_keeps_its_bytes():
    source = make_source("default", seed=0, rate_hz=1000.0, stance_sway=False)
    assert sha256_of_replay(source, compiled=fastpath.available()) == STILL_DEFAULT_SCENARIO_SHA256


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 7])
def test_error_free_default_scenario_with_still_stances_is_byte_identical_for_any_seed(seed):
    source = make_source("default", seed=seed, rate_hz=1000.0, config=IDEAL_CONFIG, stance_sway=False)
    assert sha256_of_replay(source, compiled=fastpath.available()) == IDEAL_DEFAULT_SCENARIO_SHA256


@requires_walks
@pytest.mark.slow
@needs_compiled
@pytest.mark.parametrize("walk", WALK_IDS)
def test_walk_replay_is_byte_identical(walk):
    """The compiled path's bytes; the pure-Python reference's are checked against the same figures
    by tests/nav/test_fastpath.py's six-walks test, in the run that compares the two paths' states."""
    assert sha256_of_replay(ReplaySource.from_file(walk_path(walk)), True) == WALK_SHA256[walk]
