"""A module paced against a host computes nothing long while its clock runs, whatever the host sends.

SET_IMU_BANDWIDTH changes the MPU9150s' low-pass filter; a simulated walk recomputes its
whole record of registers for it (about a second for a few minutes of walking). A served
walk has every bandwidth's registers computed before the clock starts, so the command only
picks one: the test counts the recomputations (none once prepared) and checks the registers
against the walk's own, in virtual time.
"""

from __future__ import annotations

import numpy as np
import pytest

from firmware_sim.mcu.imu_bus import DLPF_SETTINGS, PreparedBandwidths, prepare_sensors
from firmware_sim.nav.firmware import build_module
from firmware_sim.sensors.imu_array import make_source
from firmware_sim.transports.factory import make_sensors
from firmware_sim.transports.pacer import Pacer
from protocol.ids import Command

from .emu import Host

WALK = "stand:1+walk:3+stand:1"
SEED = 3


def _served_walk():
    """A served walk, and the PreparedBandwidths inside it."""
    served = make_sensors(WALK, SEED, 1000.0)
    inner = served
    while not isinstance(inner, PreparedBandwidths):
        inner = inner.source
    return served, inner


def _count_recomputations(monkeypatch, walk) -> list[int]:
    """The settings the simulated walk itself is asked to recompute its registers for."""
    asked: list[int] = []
    recompute = walk.set_dlpf

    def counted(cfg: int) -> None:
        asked.append(cfg)
        recompute(cfg)

    monkeypatch.setattr(walk, "set_dlpf", counted)
    return asked


@pytest.fixture(scope="module")
def registers_by_setting() -> dict[int, np.ndarray]:
    """The walk's registers at every DLPF setting, as the simulated source computes them."""
    walk = make_source(WALK, seed=SEED)
    out = {}
    for cfg in DLPF_SETTINGS:
        walk.set_dlpf(cfg)
        out[cfg] = walk.imu
    return out


def test_a_prepared_walk_recomputes_nothing_for_any_bandwidth_a_host_sets(monkeypatch, registers_by_setting):
    served, prepared = _served_walk()
    assert prepare_sensors(served) == 1 and prepared.prepared
    asked = _count_recomputations(monkeypatch, prepared.source)
    h = Host(build_module(sensors=served))
    h.command(Command.STEPWISE_DEAD_RECKONING)
    h.step(50)
    for cfg in (3, 0, 6, 7, 255, 1, 1, 5, 2, 4):
        h.command(Command.SET_IMU_BANDWIDTH, dlpf_cfg=cfg)
        out = h.step()
        assert bytes.fromhex("A0 29") in out, "answered in the loop that received it"
        expected = cfg if cfg < 7 else h.module.dlpf_cfg
        assert h.module.dlpf_cfg == expected and prepared.dlpf_cfg == expected
        # the registers the module now reads are the walk's own at that setting
        index = h.module.clock.sample_index - served.source.start
        assert np.array_equal(prepared.read(index).imu, registers_by_setting[expected][index])
        h.step(20)
    assert asked == [], "the walk recomputed its registers while the clock ran"
    assert np.array_equal(prepared.source.imu, registers_by_setting[0]), "the walk itself is left as it was"


def test_every_prepared_setting_is_the_walks_own_bit_for_bit(registers_by_setting):
    served, prepared = _served_walk()
    prepare_sensors(served)
    for cfg in DLPF_SETTINGS:
        prepared.set_dlpf(cfg)
        assert np.array_equal(prepared.imu, registers_by_setting[cfg]), cfg
        sample = prepared.read(1234)
        assert np.array_equal(sample.imu, registers_by_setting[cfg][1234])
        assert np.array_equal(sample.mag, prepared.source.mag[1234])
    with pytest.raises(ValueError, match="0..6"):
        prepared.set_dlpf(7)


def test_unprepared_the_walk_recomputes_as_it_always_did(monkeypatch, registers_by_setting):
    """In virtual time (nothing prepared) no host waits on the recomputation: it happens at once."""
    served, prepared = _served_walk()
    asked = _count_recomputations(monkeypatch, prepared.source)
    h = Host(build_module(sensors=served))
    h.command(Command.SET_IMU_BANDWIDTH, dlpf_cfg=6)
    h.step()
    assert asked == [6] and not prepared.prepared
    assert np.array_equal(prepared.imu, registers_by_setting[6])


def test_the_real_time_pacer_prepares_the_walk_before_its_clock_starts(monkeypatch):
    served, prepared = _served_walk()
    module = build_module(sensors=served)
    said: list[str] = []
    monkeypatch.setattr("firmware_sim.transports.pacer.group.SENSORS_ANNOUNCED_AFTER_S", -1.0)
    pacer = Pacer(module, [], speed=1.0)
    pacer.group.prepare(said.append)  # what start() does before the loop's thread runs
    assert prepared.prepared and module.clock.ticks == 0
    assert any("every bandwidth setting" in s for s in said)
    before = len(said)
    pacer.group.prepare(said.append)
    assert len(said) == before, "prepared once per loop"


def test_a_served_walk_is_still_the_walk_to_whoever_looks_inside():
    served, prepared = _served_walk()
    walk = prepared.source
    assert prepared.truth is walk.truth and prepared.chips is walk.chips and prepared.seed == SEED
    assert served.sensor == walk.sensor == "mimu22bt" and len(prepared) == len(walk)
