"""A module paced against a host computes nothing long while its clock runs, whatever the host sends.

SET_IMU_BANDWIDTH changes the MPU9150s' low-pass filter. A served walk computes nothing when
the command runs: the new setting's registers are computed as the module reads them, one block
and the filter's lead-in at a time, and nothing is computed ahead before the clock starts. The
tests count the samples the walk computes (not wall time) and check every register the module
read against the whole walk computed at that setting, bit for bit, in virtual time.
"""

from __future__ import annotations

import numpy as np
import pytest

from firmware_sim.mcu.imu_bus import DLPF_SETTINGS
from firmware_sim.nav.firmware import build_module
from firmware_sim.sensors.imu_array import SimulatedSource, make_source
from firmware_sim.transports.factory import make_sensors
from firmware_sim.transports.pacer import Pacer
from protocol.ids import Command

from .emu import Host, split_frames

WALK = "stand:1+walk:8+stand:1"
SEED = 3
#: What a host sends, in order: every setting, then values the firmware ignores, then more.
SETTINGS_SENT = (3, 0, 6, 7, 255, 1, 1, 5, 2, 4, 6, 0)


def _served_walk():
    """A served walk (as ``serve`` makes it) and the simulated walk inside it."""
    served = make_sensors(WALK, SEED, 1000.0)
    walk = served.source.source
    assert isinstance(walk, SimulatedSource)
    return served, walk


def _record_reads(monkeypatch, walk) -> dict[int, tuple[int, np.ndarray]]:
    """Every register sample the module reads from *walk*: walk index → (setting, registers)."""
    seen: dict[int, tuple[int, np.ndarray]] = {}
    read, block = walk.read, walk.imu_block

    def recorded_read(index: int):
        sample = read(index)
        if sample is not None:
            seen[index] = (walk.dlpf_cfg, sample.imu.copy())
        return sample

    def recorded_block(start: int, n: int):
        imu = block(start, n)
        if imu is not None:
            for i, row in enumerate(imu):
                seen[start + i] = (walk.dlpf_cfg, row.copy())
        return imu

    monkeypatch.setattr(walk, "read", recorded_read)
    monkeypatch.setattr(walk, "imu_block", recorded_block)
    return seen


@pytest.fixture(scope="module")
def registers_by_setting() -> dict[int, np.ndarray]:
    """The walk's whole record of registers at every DLPF setting, each computed in one go."""
    out = {}
    for cfg in DLPF_SETTINGS:
        walk = make_source(WALK, seed=SEED)
        walk.set_dlpf(cfg)
        out[cfg] = walk.imu
    return out


def test_a_bandwidth_change_costs_at_most_one_block_and_the_module_reads_the_walks_own_registers(
        monkeypatch, registers_by_setting):
    served, walk = _served_walk()
    made = walk.computed_samples
    assert made == len(walk), "made: the power-on setting's registers, nothing more"
    seen = _record_reads(monkeypatch, walk)
    set_dlpf = walk.set_dlpf
    in_handler: list[int] = []

    def counted(cfg: int) -> None:
        before = walk.computed_samples
        set_dlpf(cfg)
        in_handler.append(walk.computed_samples - before)

    monkeypatch.setattr(walk, "set_dlpf", counted)
    h = Host(build_module(sensors=served))
    h.command(Command.STEPWISE_DEAD_RECKONING)
    h.step(50)
    block, worst = walk.chunk_samples, 0
    for cfg in SETTINGS_SENT:
        h.command(Command.SET_IMU_BANDWIDTH, dlpf_cfg=cfg)
        for loop in range(300):  # loop by loop: what each main loop computed
            before = walk.computed_samples
            out = h.step()
            computed = walk.computed_samples - before
            worst = max(worst, computed)
            assert computed <= block + walk.lead_in(walk.dlpf_cfg), f"a loop computed {computed} samples"
            for frame in split_frames(out):
                if frame[0] == 0xAA:  # a step packet: the host acknowledges it
                    h.ack(int.from_bytes(frame[1:3], "big"))
            if loop == 0:
                assert bytes.fromhex("A0 29") in out, "answered in the loop that received it"
                expected = cfg if cfg < 7 else h.module.dlpf_cfg
                assert h.module.dlpf_cfg == expected and walk.dlpf_cfg == expected
    assert in_handler == [0] * len([c for c in SETTINGS_SENT if c < 7]), "the command computed nothing"
    assert 0 < worst <= block + 2047 < len(walk) // 2
    # every register the module read is the whole walk's at the setting it was read at
    assert len(seen) > 3000 and {cfg for cfg, _ in seen.values()} == set(DLPF_SETTINGS)
    for index, (cfg, imu) in seen.items():
        assert np.array_equal(imu, registers_by_setting[cfg][index]), (index, cfg)
    # the whole run: no more than the blocks the module read, each with its lead-in at most
    blocks_read = len({(cfg, i // block) for i, (cfg, _) in seen.items() if cfg != 0})
    assert walk.computed_samples - made <= blocks_read * (block + 2047)


def test_a_served_module_reads_in_blocks_on_the_compiled_path_too(monkeypatch, registers_by_setting):
    """Many loops at a time (Module.advance: the quiet loops in one compiled call) end at a block's
    end: a call never gets more registers than one block at a setting other than the walk's own."""
    served, walk = _served_walk()
    seen = _record_reads(monkeypatch, walk)
    module = build_module(sensors=served)
    h = Host(module)
    h.command(Command.STEPWISE_DEAD_RECKONING)
    h.step(50)
    h.command(Command.SET_IMU_BANDWIDTH, dlpf_cfg=5)
    h.step()
    while module.clock.ticks < 6000:
        before = walk.computed_samples
        module.advance(2000)
        assert walk.computed_samples - before <= walk.chunk_samples + walk.lead_in(5)
    h.port.host_read()
    for index, (cfg, imu) in seen.items():
        assert np.array_equal(imu, registers_by_setting[cfg][index]), (index, cfg)


def test_the_real_time_pacer_computes_no_registers_before_its_clock_starts():
    served, walk = _served_walk()
    module = build_module(sensors=served)
    said: list[str] = []
    before = walk.computed_samples
    pacer = Pacer(module, [], speed=1.0)
    pacer.group.prepare(said.append)  # what start() does before the loop's thread runs
    assert walk.computed_samples == before and module.clock.ticks == 0
    assert not any("bandwidth" in s for s in said)


def test_a_served_walk_is_the_walk_itself_to_whoever_looks_inside():
    served, walk = _served_walk()
    assert served.sensor == walk.sensor == "mimu22bt" and walk.seed == SEED and len(walk.truth) == len(walk)
