"""HostSession: the I/O-free host protocol (decode, ack, dedupe, steps, gaps) byte by byte."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from hostlib.errors import NotSupportedByCommandSet
from hostlib.events import CommandAckEvent, GapEvent, PacketEvent, StepEvent, StepOutcome
from hostlib.link.outputs import OutputPlan, match_layout
from hostlib.link.session import HostSession
from protocol.codec import Step, encode_states, encode_step
from protocol.frames import build_command_ack, build_packet_ack, build_state_packet
from protocol.ids import Command, OutputMode, StateId
from protocol.states import STATES
from protocol.stream import decode_all

GOLDEN_STEP = bytes.fromhex(
    "AA 00 01 3A 3F 00 00 00 3C 23 D7 0A BB 03 12 6F 3C 8E 8A 72 38 D1 B7 17"
    "00 00 00 00 00 00 00 00 00 00 00 00 38 D1 B7 17 00 00 00 00 00 00 00 00"
    "38 D1 B7 17 00 00 00 00 37 27 C5 AC 00 01 0C BE"
)
REAL_STEP = bytes.fromhex(
    "AA 00 01 3A 37 E2 67 6E 34 C5 83 52 B9 FE B0 52 39 80 BE 5B 37 1D D7 64"
    "A8 C2 93 F8 AB ED 34 F3 2E 4D 0E A5 37 1D D7 65 AC A8 B1 A0 AF 22 71 18"
    "37 1D 9D 6D 29 54 78 20 36 5E 8D AC 00 01 1B 6D"
)


def started(**kw) -> HostSession:
    s = HostSession(**kw)
    assert s.encode_command(Command.STEPWISE_DEAD_RECKONING) == bytes.fromhex("34 00 34")
    events, out = s.feed(build_command_ack(0x34))
    assert events == [CommandAckEvent(0x34)] and out == b""
    return s


def step_packet(number: int, counter: int, dx=(0.5, 0.01, -0.002, 0.0174)) -> bytes:
    dp = np.diag([1e-4, 1e-4, 1e-4, 1e-5])
    return build_state_packet(number, encode_step(np.array(dx), dp, counter))


# -- golden bytes from protocol.md -----------------------------------------------------------


def test_golden_step_packet_is_summed_and_acked_with_01_00_01_00_02():
    s = started()
    events, out = s.feed(GOLDEN_STEP)
    assert out == bytes.fromhex("01 00 01 00 02")
    pkt, step = events
    assert isinstance(pkt, PacketEvent) and pkt.number == 1
    assert set(pkt.states) == {StateId.DX, StateId.DP, StateId.STEP_COUNTER}
    assert isinstance(step, StepEvent) and step.step.counter == 1 and step.index == 1
    np.testing.assert_allclose(step.pose, [0.5, 0.01, -0.002, 0.0174], rtol=1e-6)
    np.testing.assert_allclose(np.diag(step.covariance), [1e-4, 1e-4, 1e-4, 1e-5], rtol=1e-6)


def test_real_module_capture_is_understood_even_when_attaching_without_0x34():
    # A host that never sent 0x34 (attached to a tracking module) still acks steps.
    s = HostSession()
    events, out = s.feed(REAL_STEP)
    assert out == bytes.fromhex("01 00 01 00 02")
    assert [type(e) for e in events] == [PacketEvent, StepEvent]
    assert events[1].step.counter == 1
    assert s.tracker.distance < 1e-3  # a stand-still "step"


def test_command_frames_in_both_numberings():
    assert HostSession("2015").encode_command(Command.PING) == bytes.fromhex("03 00 03")
    assert HostSession("2015").encode_command(Command.OUTPUT_ALL_OFF) == bytes.fromhex("22 00 22")
    assert HostSession("2014").encode_command(Command.STEPWISE_DEAD_RECKONING) == bytes.fromhex("14 00 14")
    assert HostSession("2014").encode_command(Command.OUTPUT_ALL_OFF) == bytes.fromhex("21 00 21")
    frame = HostSession().encode_command(Command.SET_STATE_4, state_id=0x19, data=(100000).to_bytes(4, "big"))
    assert frame == bytes.fromhex("13 19 00 01 86 A0 01 53")
    with pytest.raises(NotSupportedByCommandSet, match="2014"):
        HostSession("2014").encode_command(Command.GP_TEST, a=0, b=0)


# -- dedupe, gaps, acks ----------------------------------------------------------------------


def test_resends_are_acked_every_time_but_summed_once():
    s = started()
    p1 = step_packet(1, 1)
    acks = b""
    for _ in range(3):  # the module resends every 128 cycles until it sees the ack
        _, out = s.feed(p1)
        acks += out
    assert acks == build_packet_ack(1) * 3
    assert s.stats.packets == 1 and s.stats.duplicate_packets == 2
    assert len(s.tracker) == 1


def test_step_resent_under_a_new_packet_number_is_not_summed_twice():
    # After a reconnect the module may send the latest step again in a new packet.
    s = started()
    s.feed(step_packet(1, 1))
    events, out = s.feed(step_packet(2, 1))
    assert out == build_packet_ack(2)
    assert [type(e) for e in events] == [PacketEvent]
    assert s.stats.duplicate_steps == 1 and len(s.tracker) == 1


def test_gap_in_step_counter_is_reported():
    s = started()
    s.feed(step_packet(1, 1))
    events, _ = s.feed(step_packet(2, 4))
    gaps = [e for e in events if isinstance(e, GapEvent)]
    assert gaps == [GapEvent(after=1, counter=4, missing=2, index=2)]
    assert s.stats.gaps == 1 and s.stats.missing_steps == 2
    assert len(s.tracker) == 2


def test_lossy_outputs_are_not_acked_after_the_module_confirms_lossy_mode():
    s = HostSession()
    s.encode_command(Command.OUTPUT_STATE, state_id=StateId.IMU_TS, mode=1)
    s.feed(build_command_ack(0x20))
    events, out = s.feed(build_state_packet(7, (123).to_bytes(4, "big")))
    assert out == b""
    assert int(events[0].states[StateId.IMU_TS]) == 123


def test_lossless_request_turns_acking_on_before_its_ack_arrives():
    s = HostSession(ack_policy="auto")
    s.encode_command(Command.OUTPUT_STATE, state_id=StateId.IMU_TS, mode=1 | OutputMode.LOSSLESS)
    _, out = s.feed(build_state_packet(9, bytes(4)))
    assert out == build_packet_ack(9)


def test_a_resend_reveals_lossless_mode():
    s = HostSession()
    s.plan.lossless = False
    pkt = build_state_packet(5, bytes(4))
    s.plan.outputs = frozenset({StateId.IMU_TS})
    assert s.feed(pkt)[1] == b""
    assert s.feed(pkt)[1] == build_packet_ack(5)
    assert s.lossless


def test_ack_policy_never_and_always():
    never = HostSession(ack_policy="never")
    assert never.feed(step_packet(1, 1))[1] == b""
    always = HostSession(ack_policy="always")
    always.plan.outputs = frozenset({StateId.IMU_TS})
    assert always.feed(build_state_packet(3, bytes(4)))[1] == build_packet_ack(3)
    with pytest.raises(ValueError, match="ack_policy"):
        HostSession(ack_policy="sometimes")


# -- splitting payloads ----------------------------------------------------------------------


def test_packets_of_mixed_rates_are_split_by_length():
    s = HostSession()
    s.encode_command(Command.OUTPUT_MULTIPLE_STATES, state_ids=[0x13, 0x01, 0, 0, 0, 0, 0, 0], mode=2)
    s.feed(build_command_ack(0x21))
    both = encode_states([0x01, 0x13], {0x01: 42, 0x13: np.arange(6, dtype=np.float32)})
    ev, _ = s.feed(build_state_packet(1, both))
    assert list(ev[0].states) == [0x01, 0x13]
    np.testing.assert_array_equal(ev[0].states[0x13], np.arange(6))
    ev, _ = s.feed(build_state_packet(2, encode_states([0x01], {0x01: 43})))
    assert list(ev[0].states) == [0x01]


def test_state_if_setup_quirk_expects_the_checksum_ids():
    s = HostSession()
    frame = s.encode_command(Command.STATE_IF_SETUP, flag_id=0x33, mode=0x20,
                             state_ids=[0x30, 0x31, 0x32, 0, 0, 0, 0, 0])
    ck_msb = frame[-2]
    assert 0x01 <= ck_msb <= 0x05
    assert ck_msb in s.plan.candidates  # that state rides along on a real module


def test_unsplittable_payload_is_delivered_raw_and_counted():
    s = HostSession()
    ev, _ = s.feed(build_state_packet(1, b"\x01\x02\x03"))
    assert ev[0].states is None and ev[0].payload == b"\x01\x02\x03"
    assert s.stats.undecoded_packets == 1


def test_match_layout_is_unique_or_none():
    assert match_layout(frozenset({0x30, 0x31, 0x32}), 58) == (0x30, 0x31, 0x32)
    assert match_layout(frozenset({0x01, 0x02}), 4) is None  # ambiguous
    assert match_layout(frozenset({0x01, 0x13}), 5) is None  # nothing fits
    assert OutputPlan().layout(58) == (0x30, 0x31, 0x32)


# -- properties ------------------------------------------------------------------------------

counters_st = st.lists(st.integers(1, 3), min_size=1, max_size=12)


def _stream(increments, resends, first_number=1):
    """Module bytes for steps with counter increments; each packet sent 1 + resends[i] times."""
    frames, c = [], 0
    for i, inc in enumerate(increments):
        c += inc
        dx = (0.6 + 0.01 * i, 0.02 * i, 0.0, 0.05 * ((-1) ** i))
        frames += [step_packet((first_number + i) & 0xFFFF, c, dx)] * (1 + resends[i % len(resends)])
    return frames


def _run(session, chunks):
    events, acks = [], b""
    for ch in chunks:
        ev, out = session.feed(ch)
        events += ev
        acks += out
    ev, out = session.idle()
    return events + ev, acks + out


def _split(data: bytes, cuts: list[int]) -> list[bytes]:
    idx = sorted({c % (len(data) + 1) for c in cuts})
    return [data[a:b] for a, b in zip([0, *idx], [*idx, len(data)], strict=True)]


@settings(max_examples=80, deadline=None)
@given(
    counters_st,
    st.lists(st.integers(0, 2), min_size=1, max_size=12),
    st.lists(st.binary(max_size=20).map(lambda b: bytes(x for x in b if x not in (0xA0, 0xAA))),
             min_size=1, max_size=20),
    st.lists(st.integers(0, 10_000), max_size=15),
)
def test_garbage_between_frames_changes_nothing_but_the_counters(increments, resends, garbage, cuts):
    frames = _stream(increments, resends)
    clean_ev, clean_acks = _run(started(), frames)
    dirty = b"".join(garbage[i % len(garbage)] + f for i, f in enumerate(frames)) + garbage[0]
    s = started()
    dirty_ev, dirty_acks = _run(s, _split(dirty, cuts))
    assert [repr(e) for e in dirty_ev] == [repr(e) for e in clean_ev]
    assert dirty_acks == clean_acks
    assert s.stats.garbage_bytes == len(dirty) - sum(len(f) for f in frames)
    # every packet, resends included, acked with 01 nn nn ck ck
    assert dirty_acks == b"".join(build_packet_ack(int.from_bytes(f[1:3], "big")) for f in frames)


@settings(max_examples=60, deadline=None)
@given(counters_st, st.lists(st.integers(0, 2), min_size=1, max_size=12),
       st.lists(st.binary(min_size=1, max_size=12), min_size=1, max_size=6), st.data())
def test_arbitrary_garbage_including_header_bytes(increments, resends, garbage, data):
    frames = _stream(increments, resends)
    assume(all(decode_all(g) == [] for g in garbage))
    positions = data.draw(st.lists(st.integers(0, len(frames)), min_size=len(garbage), max_size=len(garbage)))
    parts = list(frames)
    for g, p in sorted(zip(garbage, positions, strict=True), key=lambda t: -t[1]):
        parts.insert(p, g)
    clean_ev, clean_acks = _run(started(), frames)
    s = started()
    dirty_ev, dirty_acks = _run(s, parts)
    assert [repr(e) for e in dirty_ev] == [repr(e) for e in clean_ev]
    assert dirty_acks == clean_acks


@settings(max_examples=60, deadline=None)
@given(counters_st, st.lists(st.integers(0, 3), min_size=1, max_size=12), st.integers(0xFFF0, 0x1000F))
def test_resends_never_summed_twice_and_gaps_add_up(increments, resends, first_number):
    """Also across the packet-number wrap 0xFFFF → 0x0000."""
    frames = _stream(increments, resends, first_number & 0xFFFF)
    s = started()
    events, _ = _run(s, frames)
    steps = [e for e in events if isinstance(e, StepEvent)]
    assert len(steps) == len(increments) == len(s.tracker)
    assert s.stats.duplicate_packets == len(frames) - len(increments)
    assert s.stats.missing_steps == sum(increments) - len(increments)
    assert s.stats.gaps == sum(1 for i in increments if i > 1)
    assert s.stats.packet_number_jumps == 0
    np.testing.assert_array_equal(s.tracker.track.counters, np.cumsum(increments))


def test_step_class_is_the_protocol_one():
    s = started()
    ev, _ = s.feed(step_packet(1, 1))
    assert isinstance(ev[1].step, Step)


@settings(max_examples=150, deadline=None)
@given(st.sets(st.sampled_from(sorted(STATES)), min_size=1, max_size=10), st.data())
def test_match_layout_agrees_with_brute_force(candidates, data):
    chosen = data.draw(st.sets(st.sampled_from(sorted(candidates)), min_size=1))
    length = sum(STATES[i].size for i in chosen)
    fits = [
        combo
        for r in range(1, len(candidates) + 1)
        for combo in itertools.combinations(sorted(candidates), r)
        if sum(STATES[i].size for i in combo) == length
    ]
    expected = fits[0] if len(fits) == 1 else None
    assert match_layout(frozenset(candidates), length) == expected


def test_a_stray_packet_header_does_not_hold_back_frames_once_the_link_is_quiet():
    s = HostSession()
    events, _ = s.feed(b"\xaa\x00\x01\x10" + build_command_ack(0x03))
    assert events == []  # could be the start of a 22-byte packet: wait for more
    events, _ = s.idle()
    assert events == [CommandAckEvent(0x03)]
    assert s.stats.garbage_bytes == 4


def test_replay_of_bytes_with_garbage_and_resends():
    from hostlib.files.replay import replay_bytes

    data = b"\x00garbage" + step_packet(7, 3) * 2 + step_packet(8, 4) + b"\xaa\x00"
    track, stats = replay_bytes(data, chunk=5)
    assert len(track) == 2 and track.gaps == []  # counter before the capture is unknown
    assert stats.duplicate_packets == 1 and stats.garbage_bytes == 8 + 2


def test_a_checksummed_step_with_a_nan_is_acked_reported_and_left_out_of_the_track():
    """A step packet whose checksum is right but whose dx holds a NaN would turn every later pose
    into NaN: the session acks it (the link is fine), reports it as a rejected step, counts it,
    and the track goes on from the last good step."""
    s = started()
    s.feed(step_packet(1, 1))
    events, out = s.feed(step_packet(2, 2, dx=(float("nan"), 0.0, 0.0, 0.0)))
    assert out == build_packet_ack(2)
    [rejected] = [e for e in events if isinstance(e, StepEvent)]
    assert rejected.outcome is StepOutcome.REJECTED and "not finite" in s.tracker.rejections[0][1]
    assert s.stats.rejected_steps == 1 and s.stats.steps == 1 and len(s.tracker) == 1
    s.feed(step_packet(3, 3))
    assert len(s.tracker) == 2 and s.stats.gaps == 0
    assert np.isfinite(s.tracker.track.poses).all()
    assert s.tracker.distance == pytest.approx(2 * np.hypot(0.5, 0.01))  # the two good steps only
