"""The module-side frame builders (plain bytes, on every module's hot path) write exactly
the bytes of the construct declarations that define the layouts (protocol.md §2), and a
command's payload parses to the declaration's fields."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from protocol.commands import CURRENT, LEGACY_2014, CommandSpec
from protocol.frames import (
    COMMAND_ACK_FRAME,
    MAX_PAYLOAD,
    PACKET_ACK_FRAME,
    build_command_ack,
    build_packet_ack,
    build_state_packet,
    build_state_packet_declared,
    parse_state_packet,
)

numbers = st.integers(0, 0xFFFF)
payloads = st.binary(min_size=0, max_size=MAX_PAYLOAD)


@given(numbers, payloads)
def test_state_packet_fast_equals_construct(number: int, payload: bytes) -> None:
    fast = build_state_packet(number, payload)
    assert fast == build_state_packet_declared(number, payload)
    assert parse_state_packet(fast).payload == payload


@given(numbers, st.binary(min_size=0, max_size=MAX_PAYLOAD).map(bytearray))
def test_state_packet_takes_any_bytes_like(number: int, payload: bytearray) -> None:
    assert build_state_packet(number, memoryview(payload)) == build_state_packet_declared(number, payload)


@given(st.integers(0, 0xFF))
def test_command_ack_fast_equals_construct(cmd: int) -> None:
    assert build_command_ack(cmd) == COMMAND_ACK_FRAME.build({"body": {"value": {"command_id": cmd}}})


@given(numbers)
def test_packet_ack_fast_equals_construct(number: int) -> None:
    assert build_packet_ack(number) == PACKET_ACK_FRAME.build({"body": {"value": {"packet_number": number}}})


def test_golden_step_packet_header_and_checksum() -> None:
    # protocol.md §2: AA · number · len · payload · ck ck, checksum = 16-bit byte sum
    frame = build_state_packet(0x0102, bytes([0xFF] * 300))
    assert frame[:4] == bytes([0xAA, 0x01, 0x02, 300 % 256])
    assert int.from_bytes(frame[-2:], "big") == (0xAA + 1 + 2 + 44 + 300 * 0xFF) & 0xFFFF


def test_out_of_range_refused() -> None:
    import pytest

    with pytest.raises(ValueError):
        build_state_packet(0x10000, b"")
    with pytest.raises(ValueError):
        build_state_packet(1, bytes(MAX_PAYLOAD + 1))
    with pytest.raises(ValueError):
        build_command_ack(256)
    with pytest.raises(ValueError):
        build_packet_ack(-1)


COMMANDS = [spec for numbering in (CURRENT, LEGACY_2014) for spec in numbering.values()]


@given(st.sampled_from(COMMANDS), st.data())
def test_command_payload_parses_to_the_declarations_fields(spec: CommandSpec, data: st.DataObject) -> None:
    payload = data.draw(st.binary(min_size=spec.payload_len, max_size=spec.payload_len))
    assert spec.parse_payload(payload) == spec.payload.parse(payload)
