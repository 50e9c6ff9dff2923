"""Step packets with the fusion set-up (protocol.extensions.FUSION_SETUP): DX, DP, STEP_COUNTER,
SWING_TIME, QUATERNION, three IMUs' magnetometers and the states the STATE_IF_SETUP frame's
checksum bytes name (protocol.md §9), as the host session decodes them
live and from a capture; plain 0x34 packets as before."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from hostlib.events import CommandAckEvent, PacketEvent, StepEvent, StepOutcome
from hostlib.files.replay import replay_bytes, replay_session
from hostlib.link.session import HostSession
from protocol.codec import STEP_IDS, encode_states, encode_step
from protocol.extensions import EXTENSION_STATES, FUSION_SETUP, fusion_step_ids
from protocol.frames import build_command, build_command_ack, build_packet_ack, build_state_packet
from protocol.ids import Command, StateId

from .loops import STANCE_STATES, fusion_capture, rectangle

DP_UPPER = (np.eye(4) * 1e-4)[np.triu_indices(4)]


def _fusion_session(**kw) -> HostSession:
    """A session that sent 0x34 and the fusion set-up, each acked by the module."""
    s = HostSession(**kw)
    for meaning, fields in ((Command.STEPWISE_DEAD_RECKONING, {}), *FUSION_SETUP):
        frame = s.encode_command(meaning, **fields)
        s.feed(build_command_ack(frame[0]))
    return s


def _values(counter: int, swing: float = 0.42, dx=(0.7, 0.1, -0.02, 0.05)) -> dict:
    return {**STANCE_STATES, StateId.T_INT_K: 123456, StateId.DX: np.array(dx), StateId.DP: DP_UPPER,
            StateId.STEP_COUNTER: counter, StateId.SWING_TIME: swing, 0x92: [-20, 50, -160]}


def _steps(events) -> list[StepEvent]:
    return [e for e in events if isinstance(e, StepEvent)]


def test_the_fusion_step_carries_the_states_the_checksum_bytes_name():
    meaning, fields = FUSION_SETUP[0]
    frame = build_command(meaning, **fields)
    assert frame.hex(" ") == "23 33 20 30 31 32 34 22 90 91 92 03 12"
    # the firmware copies 10 ids: the 8 given and 03 12, GP_DT and T_INT_K (the step's time)
    assert fusion_step_ids() == (StateId.GP_DT, StateId.T_INT_K, StateId.QUATERNION, StateId.DX, StateId.DP,
                                 StateId.STEP_COUNTER, StateId.SWING_TIME, 0x90, 0x91, 0x92)
    assert FUSION_SETUP[1][0] is Command.MCU_ID


def test_a_fusion_step_packet_decodes_with_its_swing_time():
    s = _fusion_session()
    payload = encode_states(fusion_step_ids(), _values(1))
    assert len(payload) == 104
    events, acks = s.feed(build_state_packet(1, payload))
    (packet,) = [e for e in events if isinstance(e, PacketEvent)]
    assert list(packet.states) == [0x03, 0x12, 0x22, 0x30, 0x31, 0x32, 0x34, 0x90, 0x91, 0x92]
    assert int(packet.states[StateId.T_INT_K]) == 123456
    np.testing.assert_array_equal(packet.states[0x92], [-20, 50, -160])
    (step,) = _steps(events)
    assert step.swing_time == np.float32(0.42)
    assert step.step.counter == 1 and step.step.dx[0] == np.float32(0.7)
    assert acks == build_packet_ack(1)
    np.testing.assert_array_equal(s.tracker.track.swing_times, [np.float32(0.42)])


def test_a_plain_step_packet_decodes_as_before_with_no_swing_time():
    plain = build_state_packet(1, encode_step(np.array([0.5, 0, 0, 0]), np.eye(4) * 1e-4, 1))
    for s in (HostSession(), _fusion_session()):
        events, acks = s.feed(plain)
        (step,) = _steps(events)
        assert math.isnan(step.swing_time) and step.step.dx[0] == 0.5
        assert acks == build_packet_ack(1)
        assert np.isnan(s.tracker.track.swing_times).all()


def test_a_module_without_the_extension_states_still_delivers_its_steps():
    """A real module has no SWING_TIME: its fusion packets lack those 4 bytes, which GP_DT, T_INT_K
    or SWING_TIME would fit alike; the session takes the module's own states."""
    s = _fusion_session()
    ids = [i for i in fusion_step_ids() if i not in EXTENSION_STATES]
    events, _ = s.feed(build_state_packet(1, encode_states(ids, _values(1))))
    (step,) = _steps(events)
    assert math.isnan(step.swing_time)
    assert int(events[0].states[StateId.T_INT_K]) == 123456
    assert s.stats.undecoded_packets == 0


