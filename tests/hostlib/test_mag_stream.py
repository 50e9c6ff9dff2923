"""The magnetometer stream of the in-situ calibration (protocol.extensions.MAG_STREAM_START/STOP):
its frames byte for byte, and how the host session tells its packets from the step packets —
live, and from a capture that shows only the module's acks of it."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from hostlib.events import PacketEvent, StepEvent
from hostlib.files.replay import implied_commands, replay_session
from hostlib.link.session import HostSession
from protocol.codec import encode_states
from protocol.extensions import (
    FUSION_SETUP,
    MAG_STREAM_RATE,
    MAG_STREAM_START,
    MAG_STREAM_STATES,
    MAG_STREAM_STOP,
    fusion_step_ids,
)
from protocol.frames import build_command, build_command_ack, build_state_packet
from protocol.ids import Command, OutputMode, StateId, rate_divider

from .loops import STANCE_STATES

DP_UPPER = (np.eye(4) * 1e-4)[np.triu_indices(4)]


def _h(text: str) -> bytes:
    return bytes.fromhex(text)


def _checksum(frame: bytes) -> bytes:
    """protocol.md §1: the 16-bit sum of the bytes before it, MSB first."""
    return (sum(frame) & 0xFFFF).to_bytes(2, "big")


def test_the_stream_frames_are_the_bytes_protocol_md_gives():
    # §3 OUTPUT_MULTIPLE_STATES 0x21: 8 state ids (0x00 = none), then the mode byte (§5)
    start = _h("21 22 90 91 92 00 00 00 00 05")
    stop = _h("21 22 90 91 92 00 00 00 00 10")
    assert _checksum(start) == _h("01 FB") and _checksum(stop) == _h("02 06")  # by hand: 0x1FB, 0x206
    (meaning, fields), = MAG_STREAM_START
    assert build_command(meaning, **fields) == start + _h("01 FB")
    (meaning, fields), = MAG_STREAM_STOP
    assert build_command(meaning, **fields) == stop + _h("02 06")


def test_the_stream_is_lossy_at_62_5_hz_and_its_stop_leaves_the_steps_lossless():
    (_, on), = MAG_STREAM_START
    (_, off), = MAG_STREAM_STOP
    assert 1000.0 / rate_divider(on["mode"]) == 62.5 and on["mode"] & OutputMode.RATE_MASK == MAG_STREAM_RATE
    assert not on["mode"] & OutputMode.LOSSLESS and not on["mode"] & OutputMode.PULL
    assert rate_divider(off["mode"]) == 0 and off["mode"] & OutputMode.LOSSLESS
    assert set(MAG_STREAM_STATES) < set(fusion_step_ids()), "a stream packet in a step's cycle is the step's"


def _stream_values(q=(0.01, -0.02, 0.3, 0.95), mags=((100, -50, 400), (90, -60, 410), (-98, 52, -405))):
    return {StateId.QUATERNION: np.array(q), **{0x90 + i: np.array(m) for i, m in enumerate(mags)}}


def _step_values(counter: int, dx=(0.7, 0.1, -0.02, 0.05)) -> dict:
    return {**STANCE_STATES, StateId.T_INT_K: 123456, StateId.DX: np.array(dx), StateId.DP: DP_UPPER,
            StateId.STEP_COUNTER: counter, StateId.SWING_TIME: 0.4}


def _calibrating_session() -> HostSession:
    """A session that sent 0x34, the fusion set-up and the stream's start, each acked."""
    s = HostSession()
    for meaning, fields in ((Command.STEPWISE_DEAD_RECKONING, {}), *FUSION_SETUP, *MAG_STREAM_START):
        s.feed(build_command_ack(s.encode_command(meaning, **fields)[0]))
    return s


def test_stream_packets_are_readings_and_a_step_in_their_cycle_is_one_step():
    s = _calibrating_session()
    assert s.plan.periodic == set(MAG_STREAM_STATES) and s.lossless is False
    events, acks = s.feed(build_state_packet(7, encode_states(MAG_STREAM_STATES, _stream_values())))
    (packet,) = events
    assert isinstance(packet, PacketEvent) and sorted(packet.states) == list(MAG_STREAM_STATES)
    np.testing.assert_array_equal(packet.states[0x92], [-98, 52, -405])
    assert acks == b"", "a lossy stream is not acked"
    step = build_state_packet(8, encode_states(fusion_step_ids(), _step_values(1)))
    events, acks = s.feed(step)
    assert [type(e) for e in events] == [PacketEvent, StepEvent] and acks, "steps are acked all the same"
    assert s.stats.undecoded_packets == 0


def test_after_the_stop_the_steps_still_carry_the_attitude_and_the_magnetometers():
    s = _calibrating_session()
    (meaning, fields), = MAG_STREAM_STOP
    s.feed(build_command_ack(s.encode_command(meaning, **fields)[0]))
    assert s.plan.periodic == frozenset() and s.lossless is True
    events, _ = s.feed(build_state_packet(9, encode_states(fusion_step_ids(), _step_values(1))))
    assert 0x22 in events[0].states and 0x92 in events[0].states and isinstance(events[1], StepEvent)


def test_a_capture_tells_the_stream_by_the_acks_of_the_commands_in_the_order_they_were_sent():
    stream = build_state_packet(3, encode_states(MAG_STREAM_STATES, _stream_values()))
    capture = b"".join([
        build_command_ack(0x34), build_command_ack(0x23), build_command_ack(0x04), build_command_ack(0x21),
        stream, build_state_packet(4, encode_states(fusion_step_ids(), _step_values(1))),
        build_state_packet(5, encode_states(MAG_STREAM_STATES, _stream_values())),
        build_command_ack(0x21), build_state_packet(6, encode_states(fusion_step_ids(), _step_values(2)))])
    assert [m for m, _ in implied_commands("2015")[0x21]] == [Command.OUTPUT_MULTIPLE_STATES] * 2
    session = replay_session(capture)
    assert session.stats.undecoded_packets == 0 and session.stats.steps == 2
    assert session.plan.periodic == frozenset(), "the second ack of 0x21 was the stop"
    # without the stream the same capture's steps are what they were
    setup = b"".join(build_command_ack(c) for c in (0x34, 0x23, 0x04))
    plain = replay_session(setup + build_state_packet(4, encode_states(fusion_step_ids(), _step_values(1))))
    assert plain.stats.steps == 1 and plain.plan.periodic == frozenset()


int16 = st.integers(-4095, 4095)
finite32 = st.floats(width=32, allow_nan=False, allow_infinity=False)


@settings(max_examples=200, deadline=None)
@given(q=st.lists(finite32, min_size=4, max_size=4), mags=st.lists(st.lists(int16, min_size=3, max_size=3),
                                                                      min_size=3, max_size=3),
       number=st.integers(0, 0xFFFF))
def test_any_stream_packet_decodes_to_what_was_encoded(q, mags, number):
    s = _calibrating_session()
    values = _stream_values(q, mags)
    events, _ = s.feed(build_state_packet(number, encode_states(MAG_STREAM_STATES, values)))
    (packet,) = events
    np.testing.assert_array_equal(packet.states[StateId.QUATERNION], np.float32(q))
    for i in range(3):
        np.testing.assert_array_equal(packet.states[0x90 + i], mags[i])
