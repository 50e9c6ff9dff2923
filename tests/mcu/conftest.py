"""Fixtures of the firmware core tests."""

from __future__ import annotations

import pytest

from firmware_sim.mcu.sequence import processing_function
from firmware_sim.nav import firmware


@pytest.fixture
def temp_functions(monkeypatch):
    """Link throw-away processing functions (ids 0x28..0x2F) into the tracking firmware that
    modules built during one test run (``build_module()``, the test host)."""

    def link(proc_id: int, fn, cycles: int = 100):
        assert 0x28 <= proc_id <= 0x2F and proc_id not in firmware.OPENSHOE.functions
        processing_function(proc_id, cycles=cycles)(fn)
        monkeypatch.setattr(firmware, "OPENSHOE", firmware.OPENSHOE.with_functions(fn))
        return fn

    return link
