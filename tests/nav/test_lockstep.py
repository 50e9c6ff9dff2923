"""K modules stepped in lockstep — their quiet stretches in one compiled call — send and hold exactly
what each sends and holds alone: for K = 1, 3 and 64 walks, every module's wire bytes and states."""

from __future__ import annotations

import numpy as np
import pytest

from firmware_sim.app.batch import run_replay, start_replay
from firmware_sim.app.replay_group import run_replays
from firmware_sim.mcu.module import ModuleConfig
from firmware_sim.nav import fastpath
from firmware_sim.nav.lockstep import Lockstep
from firmware_sim.sensors.imu_array import make_source
from firmware_sim.sensors.replay import ReplaySource
from tests.conftest import requires_walks, walk_path

needs_compiled = pytest.mark.skipif(not fastpath.available(),
                                    reason=f"compiled path unavailable: {fastpath.reason_unavailable()}")


class WalkSlice:
    """Samples *start* … *start* + *length* − 1 of a recorded walk, as a walk of their own."""

    def __init__(self, walk: ReplaySource, start: int, length: int):
        self.walk, self.start, self.length = walk, start, length
        self.rate_hz = walk.rate_hz

    def __len__(self) -> int:
        return self.length

    def read(self, index: int):
        return self.walk.read(self.start + index) if index < self.length else None

    def imu_block(self, start: int, n: int) -> np.ndarray:
        return self.walk.imu[self.start + start:self.start + min(start + n, self.length)]

    def set_dlpf(self, cfg: int) -> None:
        self.walk.set_dlpf(cfg)


@pytest.fixture(scope="module")
def walk():
    return ReplaySource.from_file(walk_path("2"))


def slices(walk: ReplaySource, k: int) -> list[WalkSlice]:
    """*k* short walks: each starts in the first seconds of standing and walks 8 to 20 s."""
    return [WalkSlice(walk, (37 * i) % 400, 2000 + (97 * i) % 3000) for i in range(k)]


def together(sources, **options):
    """The replays of *sources* run in lockstep: (bytes, every state) of each."""
    hosts = [start_replay(s, config=ModuleConfig(rate_hz=s.rate_hz, **options), announce=None)
             for s in sources]
    return [(bytes(r), r.module.memory.arena.tobytes()) for r in run_replays(hosts)]


def alone(source, **options):
    r = run_replay(source, config=ModuleConfig(rate_hz=source.rate_hz, **options), announce=None)
    return bytes(r), r.module.memory.arena.tobytes()


@requires_walks
@needs_compiled
@pytest.mark.parametrize("k", [1, 3, 64])
def test_walks_replayed_in_lockstep_send_and_hold_what_each_does_alone(walk, k):
    sources = slices(walk, k)
    got = together(sources, compiled=True)
    for i, source in enumerate(sources):
        wire, states = alone(source, compiled=True)
        assert len(got[i][0]) > 100, "the slice tracked steps"
        assert got[i][0] == wire, f"walk {i} of {k}: the wire bytes"
        assert got[i][1] == states, f"walk {i} of {k}: every state"


@needs_compiled
def test_one_compiled_call_runs_the_quiet_stretches_of_all_the_modules():
    sources = [make_source("stand:2+walk:3", seed=s, rate_hz=250.0) for s in range(4)]
    hosts = [start_replay(s, config=ModuleConfig(rate_hz=250.0, compiled=True), announce=None)
             for s in sources]
    group = Lockstep([h.module for h in hosts])
    while not group.calls:  # the first loops receive the start command, loop by loop
        ran = group.advance(5000)
        for host, n in zip(hosts, ran, strict=True):
            host.after_loops(n)
    assert group.calls == 1 and group.stretches == 4
    assert all(n > 1 for n in ran), "each module ran its first quiet stretch"
    assert [h.module.clock.ticks for h in hosts] == [h.ticks for h in hosts]


@needs_compiled
@pytest.mark.parametrize("round_loops", [5000, 40], ids=["long rounds", "a frame's rounds"])
def test_short_and_long_stretches_send_and_hold_what_each_module_does_alone(round_loops):
    """Long stretches' registers are passed where they are, short ones (a served module's frame)
    copied into one block first: the same bytes and states either way."""
    sources = [make_source("stand:2+walk:4", seed=s, rate_hz=250.0) for s in range(3)]
    hosts = [start_replay(s, config=ModuleConfig(rate_hz=250.0, compiled=True), announce=None)
             for s in sources]
    group = Lockstep([h.module for h in hosts])
    while loops := [h.source_loops(len(s), round_loops) for h, s in zip(hosts, sources, strict=True)]:
        if not any(loops):
            break
        for host, ran in zip(hosts, group.advance(loops), strict=True):
            host.after_loops(ran)
    assert group.calls > 0
    for source, host in zip(sources, hosts, strict=True):
        host.drain()
        expect = run_replay(source, config=ModuleConfig(rate_hz=250.0, compiled=True), announce=None)
        assert bytes(host.result()) == bytes(expect)
        assert host.module.memory.arena.tobytes() == expect.module.memory.arena.tobytes()


@needs_compiled
def test_lockstep_keeps_the_bytes_of_the_fusion_host_with_height_compensation():
    """Alignment, tracking with HEIGHT_COMPENSATION after the step output, and the extensions' commands."""
    sources = [make_source("stand:3+walk:4+stairs_up:4+stand:2", seed=s, rate_hz=500.0) for s in range(3)]
    options = {"host": "fusion", "height_compensation": True}
    hosts = [start_replay(s, config=ModuleConfig(rate_hz=500.0, compiled=True), announce=None, **options)
             for s in sources]
    for source, result in zip(sources, run_replays(hosts), strict=True):
        config = ModuleConfig(rate_hz=500.0, compiled=True)
        expect = run_replay(source, config=config, announce=None, **options)
        assert bytes(result) == bytes(expect)
        assert result.module.memory.arena.tobytes() == expect.module.memory.arena.tobytes()


def test_pure_modules_in_lockstep_run_loop_by_loop_with_the_same_bytes():
    sources = [make_source("stand:2+walk:1", seed=s, rate_hz=100.0) for s in range(2)]
    hosts = [start_replay(s, config=ModuleConfig(rate_hz=100.0, compiled=False), announce=None)
             for s in sources]
    for source, result in zip(sources, run_replays(hosts), strict=True):
        assert bytes(result) == bytes(run_replay(source, config=ModuleConfig(rate_hz=100.0, compiled=False),
                                                 announce=None))
