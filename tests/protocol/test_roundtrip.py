"""Known-good byte vectors and build → parse round trips of every frame type."""

from __future__ import annotations

import pytest
from construct import Array, Bytes, FormatField, Pass, Struct
from hypothesis import given, settings
from hypothesis import strategies as st

from protocol import CURRENT, LEGACY_2014, Command, command_set
from protocol.frames import (
    MAX_PAYLOAD,
    CommandAck,
    FrameError,
    PacketAck,
    StatePacket,
    build_command,
    build_command_ack,
    build_packet_ack,
    build_state_packet,
    checksum,
    parse_command,
    parse_command_ack,
    parse_packet_ack,
    parse_state_packet,
)
from protocol.stream import decode_all

from . import golden as g

SETTINGS = settings(derandomize=True, deadline=None, max_examples=300)


@pytest.mark.parametrize(("meaning", "fields", "numbering", "wire"), g.KNOWN_GOOD_COMMANDS)
def test_known_good_command_vectors(meaning, fields, numbering, wire):
    cs = command_set(numbering)
    frame = bytes.fromhex(wire)
    assert build_command(Command[meaning], command_set=cs, **fields) == frame
    parsed = parse_command(frame, cs)
    assert parsed.command is Command[meaning] and parsed.fields == fields


@pytest.mark.parametrize(("what", "wire"), g.KNOWN_GOOD_MODULE_FRAMES)
def test_known_good_module_frames_decode_and_rebuild(what, wire):
    frame = bytes.fromhex(wire)
    (decoded,) = decode_all(frame)
    assert decoded.to_bytes() == frame


def test_checksum_wraps_modulo_2_16():
    payload = b"\xff" * 300
    frame = build_state_packet(0x0102, payload)
    want = (0xAA + 0x01 + 0x02 + 44 + 300 * 0xFF) & 0xFFFF
    assert int.from_bytes(frame[-2:], "big") == want == checksum(frame[:-2])
    assert parse_state_packet(frame).payload == payload


# --- strategies from the construct payload declarations -----------------------------


def _strategy(con):
    """Values for a construct field: ints in the field's range, bytes of its length, lists for arrays."""
    if isinstance(con, FormatField):
        bits = con.length * 8
        signed = con.fmtstr[-1].islower()
        lo, hi = (-(1 << (bits - 1)), (1 << (bits - 1)) - 1) if signed else (0, (1 << bits) - 1)
        return st.integers(lo, hi)
    if isinstance(con, Bytes):
        return st.binary(min_size=con.length, max_size=con.length)
    if isinstance(con, Array):
        return st.lists(_strategy(con.subcon), min_size=con.count, max_size=con.count)
    raise TypeError(f"no strategy for {con!r}")


def _fields(spec):
    if spec.payload is Pass:
        return st.just({})
    assert isinstance(spec.payload, Struct)
    return st.fixed_dictionaries({sc.name: _strategy(sc.subcon) for sc in spec.payload.subcons})


ALL_SPECS = [(cs, spec) for cs in (CURRENT, LEGACY_2014) for spec in cs.values()]


@SETTINGS
@given(st.sampled_from(ALL_SPECS).flatmap(lambda p: st.tuples(st.just(p), _fields(p[1]))))
def test_every_command_of_both_numberings_round_trips(case):
    (cs, spec), fields = case
    frame = build_command(spec.command, command_set=cs, **fields)
    assert len(frame) == spec.frame_len
    assert frame[0] == spec.wire_id
    assert int.from_bytes(frame[-2:], "big") == checksum(frame[:-2])
    parsed = parse_command(frame, cs)
    assert parsed.spec == spec and parsed.fields == fields and parsed.raw == frame
    # the plain wire id names the same command
    assert build_command(spec.wire_id, command_set=cs, **fields) == frame


@SETTINGS
@given(st.sampled_from(ALL_SPECS).flatmap(lambda p: st.tuples(st.just(p), _fields(p[1]))), st.data())
def test_any_corrupted_byte_of_a_command_is_refused(case, data):
    (cs, spec), fields = case
    frame = bytearray(build_command(spec.command, command_set=cs, **fields))
    i = data.draw(st.integers(0, len(frame) - 1))
    frame[i] = (frame[i] + data.draw(st.integers(1, 255))) & 0xFF
    with pytest.raises(FrameError):
        parse_command(bytes(frame), cs)


@SETTINGS
@given(st.integers(0, 0xFF))
def test_command_ack_round_trips(cmd):
    frame = build_command_ack(cmd)
    assert len(frame) == 4
    assert parse_command_ack(frame) == CommandAck(cmd)


@SETTINGS
@given(st.integers(0, 0xFFFF))
def test_packet_ack_round_trips_and_is_command_0x01(number):
    frame = build_packet_ack(number)
    assert parse_packet_ack(frame) == PacketAck(number)
    assert frame == build_command(Command.ACK, packet_number=number)
    assert frame == build_command(Command.ACK, command_set=LEGACY_2014, packet_number=number)


@SETTINGS
@given(st.integers(0, 0xFFFF), st.binary(max_size=MAX_PAYLOAD))
def test_state_packet_round_trips(number, payload):
    frame = build_state_packet(number, payload)
    assert len(frame) == len(payload) + 6 <= 512
    assert frame[3] == len(payload) % 256
    assert parse_state_packet(frame) == StatePacket(number, payload, len(payload) % 256)
