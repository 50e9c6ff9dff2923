"""A walk at another DLPF setting than it was made at: registers computed block by block, as read.

Every register equals, bit for bit, the one the whole walk computed at that setting holds, in
any order of reads and settings; setting the filter computes nothing, and a read computes at
most one block and the filter's lead-in before it.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from firmware_sim.mcu.imu_bus import DLPF_SETTINGS, imu_block
from firmware_sim.sensors.config import DEFAULT_CONFIG, SensorConfig
from firmware_sim.sensors.imu_array import make_foot_source, make_source
from firmware_sim.sensors.mpu9150 import dlpf_filter, dlpf_reach

WALK = "stand:1+walk:6+stand:1"
SEED = 5


def whole_records(make) -> dict[int, np.ndarray]:
    """The walk's whole record of registers at every setting, each from a walk made anew."""
    out = {}
    for cfg in DLPF_SETTINGS:
        walk = make()
        walk.set_dlpf(cfg)
        out[cfg] = walk.imu
    return out


@pytest.fixture(scope="module")
def walk_records() -> dict[int, np.ndarray]:
    return whole_records(lambda: make_source(WALK, seed=SEED))


@pytest.mark.parametrize("rate_hz", [1000.0, 200.0])
@pytest.mark.parametrize("bandwidth_hz", [260.0, 94.0, 21.0, 5.0])
def test_a_part_filtered_after_its_lead_in_is_the_whole_records_bit_for_bit(bandwidth_hz, rate_hz):
    x = np.random.default_rng(1).standard_normal((6000, 2, 3)) * 1e3
    whole = dlpf_filter(x, bandwidth_hz, rate_hz)
    reach = dlpf_reach(bandwidth_hz, rate_hz)
    assert 0 < reach < 2100
    for start in (reach, reach + 1, 3001, 5999):
        part = dlpf_filter(x[start - reach:start + 500], bandwidth_hz, rate_hz, from_rest=False)
        assert np.array_equal(part[reach:], whole[start:start + 500]), start
    # within the lead-in of the record's start, the part is the record's beginning
    assert np.array_equal(dlpf_filter(x[:reach], bandwidth_hz, rate_hz), whole[:reach])


def test_every_setting_read_in_order_is_the_whole_records(walk_records):
    walk = make_source(WALK, seed=SEED)
    for cfg in DLPF_SETTINGS:
        walk.set_dlpf(cfg)
        read = np.stack([walk.read(i).imu for i in range(len(walk))])
        assert np.array_equal(read, walk_records[cfg]), cfg
        assert walk.read(len(walk)) is None


def test_blocks_read_in_any_order_after_any_settings_are_the_whole_records(walk_records):
    walk = make_source(WALK, seed=SEED)
    rng = np.random.default_rng(7)
    n = len(walk)
    for _ in range(200):
        cfg = int(rng.integers(0, 7))
        walk.set_dlpf(cfg)
        start = int(rng.integers(0, n))
        block = imu_block(walk, start, int(rng.integers(1, 600)))
        assert np.array_equal(block, walk_records[cfg][start:start + len(block)]), (cfg, start)
        i = int(rng.integers(0, n))
        sample = walk.read(i)
        assert np.array_equal(sample.imu, walk_records[cfg][i])
        assert np.array_equal(sample.temp, walk.temp[i]) and np.array_equal(sample.mag, walk.mag[i])


def test_setting_the_filter_computes_nothing_and_a_read_at_most_one_block_and_its_lead_in():
    walk = make_source(WALK, seed=SEED)
    n = len(walk)
    assert walk.computed_samples == n, "made: the whole record at the power-on setting"
    size = walk.chunk_samples
    assert size == 100
    for cfg in (6, 3, 0, 1, 5):
        before = walk.computed_samples
        walk.set_dlpf(cfg)
        assert walk.computed_samples == before
        walk.read(4321)
        assert walk.computed_samples - before <= size + walk.lead_in(cfg)
    # read on in order: each block's lead-in is the block before's inputs, computed once
    walk.set_dlpf(4)
    before = walk.computed_samples
    for i in range(1000, n):
        walk.read(i)
    assert walk.computed_samples - before <= (n - 1000) + size + walk.lead_in(4)
    assert walk.lead_in(6) == 2047 and walk.lead_in(0) == 31


