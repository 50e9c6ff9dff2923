"""StreamDecoder: module → host bytes in arbitrary chunks, with garbage, back to frames."""

from __future__ import annotations

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from protocol import CURRENT, LEGACY_2014
from protocol.frames import (
    MAX_PACKET,
    MAX_PAYLOAD,
    CommandAck,
    StatePacket,
    build_command_ack,
    build_state_packet,
    checksum,
)
from protocol.ids import ACK_HEADER, PACKET_HEADER
from protocol.stream import DEFAULT_ACK_IDS, StreamDecoder, decode_all, frame_len

from . import golden as g

SETTINGS = settings(derandomize=True, deadline=None, max_examples=150)

GOLDEN_FRAMES = [
    CommandAck(0x34),
    StatePacket(1, g.STEP_PACKET[4:-2]),
    StatePacket(1, g.REAL_STEP_PACKET[4:-2]),
]
GOLDEN_STREAM = g.ACK_OF_START + g.STEP_PACKET + g.REAL_STEP_PACKET


def feed_all(dec: StreamDecoder, chunks) -> list:
    out = []
    for c in chunks:
        out += dec.feed(c)
        assert dec.pending < MAX_PACKET
    return out


def test_golden_frames_in_one_chunk_and_split_at_every_position():
    assert StreamDecoder().feed(GOLDEN_STREAM) == GOLDEN_FRAMES
    for cut in range(len(GOLDEN_STREAM) + 1):
        dec = StreamDecoder()
        assert feed_all(dec, [GOLDEN_STREAM[:cut], GOLDEN_STREAM[cut:]]) == GOLDEN_FRAMES
        assert (dec.skipped_bytes, dec.bad_frames, dec.pending) == (0, 0, 0)


def test_byte_by_byte_yields_each_frame_on_its_last_byte():
    dec = StreamDecoder()
    got = [(i, f) for i, b in enumerate(GOLDEN_STREAM) for f in dec.feed(bytes([b]))]
    ends = [3, 3 + 64, 3 + 128]
    assert got == list(zip(ends, GOLDEN_FRAMES, strict=True))
    assert (dec.acks, dec.packets) == (1, 2)


def test_garbage_before_and_between_frames_is_skipped_and_counted():
    dec = StreamDecoder()
    data = b"\x00\x13\x55" + g.ACK_OF_START + b"\xff\x01" + g.STEP_PACKET
    assert dec.feed(data) == GOLDEN_FRAMES[:2]
    assert dec.skipped_bytes == 5 and dec.bad_frames == 0


def test_bad_checksum_frame_is_never_yielded_and_counted():
    data = g.STEP_PACKET[:-1] + b"\x00" + g.ACK_OF_START[:-1] + b"\x00" + g.ACK_OF_START
    dec = StreamDecoder(max_payload=255)
    assert dec.feed(data) == [CommandAck(0x34)]
    assert dec.bad_frames == 2  # the packet and the first ack
    # With long payloads possible, the bad packet's 0x3A+256-byte reading must be waited for ...
    dec = StreamDecoder()
    assert dec.feed(data) == []
    # ... until the link goes quiet: then the good ack after it is decided.
    assert dec.flush() == [CommandAck(0x34)]
    assert dec.bad_frames == 2 and dec.pending == 0
    assert decode_all(g.STEP_PACKET[:-1] + b"\x00") == []


def test_valid_frame_starting_inside_a_bad_one_is_found():
    # A packet header announcing 10 bytes whose "payload" holds a real ack; its checksum is wrong.
    fake = bytes([PACKET_HEADER, 0, 7, 10]) + g.ACK_OF_START + bytes(6) + b"\x12\x34"
    dec = StreamDecoder(max_payload=255)
    assert dec.feed(fake + g.STEP_PACKET) == [CommandAck(0x34), GOLDEN_FRAMES[1]]
    assert dec.bad_frames == 1


def test_long_payload_with_length_byte_mod_256_is_decoded():
    payload = bytes(range(256)) * 1 + bytes(range(44))
    frame = build_state_packet(0x1234, payload)
    assert frame[3] == 44
    dec = StreamDecoder()
    assert feed_all(dec, [frame[:100], frame[100:]]) == [StatePacket(0x1234, payload)]


