"""Preparing the compiled tracking path: once per process, announced when slow, a safe fallback.

The announcement is driven by events, not by sleeping: the stand-in warm-up
waits (with a deadline) until the announcement has been made.
"""

from __future__ import annotations

import threading

import pytest

from firmware_sim.app.batch import run_replay
from firmware_sim.mcu.module import ModuleConfig
from firmware_sim.nav import fastpath, warmup
from firmware_sim.nav.firmware import build_module
from firmware_sim.sensors.imu_array import make_source


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