def test_resent_fusion_packets_are_acked_again_and_summed_once():
    s = _fusion_session()
    pkt = build_state_packet(7, encode_states(fusion_step_ids(), _values(1)))
    first, ack1 = s.feed(pkt)
    again, ack2 = s.feed(pkt)
    assert ack1 == ack2 == build_packet_ack(7)
    assert len(_steps(first)) == 1 and _steps(again) == []
    assert s.stats.duplicate_packets == 1 and len(s.tracker.track) == 1


def test_the_serial_number_packet_tells_the_session_which_module_it_is():
    s = _fusion_session()
    assert s.mcu_serial is None
    s.feed(build_state_packet(1, encode_states([StateId.MCU_ID], {StateId.MCU_ID: b"OSEMU-M00000003"})))
    assert s.mcu_serial == b"OSEMU-M00000003"


def test_a_capture_replays_the_fusion_set_up_it_only_shows_the_acks_of():
    loop = rectangle((0.02, 0.0, 0.0))
    session = replay_session(fusion_capture(loop, b"OSEMU-M00000003"))
    assert session.mcu_serial == b"OSEMU-M00000003"
    assert session.stats.undecoded_packets == 0
    np.testing.assert_array_equal(session.tracker.track.swing_times, loop.swing)
    plain, _ = replay_bytes(fusion_capture(loop, None, with_setup=False))
    np.testing.assert_array_equal(plain.poses, session.tracker.track.poses)
    assert np.isnan(plain.swing_times).all()


def test_a_fusion_host_acks_in_the_order_it_sent():
    s = HostSession()
    sent = [s.encode_command(m, **f) for m, f in ((Command.STEPWISE_DEAD_RECKONING, {}), *FUSION_SETUP)]
    events, _ = s.feed(b"".join(build_command_ack(f[0]) for f in sent))
    assert [e.command_id for e in events if isinstance(e, CommandAckEvent)] == [0x34, 0x23, 0x04]
    assert s.plan.conditional == fusion_step_ids()


finite32 = st.floats(width=32, allow_nan=False, allow_infinity=False)


@settings(max_examples=200, deadline=None)
@given(dx=st.lists(finite32, min_size=4, max_size=4), dp=st.lists(finite32, min_size=10, max_size=10),
       counter=st.integers(0, 0xFFFF), swing=finite32, imu_ts=st.integers(0, 0xFFFFFFFF),
       number=st.integers(0, 0xFFFF))
def test_any_fusion_step_decodes_to_what_was_encoded(dx, dp, counter, swing, imu_ts, number):
    s = _fusion_session()
    s.tracker.restart_counter(None)  # any counter is the first one seen
    values = {**_values(counter), StateId.T_INT_K: imu_ts, StateId.DX: dx, StateId.DP: dp,
              StateId.SWING_TIME: swing}
    events, acks = s.feed(build_state_packet(number, encode_states(fusion_step_ids(), values)))
    (step,) = _steps(events)
    np.testing.assert_array_equal(step.step.dx, np.float32(dx))
    np.testing.assert_array_equal(step.step.dp_upper, np.float32(dp))
    assert step.step.counter == counter and step.packet_number == number
    assert step.swing_time == np.float32(swing)
    assert int(events[0].states[StateId.T_INT_K]) == imu_ts
    assert acks == build_packet_ack(number)
    if step.outcome is StepOutcome.REJECTED:  # a random dP is seldom a covariance: left out, said why
        assert "dP" in s.tracker.rejections[-1][1]
    else:
        assert s.tracker.track.swing_times[-1] == np.float32(swing)


def test_plain_step_ids_are_untouched_by_the_extensions():
    assert STEP_IDS == (0x30, 0x31, 0x32)
    assert HostSession().plan.layout(58) == STEP_IDS
