"""Fixtures of the firmware core tests."""

from __future__ import annotations

import pytest

from firmware_sim.sequence import PROCESSING_FUNCTIONS, processing_function


@pytest.fixture
def temp_functions():
    """Register throw-away processing functions (ids 0x28..0x2F) for one test."""
    added: list[int] = []

    def register(proc_id: int, fn, cycles: int = 100):
        assert 0x28 <= proc_id <= 0x2F and proc_id not in PROCESSING_FUNCTIONS
        processing_function(proc_id, cycles=cycles)(fn)
        added.append(proc_id)
        return fn

    yield register
    for pid in added:
        PROCESSING_FUNCTIONS.pop(pid, None)