def test_switching_among_settings_within_a_block_computes_each_once():
    walk = make_source(WALK, seed=SEED)
    for cfg in DLPF_SETTINGS:
        walk.set_dlpf(cfg)
        walk.read(2600)
    before = walk.computed_samples
    for cfg in [6, 1, 4, 0, 2, 5, 3] * 3:
        walk.set_dlpf(cfg)
        walk.read(2600 + cfg)
    assert walk.computed_samples == before


def _held_bytes(walk) -> int:
    """The bytes of the arrays the walk holds (in its attributes, their tuples and dicts)."""
    seen: dict[int, int] = {}
    todo = list(vars(walk).values())
    while todo:
        v = todo.pop()
        if isinstance(v, np.ndarray):
            seen[id(v)] = v.nbytes
        elif isinstance(v, (tuple, list)):
            todo.extend(v)
        elif isinstance(v, dict):
            todo.extend(v.values())
    return sum(seen.values())


def test_the_walk_holds_one_whole_record_whatever_settings_are_read():
    walk = make_source(WALK, seed=SEED)
    made = _held_bytes(walk)
    for cfg in DLPF_SETTINGS:
        walk.set_dlpf(cfg)
        for i in range(0, len(walk), 7):
            walk.read(i)
    blocks = 16 * walk.chunk_samples * 4 * 6 * 2  # int16 registers
    lead_ins = sum(walk.lead_in(cfg) for cfg in DLPF_SETTINGS) * 4 * 3 * 8 * 2  # float64 inputs
    assert _held_bytes(walk) - made <= blocks + lead_ins < 1_000_000
    assert walk.imu.nbytes * 7 > 1_000_000, "seven whole records would not fit in that"


def test_asking_for_the_whole_record_computes_it_at_the_current_setting(walk_records):
    walk = make_source(WALK, seed=SEED)
    walk.set_dlpf(5)
    before = walk.computed_samples
    assert np.array_equal(walk.imu, walk_records[5])
    assert walk.computed_samples - before == len(walk)
    walk.read(10)
    assert walk.computed_samples - before == len(walk), "read from the whole record now"
    walk.set_dlpf(0)
    assert np.array_equal(walk.read(4000).imu, walk_records[0][4000])


DELAYS_ONLY = replace(DEFAULT_CONFIG, dlpf=replace(DEFAULT_CONFIG.dlpf, delays_only=True))


@pytest.mark.parametrize("config", [SensorConfig.ideal(), DELAYS_ONLY], ids=["no-dlpf", "delays-only"])
def test_without_the_filters_smoothing_blocks_need_no_lead_in(config):
    records = whole_records(lambda: make_source("stand:1+walk:2+stand:1", seed=2, config=config))
    walk = make_source("stand:1+walk:2+stand:1", seed=2, config=config)
    for cfg in (6, 2):
        walk.set_dlpf(cfg)
        assert walk.lead_in(cfg) == 0
        before = walk.computed_samples
        assert np.array_equal(walk.read(2345).imu, records[cfg][2345])
        assert walk.computed_samples - before == walk.chunk_samples


def test_a_foot_at_a_low_rate_and_a_walk_shorter_than_the_lead_in():
    def foot():
        return make_foot_source("stand:1+walk:3+stand:1", "right", seed=9, walker_seed=4, rate_hz=200.0)

    records = whole_records(foot)
    walk = foot()
    assert walk.chunk_samples == 20
    for cfg in (6, 4, 1):
        walk.set_dlpf(cfg)
        read = np.stack([walk.read(i).imu for i in range(len(walk) - 1, -1, -1)])[::-1]
        assert np.array_equal(read, records[cfg])
    short = make_source("stand:0.5", seed=1)
    whole = make_source("stand:0.5", seed=1)
    whole.set_dlpf(6)
    short.set_dlpf(6)
    assert short.lead_in(6) > len(short)
    assert np.array_equal(np.stack([short.read(i).imu for i in range(len(short))]), whole.imu)
