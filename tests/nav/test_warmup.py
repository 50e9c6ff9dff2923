"""Preparing the compiled tracking path: once per process, announced when slow, a safe fallback.

The announcement is driven by events, not by sleeping: the stand-in warm-up
waits (with a deadline) until the announcement has been made.
"""

from __future__ import annotations

import threading

import pytest

from firmware_sim.app.batch import run_replay
from firmware_sim.mcu.module import ModuleConfig
from firmware_sim.nav import fastpath, jit, warmup
from firmware_sim.nav.driver import TRACKING
from firmware_sim.nav.fastpath import FastNav
from firmware_sim.nav.firmware import OPENSHOE, build_module
from firmware_sim.sensors.imu_array import make_source
from firmware_sim.sensors.playback import served_source
from protocol.commands import CURRENT
from protocol.frames import build_command, checksum
from protocol.ids import Command
from protocol.states import STATES


@pytest.fixture
def fresh(monkeypatch):
    """A process in which nothing was prepared yet; restored afterwards."""
    monkeypatch.setattr(warmup, "_prepared", None)
    monkeypatch.setattr(warmup, "_fallback_said", False)
    monkeypatch.setattr(fastpath, "_disabled", "")
    yield


def test_a_slow_preparation_is_announced_while_it_runs_and_when_done(fresh, monkeypatch):
    if not fastpath.available():
        pytest.skip(f"compiled path unavailable here: {fastpath.reason_unavailable()}")
    monkeypatch.setattr(warmup, "ANNOUNCE_AFTER_S", 0.0)
    said: list[str] = []
    heard = threading.Event()

    def announce(text: str) -> None:
        said.append(text)
        heard.set()

    def slow_compile() -> None:
        assert heard.wait(10.0), "the notice comes while the compile still runs"

    found = warmup.prepare_compiled_path(announce, warm_up=slow_compile)
    assert found.compiled
    assert said[0] == warmup.FIRST_RUN_NOTICE
    assert said[1].startswith("compiled tracking path ready")


def test_a_quick_preparation_says_nothing_and_happens_once(fresh):
    said: list[str] = []
    calls: list[int] = []
    first = warmup.prepare_compiled_path(said.append, warm_up=lambda: calls.append(1))
    again = warmup.prepare_compiled_path(said.append, warm_up=lambda: calls.append(1))
    assert again is first
    assert said == []
    assert len(calls) == (1 if fastpath.available() else 0)


def test_a_failing_compile_falls_back_to_the_pure_path_and_says_so(fresh):
    if not fastpath.available():
        pytest.skip(f"compiled path unavailable here: {fastpath.reason_unavailable()}")
    module = build_module(ModuleConfig(compiled=True))
    said: list[str] = []

    def broken() -> None:
        raise RuntimeError("no LLVM today")

    found = warmup.prepare_compiled_path(said.append, warm_up=broken)
    assert not found.compiled and "no LLVM today" in found.reason
    warmup.prepare_module(module, said.append)
    warmup.prepare_module(build_module(ModuleConfig()), said.append)
    assert not module.compiled, "the module runs the pure reference instead"
    assert not build_module(ModuleConfig()).compiled, "and so do later modules of this process"
    assert len(said) == 1 and "pure-Python reference" in said[0] and "no LLVM today" in said[0]


def test_a_module_that_runs_pure_by_request_is_not_prepared(fresh):
    said: list[str] = []
    assert warmup.prepare_module(build_module(ModuleConfig(compiled=False)), said.append) is None
    assert said == []


def test_the_fallback_gives_the_same_bytes(fresh):
    """A module switched to the pure path mid-life sends exactly what the compiled one would."""
    source = make_source("stand:3+walk:4+stand:1", seed=3)
    reference = run_replay(source, config=ModuleConfig(compiled=False), announce=None)
    fastpath.disable("test")
    fallen_back = run_replay(make_source("stand:3+walk:4+stand:1", seed=3), announce=None)
    assert not fallen_back.module.compiled
    assert bytes(fallen_back) == bytes(reference)


# ----------------------------------------------------------------------------- no compile later

_FLOAT_STATES = [s.id for s in STATES.values() if s.dtype.kind == "f"]
_FILLS = (b"\x00", b"\xff", b"\x7f\x7f\xff\xff")  # zeros; NaN; the largest float32


def _set_state_command(size: int) -> Command:
    sizes = ((Command.SET_STATE_4, 4), (Command.SET_STATE_12, 12), (Command.SET_STATE_24, 24),
             (Command.SET_STATE_254, 254))
    return next(m for m, n in sizes if size <= n)


def _extreme_frames() -> list[bytes]:
    """Every command of the table with payloads of all zeros, all ones and the largest float; every
    float state set to those; every processing function put in slots 0, 5 and 10; both modes."""
    frames = []
    for spec in CURRENT.values():
        for fill in _FILLS:
            body = bytes([spec.wire_id]) + (fill * spec.payload_len)[:spec.payload_len]
            frames.append(body + checksum(body).to_bytes(2, "big"))
    for sid in _FLOAT_STATES:
        size = STATES[sid].size
        meaning = _set_state_command(size)
        for fill in _FILLS:
            frames.append(build_command(meaning, state_id=sid, data=(fill * size)[:size]))
    for pid in OPENSHOE.functions:
        for slot in (0, 5, 10):
            frames.append(build_command(Command.RUN_PROC, proc_id=pid, slot=slot))
    frames += [build_command(Command.RESET_ZUPT_AIDED_INS), build_command(Command.STEPWISE_DEAD_RECKONING)]
    return frames


def test_no_command_compiles_a_kernel_once_the_compiled_path_is_prepared():
    """After the preparation, a tracking module that receives any command with extreme payloads
    runs on without a kernel compiling (or loading) — nothing a host sends makes it wait on numba.
    Commands that keep the tracking sequence keep it compiled (no fall back to the pure path)."""
    if not fastpath.available():
        pytest.skip(f"compiled path unavailable here: {fastpath.reason_unavailable()}")
    assert warmup.prepare_compiled_path(None).compiled
    walk = make_source("stand:1+walk:2+stand:1", seed=5)
    before = jit.compilations()
    edits_sequence = {CURRENT.spec(m).wire_id for m in (
        Command.SETUP_DEBUG_PROC, Command.RUN_PROC, Command.RUN_MULT_PROC, Command.ALL_PROC_OFF,
        Command.MIMU_FRONTEND, Command.STORE_AND_EMPTY, Command.RESTORE_PROC_SEQU, Command.NORMAL_IMU,
        Command.NORMAL_IMU_WITH_BIAS_EST, Command.RESET_ZUPT_AIDED_INS, Command.STEPWISE_DEAD_RECKONING,
        Command.INPUT_IMU_RD)}
    for frame in _extreme_frames():
        module = build_module(ModuleConfig(compiled=True), served_source(walk))
        module.usb.port.host_write(build_command(Command.STEPWISE_DEAD_RECKONING))
        module.run(600)  # aligned: tracking
        assert FastNav.kind(module) == TRACKING
        module.usb.port.host_write(frame)
        module.run(400)
        module.usb.port.host_read()
        assert jit.compilations() == before, f"a kernel compiled after {frame.hex(' ')}"
        if frame[0] not in edits_sequence:
            assert FastNav.kind(module) == TRACKING, f"{frame.hex(' ')} left the compiled path"
