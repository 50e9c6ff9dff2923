"""The events a host receives: one module declares them, the package exports them, all are frozen."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import hostlib
import hostlib.events
from hostlib.link.session import HostSession
from protocol.codec import encode_step
from protocol.frames import build_command_ack, build_state_packet

EVENT_TYPES = ["CommandAckEvent", "PacketEvent", "StepEvent", "GapEvent", "LinkEvent"]


@pytest.mark.parametrize("name", EVENT_TYPES)
def test_every_event_type_is_importable_from_hostlib_and_is_the_one_declared_in_events(name):
    assert name in hostlib.__all__
    assert getattr(hostlib, name) is getattr(hostlib.events, name)
    cls = getattr(hostlib, name)
    assert dataclasses.is_dataclass(cls) and cls.__dataclass_params__.frozen
    assert cls.__doc__ and cls.__module__ == "hostlib.events"


def test_every_name_hostlib_exports_resolves():
    for name in hostlib.__all__:
        assert getattr(hostlib, name) is not None, name


def test_events_cannot_be_changed_after_they_are_made():
    with pytest.raises(dataclasses.FrozenInstanceError):
        hostlib.LinkEvent(True).up = False  # type: ignore[misc]


def test_a_session_reports_the_exported_event_types():
    session = HostSession()
    session.encode_command("STEPWISE_DEAD_RECKONING")
    step = build_state_packet(1, encode_step(np.array([0.7, 0, 0, 0]), np.eye(4) * 1e-4, 1))
    gap_step = build_state_packet(2, encode_step(np.array([0.7, 0, 0, 0]), np.eye(4) * 1e-4, 3))
    events, _ = session.feed(build_command_ack(0x34) + step + gap_step)
    assert [type(e) for e in events] == [
        hostlib.CommandAckEvent, hostlib.PacketEvent, hostlib.StepEvent,
        hostlib.PacketEvent, hostlib.GapEvent, hostlib.StepEvent,
    ]
    assert all(isinstance(e, hostlib.StreamEvent) for e in events)
    assert isinstance(hostlib.LinkEvent(False, OSError("gone")), hostlib.Event)
    assert events[2].outcome is hostlib.StepOutcome.SUMMED
    assert events[5].outcome is hostlib.StepOutcome.SUMMED_AFTER_GAP
