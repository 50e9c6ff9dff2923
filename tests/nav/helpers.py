"""Shared helpers of the navigation tests: run the module on a source, sum the steps from the wire."""

from __future__ import annotations

import dataclasses

import numpy as np

from firmware_sim.app.batch import run_replay
from firmware_sim.mcu.module import ModuleConfig
from hostlib.tracking import StepTracker
from protocol.codec import decode_step
from protocol.frames import CommandAck, StatePacket
from protocol.stream import decode_all


def reference_config(rate_hz: float) -> ModuleConfig:
    """A module config running the pure-Python processing functions (the reference path)."""
    config = ModuleConfig(rate_hz=rate_hz)
    if any(f.name == "compiled" for f in dataclasses.fields(ModuleConfig)):
        config = dataclasses.replace(config, compiled=False)
    return config


def steps_from_wire(data: bytes) -> tuple[list[CommandAck], StepTracker]:
    """Decode the module's Bluetooth bytes and sum the step packets as a host would."""
    tracker = StepTracker()
    acks = []
    for frame in decode_all(bytes(data)):
        if isinstance(frame, StatePacket):
            tracker.add(decode_step(frame.payload))
        else:
            acks.append(frame)
    return acks, tracker


def replay_track(source, rate_hz: float | None = None) -> tuple[bytes, StepTracker]:
    data = run_replay(source, config=reference_config(rate_hz or float(source.rate_hz)))
    return data, steps_from_wire(data)[1]


def closure_percent(tracker: StepTracker) -> float:
    """Horizontal closure error as % of the distance walked (sum of horizontal step lengths)."""
    return float(np.hypot(*tracker.position[:2])) / tracker.distance * 100.0
