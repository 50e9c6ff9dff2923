"""Payload codec: state order, the packet cap, typed values, and the step packet."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from protocol import STATES, StateId
from protocol.codec import (
    STEP_IDS,
    STEP_PAYLOAD_LEN,
    PayloadError,
    Step,
    assembly_order,
    decode_state,
    decode_states,
    decode_step,
    encode_state,
    encode_states,
    encode_step,
    fitting_ids,
    left_out_ids,
    payload_len,
)
from protocol.frames import MAX_PAYLOAD, build_state_packet, checksum, parse_state_packet

from . import golden as g

SETTINGS = settings(derandomize=True, deadline=None, max_examples=200)


def test_step_payload_is_dx_dp_counter_58_bytes():
    assert STEP_IDS == (0x30, 0x31, 0x32)
    assert STEP_PAYLOAD_LEN == 58 == g.STEP_PACKET[3]
    # 0x33 (filter reset flag) only triggers the output; it is not in the payload.
    assert payload_len([0x30, 0x31, 0x32, 0x33]) == 59


def test_golden_step_packet_decodes_and_encodes():
    payload = parse_state_packet(g.STEP_PACKET).payload
    step = decode_step(payload)
    assert step.counter == 1
    np.testing.assert_array_equal(step.dx, g.STEP_DX)
    np.testing.assert_array_equal(step.dp, g.STEP_DP)
    assert step.dx.dtype == np.float32 and step.dp.dtype == np.float32
    assert encode_step(g.STEP_DX, g.STEP_DP, 1) == payload
    assert build_state_packet(1, encode_step(step)) == g.STEP_PACKET


def test_real_captured_step_packet_decodes():
    pkt = parse_state_packet(g.REAL_STEP_PACKET)
    step = decode_step(pkt.payload)
    assert (pkt.number, step.counter) == (1, 1)
    assert checksum(g.REAL_STEP_PACKET[:-2]) == 0x1B6D
    np.testing.assert_allclose(step.dx, g.REAL_STEP_DX, rtol=5e-3)
    assert np.allclose(step.dp, step.dp.T)
    assert np.all(np.diag(step.dp) > 0)
    assert build_state_packet(1, encode_step(step)) == g.REAL_STEP_PACKET


def test_states_are_assembled_ascending_once_and_unknown_ids_skipped():
    assert assembly_order([0x32, 0x30, 0x06, 0x31, 0x30, 0xB0, 0xFF]) == [0x30, 0x31, 0x32]
    values = {0x01: 7, 0x17: True, 0x14: 0.01}
    payload = encode_states([0x17, 0x01, 0x14, 0x01, 0x07], values)
    assert payload == bytes.fromhex("00000007") + np.array(0.01, ">f4").tobytes() + b"\x01"
    out = decode_states([0x14, 0x17, 0x01], payload)
    assert list(out) == [0x01, 0x14, 0x17]
    assert out[0x01] == 7 and out[0x01].dtype == np.dtype("=u4") and out[0x01].shape == ()
    assert out[0x17].dtype == np.bool_ and bool(out[0x17])


def test_packet_cap_leaves_out_states_that_would_overflow():
    # P 180 + U_NEW, U_INT_K, U_K 3×24 + POSITION, VELOCITY 2×12 + QUATERNION 16 = 292 bytes,
    # then 12-byte raw IMU states: 17 fit (496), the 18th would make 508 > 506 and is left out,
    # as are the rest; then 2-byte temperatures still fit up to exactly 506.
    raw = list(range(0x40, 0x60))
    temps = list(range(0x60, 0x68))
    ids = [0x23, 0x10, 0x11, 0x13, 0x20, 0x21, 0x22, *raw, *temps]
    fit = fitting_ids(ids)
    assert fit == [0x10, 0x11, 0x13, 0x20, 0x21, 0x22, 0x23, *raw[:17], *temps[:5]]
    assert left_out_ids(ids) == [*raw[17:], *temps[5:]]
    assert payload_len(ids) == MAX_PAYLOAD == 506
    values = {sid: np.zeros(STATES[sid].shape) for sid in ids}
    assert len(build_state_packet(1, encode_states(ids, values))) == 512


def test_decode_refuses_a_payload_of_the_wrong_length():
    with pytest.raises(PayloadError, match="must be 58 bytes, got 57"):
        decode_states(STEP_IDS, bytes(57))
    with pytest.raises(PayloadError, match="58 bytes"):
        decode_step(bytes(59))


def test_encode_refuses_values_that_do_not_fit():
    with pytest.raises(ValueError, match="shape"):
        encode_state(StateId.DX, [1.0, 2.0])
    with pytest.raises(ValueError, match="does not fit"):
        encode_state(StateId.STEP_COUNTER, 70000)
    with pytest.raises(KeyError, match="0x32"):
        encode_states(STEP_IDS, {0x30: np.zeros(4), 0x31: np.zeros(10)})
    with pytest.raises(KeyError, match="0x06"):
        decode_state(0x06, b"")


def test_mcu_id_takes_raw_bytes():
    serial = bytes(range(15))
    assert encode_state(StateId.MCU_ID, serial) == serial
    assert decode_state(StateId.MCU_ID, serial).tobytes() == serial


def test_step_dp_is_symmetric_from_the_upper_triangle():
    tri = np.arange(1, 11, dtype=np.float32)
    step = Step(dx=np.zeros(4), dp=tri, counter=3)
    assert np.array_equal(step.dp, step.dp.T)
    assert step.dp[0, 1] == 2 and step.dp[1, 0] == 2 and step.dp[3, 3] == 10
    np.testing.assert_array_equal(step.dp_upper, tri)
    assert not step.dx.flags.writeable
    with pytest.raises(ValueError):
        Step(dx=np.zeros(4), dp=np.zeros(3), counter=0)
    with pytest.raises(ValueError):
        Step(dx=np.zeros(4), dp=np.zeros(10), counter=1 << 16)


def _state_value(spec):
    n = int(np.prod(spec.shape, dtype=np.int64))
    dt = spec.dtype
    if dt.kind == "f":
        elem = st.floats(width=32, allow_nan=False)
    elif dt.kind == "b":
        elem = st.booleans()
    else:
        info = np.iinfo(dt)
        elem = st.integers(int(info.min), int(info.max))
    return st.lists(elem, min_size=n, max_size=n).map(lambda v: np.array(v).reshape(spec.shape))


@SETTINGS
@given(st.sampled_from(sorted(STATES)).flatmap(lambda s: st.tuples(st.just(s), _state_value(STATES[s]))))
def test_every_state_round_trips(sid_value):
    sid, value = sid_value
    spec = STATES[sid]
    data = encode_state(sid, value)
    assert len(data) == spec.size
    back = decode_state(sid, data)
    assert back.shape == spec.shape and back.dtype == spec.native_dtype
    np.testing.assert_array_equal(back, value.astype(spec.dtype))
    # big-endian on the wire
    assert data == np.asarray(value).astype(spec.dtype).tobytes()


@st.composite
def id_sets_with_values(draw):
    ids = draw(st.lists(st.integers(0, 0xFF), max_size=40))
    values = {sid: draw(_state_value(STATES[sid])) for sid in set(ids) if sid in STATES}
    return ids, values


@SETTINGS
@given(id_sets_with_values())
def test_any_requested_set_round_trips_through_a_packet(ids_values):
    ids, values = ids_values
    payload = encode_states(ids, values)
    assert len(payload) <= MAX_PAYLOAD
    frame = build_state_packet(9, payload)
    out = decode_states(list(reversed(ids)), parse_state_packet(frame).payload)
    assert list(out) == fitting_ids(ids)
    for sid, v in out.items():
        np.testing.assert_array_equal(v, values[sid].astype(STATES[sid].dtype))


@SETTINGS
@given(
    st.lists(st.floats(width=32, allow_nan=False), min_size=4, max_size=4),
    st.lists(st.floats(width=32, allow_nan=False), min_size=10, max_size=10),
    st.integers(0, 0xFFFF),
)
def test_step_round_trips(dx, tri, counter):
    step = Step(dx=dx, dp=tri, counter=counter)
    payload = encode_step(step)
    assert len(payload) == STEP_PAYLOAD_LEN
    assert decode_step(payload) == step