def test_ack_command_byte_must_be_an_acknowledged_command():
    unknown = build_command_ack(0x55)  # valid checksum, but 0x55 is no command
    packet_ack = build_command_ack(0x01)  # 0x01 is never acknowledged
    legacy = build_command_ack(0x27)  # 2014 "processing off"
    assert decode_all(unknown + packet_ack + legacy) == [CommandAck(0x27)]
    assert decode_all(legacy, command_set=CURRENT) == []
    assert decode_all(legacy, command_set=LEGACY_2014) == [CommandAck(0x27)]
    assert 0x01 not in DEFAULT_ACK_IDS and max(DEFAULT_ACK_IDS) < 0x50


def test_stray_aa_before_an_ack_holds_it_until_flush():
    dec = StreamDecoder()
    assert dec.feed(b"\xaa" + g.ACK_OF_START) == []  # could be a 256-byte packet: wait
    assert dec.flush() == [CommandAck(0x34)]
    assert dec.pending == 0 and dec.skipped_bytes == 1
    # a host that never asks for > 255-byte payloads does not wait at all
    dec = StreamDecoder(max_payload=255)
    assert dec.feed(b"\xaa" + g.ACK_OF_START) == []  # the 0-byte reading needs one more byte
    assert dec.feed(g.ACK_OF_START) == [CommandAck(0x34)] * 2


def test_flush_keeps_a_partly_received_frame():
    dec = StreamDecoder()
    assert dec.feed(g.ACK_OF_START + g.STEP_PACKET[:30]) == [CommandAck(0x34)]
    assert dec.flush() == []
    assert dec.pending == 30 and dec.skipped_bytes == 0
    assert dec.feed(g.STEP_PACKET[30:]) == [GOLDEN_FRAMES[1]]


def test_finish_drops_incomplete_bytes_as_skipped():
    dec = StreamDecoder()
    assert dec.feed(g.STEP_PACKET[:30]) == []
    assert dec.finish() == []
    assert (dec.pending, dec.skipped_bytes) == (0, 30)


def test_buffer_stays_bounded_under_a_header_flood():
    dec = StreamDecoder()
    for _ in range(50):
        assert dec.feed(b"\xaa\x00\x00\xfa" * 250 + b"\xa0" * 100) == []
        assert dec.pending < MAX_PACKET
    assert dec.bytes_in == dec.skipped_bytes + dec.pending


def test_repr_shows_counters():
    dec = StreamDecoder()
    dec.feed(b"\x00" + g.ACK_OF_START)
    assert repr(dec) == "StreamDecoder(acks=1, packets=0, skipped_bytes=1, bad_frames=0, pending=0)"


def test_constructor_rejects_a_payload_limit_above_the_cap():
    with pytest.raises(ValueError, match="506"):
        StreamDecoder(max_payload=MAX_PAYLOAD + 1)


# ---------------------------------------------------------------------------- properties

acks = st.sampled_from(sorted(DEFAULT_ACK_IDS)).map(CommandAck)
packets = st.builds(
    StatePacket,
    st.integers(0, 0xFFFF),
    st.one_of(st.binary(max_size=80), st.binary(min_size=240, max_size=MAX_PAYLOAD)),
)
frames = st.lists(st.one_of(acks, packets), max_size=12)
clean_garbage = st.binary(max_size=12).map(lambda b: b.replace(b"\xa0", b"\x00").replace(b"\xaa", b"\x55"))
header_garbage = st.lists(
    st.one_of(st.sampled_from([ACK_HEADER, PACKET_HEADER]), st.integers(0, 255)), max_size=12
).map(bytes)
cut_points = st.lists(st.integers(0, 8000), max_size=20)


def assemble(frame_list, gaps):
    """The stream and the (start, frame) spans of the real frames in it."""
    data = bytearray()
    spans = []
    for frame, gap in zip(frame_list, gaps, strict=False):
        data += gap
        spans.append((len(data), frame))
        data += frame.to_bytes()
    data += gaps[len(frame_list)] if len(gaps) > len(frame_list) else b""
    return bytes(data), spans


def chunked(data: bytes, cuts: list[int]) -> list[bytes]:
    points = sorted({min(c, len(data)) for c in cuts})
    edges = [0, *points, len(data)]
    return [data[a:b] for a, b in zip(edges, edges[1:], strict=False)]


