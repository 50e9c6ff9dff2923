"""Frames and checksum: the golden bytes of protocol.md §2 and the parsers' refusals."""

from __future__ import annotations

import pytest

from protocol import CURRENT, LEGACY_2014, Command, Command2014
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

from . import golden as g


def test_checksum_is_additive_sum_mod_2_16_not_a_crc():
    assert checksum(b"") == 0
    assert checksum(b"\x34") == 0x34
    assert checksum(b"\xff" * 300) == (0xFF * 300) & 0xFFFF
    assert checksum(b"\x01\x02") == checksum(b"\x02\x01")  # order does not matter: additive


@pytest.mark.parametrize(
    ("meaning", "fields", "wire"),
    [
        (Command.STEPWISE_DEAD_RECKONING, {}, g.START_STEPWISE),
        (Command.PING, {}, g.PING),
        (Command.OUTPUT_ALL_OFF, {}, g.ALL_OUTPUTS_OFF),
        (Command.SET_STATE_4, {"state_id": 0x19, "data": b"\x00\x01\x86\xa0"}, g.SET_TH_ZUPT_100000),
        (Command.ACK, {"packet_number": 0x0102}, g.PACKET_ACK_0102),
    ],
)
def test_build_command_reproduces_the_documented_bytes(meaning, fields, wire):
    assert build_command(meaning, **fields) == wire
    frame = parse_command(wire)
    assert frame.command is meaning
    assert frame.fields == fields
    assert frame.raw == wire


def test_module_ack_and_host_packet_ack_golden():
    assert build_command_ack(0x34) == g.ACK_OF_START
    assert parse_command_ack(g.ACK_OF_START) == CommandAck(0x34)
    assert build_packet_ack(0x0102) == g.PACKET_ACK_0102
    assert parse_packet_ack(g.PACKET_ACK_0102) == PacketAck(0x0102)


def test_step_packet_golden_frame():
    pkt = parse_state_packet(g.STEP_PACKET)
    assert len(g.STEP_PACKET) == 64
    assert pkt.number == 1
    assert pkt.length_byte == 0x3A == len(pkt.payload)
    assert build_state_packet(1, pkt.payload) == g.STEP_PACKET
    real = parse_state_packet(g.REAL_STEP_PACKET)
    assert real.number == 1
    assert checksum(g.REAL_STEP_PACKET[:-2]) == 0x1B6D


def test_legacy_numbering_uses_2014_ids_for_the_same_meaning():
    assert build_command(Command.STEPWISE_DEAD_RECKONING, command_set=LEGACY_2014) == bytes.fromhex("140014")
    assert build_command(Command2014.OUTPUT_ALL_OFF) == bytes.fromhex("210021")
    assert parse_command(bytes.fromhex("140014"), LEGACY_2014).command is Command.STEPWISE_DEAD_RECKONING
    with pytest.raises(ValueError, match="2014 wire id"):
        build_command(Command2014.OUTPUT_ALL_OFF, command_set=CURRENT)
    with pytest.raises(KeyError, match="SET_STATE_4"):
        build_command(Command.SET_STATE_4, command_set=LEGACY_2014, state_id=1, data=b"")


def test_long_payload_announces_its_length_mod_256():
    payload = bytes(range(256)) + bytes(44)
    frame = build_state_packet(7, payload)
    assert frame[3] == 44
    assert parse_state_packet(frame) == StatePacket(7, payload, 44)
    with pytest.raises(ValueError, match="506"):
        build_state_packet(1, bytes(MAX_PAYLOAD + 1))


def test_bad_checksum_is_refused_naming_the_bytes_in_hex():
    bad = g.START_STEPWISE[:-1] + b"\x35"
    with pytest.raises(FrameError, match="checksum 0x0035, expected 0x0034: 34 00 35"):
        parse_command(bad)
    with pytest.raises(FrameError, match="A0 34 00 D5"):
        parse_command_ack(g.ACK_OF_START[:-1] + b"\xd5")
    with pytest.raises(FrameError, match="checksum"):
        parse_state_packet(g.STEP_PACKET[:-1] + b"\x00")
    with pytest.raises(FrameError):
        parse_packet_ack(g.PACKET_ACK_0102[:-1] + b"\x05")


def test_parsers_refuse_wrong_header_length_and_unknown_commands():
    with pytest.raises(FrameError, match="0x55 is not a command id"):
        parse_command(bytes.fromhex("55 00 55"))
    with pytest.raises(FrameError, match="must be 8 bytes"):
        parse_command(g.SET_TH_ZUPT_100000[:-1])
    with pytest.raises(FrameError, match="length byte"):
        parse_state_packet(g.STEP_PACKET[:3] + b"\x3b" + g.STEP_PACKET[4:])
    with pytest.raises(FrameError, match="start with A0"):
        parse_command_ack(bytes.fromhex("A1 34 00 D5"))
    with pytest.raises(FrameError, match="not an acknowledged command"):
        parse_command_ack(build_command_ack(0x01), command_set=LEGACY_2014)


def test_build_command_refuses_missing_unknown_and_oversized_fields():
    with pytest.raises(ValueError, match="missing \\['data'\\]"):
        build_command(Command.SET_STATE_4, state_id=0x19)
    with pytest.raises(ValueError, match="unknown \\['bogus'\\]"):
        build_command(Command.PING, bogus=1)
    with pytest.raises(ValueError, match="at most 4 bytes"):
        build_command(Command.SET_STATE_4, state_id=0x19, data=bytes(5))
    with pytest.raises(ValueError):
        build_command(Command.OUTPUT_STATE, state_id=0x100, mode=0)
    with pytest.raises(ValueError, match="not a command id"):
        build_command(0x55)


def test_short_set_state_data_is_zero_padded():
    frame = build_command(Command.SET_STATE_12, state_id=0x90, data=b"\x01\x02")
    assert parse_command(frame).fields["data"] == b"\x01\x02" + bytes(10)


def test_reprs_show_hex():
    assert repr(CommandAck(0x34)) == "CommandAck(command_id=0x34)"
    assert "0x0102" in repr(PacketAck(0x0102))
    assert "3F 00 00 00" in repr(parse_state_packet(g.STEP_PACKET))
    assert "13 19 00 01 86 A0 01 53" in repr(parse_command(g.SET_TH_ZUPT_100000))