def false_frame_possible(data: bytes, spans, *, inside_frames: bool = False) -> bool:
    """Could a valid-checksum frame start anywhere but at a real frame's start (or with another length)?

    Brute force over every position outside the real frames (also inside them
    with *inside_frames*) and over the short candidate of every real long
    packet: the oracle for the garbage properties.
    """
    ack_ids = DEFAULT_ACK_IDS
    real = {start: frame_len(f) for start, f in spans}
    inside = set() if inside_frames else {p for s, n in real.items() for p in range(s + 1, s + n)}
    for p, b in enumerate(data):
        if p in inside:
            continue
        if b == ACK_HEADER and p not in real and p + 4 <= len(data):
            ck = int.from_bytes(data[p + 2 : p + 4], "big")
            if data[p + 1] in ack_ids and checksum(data[p : p + 2]) == ck:
                return True
        if b == PACKET_HEADER and p + 4 <= len(data):
            for plen in (data[p + 3], data[p + 3] + 256):
                end = p + 6 + plen
                if plen > MAX_PAYLOAD or end > len(data) or real.get(p) == end - p:
                    break  # impossible, incomplete, or the real frame itself
                if checksum(data[p : end - 2]) == int.from_bytes(data[end - 2 : end], "big"):
                    return True
    return False


@SETTINGS
@given(frames, st.lists(clean_garbage, min_size=13, max_size=13), cut_points)
def test_frames_with_garbage_between_come_out_exactly_in_any_chunking(frame_list, gaps, cuts):
    data, spans = assemble(frame_list, gaps)
    dec = StreamDecoder()
    out = feed_all(dec, chunked(data, cuts))
    assert out == frame_list
    assert dec.bad_frames == 0
    assert dec.skipped_bytes == len(data) - sum(frame_len(f) for f in frame_list)
    assert dec.pending == 0


@SETTINGS
@given(frames, st.lists(header_garbage, min_size=13, max_size=13), cut_points)
def test_header_bytes_in_garbage_only_delay_frames(frame_list, gaps, cuts):
    data, spans = assemble(frame_list, gaps)
    assume(not false_frame_possible(data, spans))
    dec = StreamDecoder()
    out = feed_all(dec, chunked(data, cuts)) + dec.finish()
    assert out == frame_list
    assert dec.bytes_in == dec.frame_bytes + dec.skipped_bytes and dec.pending == 0


@SETTINGS
@given(frames, st.lists(header_garbage, min_size=13, max_size=13), cut_points)
def test_flush_after_every_chunk_loses_no_real_frame(frame_list, gaps, cuts):
    """A host that flushes on every read still gets every frame, in order.

    (flush scans inside a partly received frame, so the oracle looks there too.)
    """
    data, spans = assemble(frame_list, gaps)
    assume(not false_frame_possible(data, spans, inside_frames=True))
    dec = StreamDecoder()
    out = []
    for c in chunked(data, cuts):
        out += dec.feed(c)
        out += dec.flush()
        assert dec.pending < MAX_PACKET
    out += dec.finish()
    assert out == frame_list


def found_in_order(data: bytes, out) -> bool:
    """Every yielded frame's exact bytes (checksum recomputed) occur in *data*, in order, not overlapping."""
    cursor = 0
    for f in out:
        at = data.find(f.to_bytes(), cursor)
        if at < 0:
            return False
        cursor = at + frame_len(f)
    return True


@SETTINGS
@given(st.binary(max_size=3000), st.lists(st.integers(0, 3000), max_size=30), st.booleans())
def test_random_bytes_never_raise_nor_yield_a_bad_checksum(data, cuts, flush):
    dec = StreamDecoder()
    out = []
    for c in chunked(data, cuts):
        out += dec.feed(c)
        assert dec.pending < MAX_PACKET
        if flush:
            out += dec.flush()
    out += dec.finish()
    assert found_in_order(data, out)
    assert dec.bytes_in == len(data) == dec.frame_bytes + dec.skipped_bytes


@SETTINGS
@given(st.lists(st.sampled_from([ACK_HEADER, PACKET_HEADER, 0x00, 0x01, 0x34, 0xD4, 0xFF]), max_size=2000))
def test_header_heavy_noise_never_yields_a_bad_checksum(noise):
    data = bytes(noise)
    dec = StreamDecoder()
    out = feed_all(dec, [data[i : i + 97] for i in range(0, len(data), 97)]) + dec.finish()
    assert found_in_order(data, out)
