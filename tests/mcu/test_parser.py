"""The module's command parser (protocol.md §7): garbage, checksums, limits, timeouts,
and properties over arbitrary byte streams."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from firmware_sim.mcu.interface import MAX_RX_BYTES_PER_CYCLE, RX_TIMEOUT_CYCLES
from firmware_sim.mcu.module import Module, ModuleConfig
from firmware_sim.nav.firmware import build_module
from protocol.commands import CURRENT, LEGACY_2014
from protocol.frames import checksum

from .emu import Host, with_checksum

PING = bytes.fromhex("03 00 03")
PING_ACK = bytes.fromhex("A0 03 00 A3")
NON_COMMAND = bytes(b for b in range(256) if b not in CURRENT)


def test_non_command_bytes_are_discarded_and_counted():
    h = Host()
    h.send(bytes([0x00, 0x02, 0x50, 0xAA, 0xFF, 0x99]) + PING)
    assert h.step() == PING_ACK
    assert h.iface.bytes_discarded == 6


def test_bad_checksum_is_dropped_silently():
    h = Host()
    h.send(bytes.fromhex("03 00 04") + bytes.fromhex("22 00 23") + PING)
    assert h.step(2) == PING_ACK
    assert h.iface.bad_checksums == 2 and h.iface.frames_executed == 1


def test_a_frame_split_over_many_cycles_is_executed_when_complete():
    h = Host()
    frame = bytes.fromhex("13 19 00 01 86 A0 01 53")
    for b in frame[:-1]:
        h.send(bytes([b]))
        assert h.step() == b""
    h.send(frame[-1:])
    assert h.step() == bytes.fromhex("A0 13 00 B3")


def test_at_most_400_bytes_per_cycle():
    h = Host()
    h.send(PING * 200)  # 600 bytes
    first = h.step()
    assert len(first) == 4 * (MAX_RX_BYTES_PER_CYCLE // 3)  # 133 pings
    assert h.iface.partial_frame == PING[:1]
    second = h.step()
    assert len(second) == 4 * 67
    assert h.iface.bytes_received == 600


def test_partial_frame_timeout_is_about_3_seconds_after_the_last_byte():
    h = Host()
    h.send(bytes.fromhex("13 19"))
    h.step()
    h.step(1000)
    h.send(bytes.fromhex("00"))  # a byte restarts the timer
    h.step()
    t_last = h.module.clock.now_cycles
    ticks = RX_TIMEOUT_CYCLES // 64_000
    h.step(ticks - 2)
    assert h.iface.partial_frame == bytes.fromhex("13 19 00")
    h.step(3)
    assert h.iface.partial_frame == b"" and h.iface.partial_timeouts == 1
    assert h.module.clock.now_cycles - t_last > RX_TIMEOUT_CYCLES


def test_timeout_in_virtual_time_at_250_hz():
    h = Host(rate_hz=250)
    h.send(bytes.fromhex("13"))
    h.step(RX_TIMEOUT_CYCLES // 256_000 + 2)
    assert h.iface.partial_timeouts == 1


def test_trace_records_frames_in_and_out_with_virtual_time():
    h = Host(trace=True)
    h.send(bytes.fromhex("03 00 04") + PING)
    h.step()
    tr = h.module.trace
    assert [(e.direction, e.note, e.data) for e in tr] == [
        ("in", "bad checksum", bytes.fromhex("03 00 04")),
        ("in", "command", PING),
        ("out", "ack", PING_ACK),
    ]
    assert all(e.interface == "USB" and 64_000 <= e.cycles < 128_000 for e in tr)
    assert tr[0].cycles <= tr[1].cycles <= tr[2].cycles


# ------------------------------------------------------------------- properties
def valid_frame(command_set=CURRENT):
    specs = sorted(command_set.values(), key=lambda s: s.wire_id)
    return st.sampled_from(specs).flatmap(
        lambda spec: st.binary(min_size=spec.payload_len, max_size=spec.payload_len).map(
            lambda p, spec=spec: with_checksum(bytes([spec.wire_id]) + p)
        )
    )


corrupted_frame = valid_frame().map(lambda f: f[:-1] + bytes([f[-1] ^ 1]))
streams = st.lists(st.one_of(st.binary(max_size=40), valid_frame(), corrupted_frame), max_size=12)


def executed_frames_are_valid(module: Module) -> list[bytes]:
    executed = [e.data for e in module.trace if e.direction == "in" and e.note == "command"]
    for f in executed:
        assert checksum(f[:-2]) == int.from_bytes(f[-2:], "big"), f.hex(" ")
    return executed


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(parts=streams, chunk=st.integers(1, 64), command_set=st.sampled_from(["2015", "2014"]))
def test_any_stream_never_raises_and_never_executes_a_bad_checksum(parts, chunk, command_set):
    m = build_module(ModuleConfig(trace=True, command_set=command_set))
    data = b"".join(parts)
    for i in range(0, len(data), chunk):
        m.usb.port.host_write(data[i:i + chunk])
        m.step()
    m.run(2)
    executed_frames_are_valid(m)
    cs = m.command_set
    assert m.usb.frames_executed == len(executed_frames_are_valid(m))
    assert m.usb.bad_checksums == sum(
        1 for e in m.trace if e.direction == "in" and e.note == "bad checksum")
    assert all(e.data[0] in cs for e in m.trace if e.direction == "in")


@settings(max_examples=150, deadline=None)
@given(garbage=st.binary(max_size=300))
def test_a_valid_command_after_garbage_is_executed_once_the_garbage_is_discarded(garbage):
    m = build_module(ModuleConfig(trace=True))
    m.usb.port.host_write(garbage)
    m.run(2)
    m.usb.reset_parser()  # what ~3 s of silence does (timeout tested above)
    m.usb.port.host_write(PING)
    m.step()
    assert executed_frames_are_valid(m)[-1] == PING


@settings(max_examples=100, deadline=None)
@given(garbage=st.binary(max_size=300).map(lambda b: bytes(x for x in b if x not in CURRENT)))
def test_non_command_garbage_needs_no_timeout(garbage):
    h = Host()
    h.send(garbage + PING)
    h.step(2)
    assert h.iface.frames_executed == 1 and h.iface.bytes_discarded == len(garbage)


def test_2014_set_has_its_own_header_bytes():
    h = Host(command_set="2014")
    h.send(bytes([0x12, 0x13, 0x22]) + PING)
    assert h.step() == PING_ACK
    assert h.iface.bytes_discarded == 3
    assert set(LEGACY_2014) == {0x01, 0x03, 0x04, 0x10, 0x14, 0x20, 0x21, 0x27, 0x28}


@pytest.mark.slow
# Random streams execute random SET_STATEs: garbage floats in the INS overflow to inf/nan, as they
# would on the µC's FPU (IEEE, no trap), and quietly: a numpy warning fails the test.
@pytest.mark.filterwarnings("error::RuntimeWarning")
def test_1e5_random_streams_through_one_parser():
    """10^5 random streams (raw bytes, valid frames, corrupted frames), then a PING each time."""
    rng = np.random.default_rng(20150115)
    m = build_module(ModuleConfig(trace=True))
    usb = m.usb
    specs = [s for s in CURRENT.values() if s.payload_len <= 60]
    pool = rng.integers(0, 256, 1 << 22, dtype=np.uint8).tobytes()
    n_parts = rng.integers(0, 4, 100_000)
    kinds = rng.random((100_000, 3))
    picks = rng.integers(0, 1 << 30, (100_000, 3, 3))
    for k in range(100_000):
        parts = []
        for j in range(n_parts[k]):
            r = kinds[k, j]
            a, b, c = (int(x) for x in picks[k, j])
            start = a % (len(pool) - 64)
            if r < 0.5:
                parts.append(pool[start:start + b % 24])
            else:
                spec = specs[c % len(specs)]
                f = with_checksum(bytes([spec.wire_id]) + pool[start:start + spec.payload_len])
                if r > 0.8:
                    f = f[:-1] + bytes([f[-1] ^ 0x5A])
                parts.append(f)
        usb.feed(b"".join(parts))
        usb.reset_parser()
        usb.feed(PING)
        assert executed_frames_are_valid(m)[-1] == PING
        m.trace.clear()
        if k % 64 == 0:
            m.step()  # let the sequence and transmission run with whatever got set up
            usb.port.host_read()
    assert usb.bad_checksums > 10_000


@settings(max_examples=60, deadline=None)
@given(parts=streams, chunk=st.integers(1, 64))
def test_same_random_inputs_twice_give_identical_bytes_and_traces(parts, chunk):
    def run() -> tuple[bytes, list]:
        m = build_module(ModuleConfig(trace=True))
        data = b"".join(parts)
        out = bytearray()
        for i in range(0, len(data), chunk):
            m.usb.port.host_write(data[i:i + chunk])
            m.step()
            out += m.usb.port.host_read()
        m.run(3)
        out += m.usb.port.host_read()
        return bytes(out), list(m.trace)

    assert run() == run()


# ------------------------------------------------------------- resynchronisation, byte by byte
# The rule (docs/protocol-extensions.md, "Garbage on the line"): between frames a byte that is not a
# command id of the numbering is discarded; a command id opens a frame that takes the next
# payload + 2 bytes whatever they are; the complete frame runs if its checksum is right and is
# dropped whole otherwise, its bytes never looked at again; a partial frame is dropped after
# 2·10^8 cycles without a byte (or when the link goes down). Each vector: the chunks the host
# sends (hex, then the loops run before the next chunk), the commands acknowledged (in order),
# the frames dropped for their checksum, the bytes discarded between frames, the partial frame left.

OFF = "22 00 22"  # OUTPUT_ALL_OFF
RESYNC_VECTORS = [
    # name, numbering, [(hex, loops)], acked ids, bad checksums, discarded, partial frame left
    ("non-command bytes are skipped", "2015", [("00 02 50 A0 AA FF 7F 03 00 03", 1)], [0x03], 0, 7, ""),
    ("an ack echoed back: A0 and AA are skipped, its 03 opens a frame", "2015",
     [("A0 03 00 A3 AA 03 00 03", 1)], [0x03], 1, 2, ""),
    ("a command id opens a frame that swallows the PING after it", "2015",
     [("13 03 00 03 00 00 12 34", 1)], [], 1, 0, ""),
    ("the swallowed bytes are not searched again", "2015",
     [("13 03 00 03 00 00 12 34 03 00 03", 1)], [0x03], 1, 0, ""),
    ("a stray byte knocks out the commands that follow it, one after another", "2015",
     [("03 " + OFF + " 03 00 03 03 00 03", 1)], [], 3, 0, "03"),
    ("... until the bytes sent happen to close the open frame", "2015",
     [("03 " + OFF + " 03 00 03 03 00 03 00 00 " + OFF, 1)], [0x22], 4, 0, ""),
    ("a right checksum runs whatever came before it", "2015", [("FF FF 00 " + OFF, 1)], [0x22], 0, 3, ""),
    ("a frame may span many loops", "2015", [("13 19 00", 5), ("01 86", 5), ("A0 01 53", 1)], [0x13], 0, 0,
     ""),
    ("SET_STATE_254 swallows the next 257 bytes", "2015",
     [("17" + " 03 00 03" * 85 + " 03 00", 2), ("03 00 03", 1)], [0x03], 1, 0, ""),
    ("zeros complete an open frame and are then skipped", "2015",
     [("17 05", 1), ("00" * 300, 1), ("03 00 03", 1)], [0x03], 1, 300 - 256, ""),
    ("ACK 0x01 runs but is not acknowledged", "2015", [("01 00 05 00 06 03 00 03", 1)], [0x03], 0, 0, ""),
    ("2015 ids are garbage in the 2014 numbering", "2014", [("22 00 22 13 32 03 00 03", 1)], [0x03], 0, 5,
     ""),
    ("14 00 14 is a whole frame in the 2014 numbering", "2014", [("14 00 14", 1)], [0x14], 0, 0, ""),
    ("14 00 14 waits for 13 more bytes in the 2015 numbering", "2015", [("14 00 14", 1)], [], 0, 0,
     "14 00 14"),
]


def _acked(out: bytes) -> list[int]:
    return [out[i + 1] for i in range(0, len(out), 4)] if out else []


@pytest.mark.parametrize(("name", "numbering", "chunks", "acked", "bad", "discarded", "partial"),
                         RESYNC_VECTORS, ids=[v[0] for v in RESYNC_VECTORS])
def test_the_parser_resynchronises_by_the_written_rule(name, numbering, chunks, acked, bad, discarded,
                                                       partial):
    h = Host(command_set=numbering)
    out = b""
    for data, loops in chunks:
        h.send(bytes.fromhex(data))
        out += h.step(loops)
    assert _acked(out) == acked
    assert h.iface.bad_checksums == bad
    assert h.iface.bytes_discarded == discarded
    assert h.iface.partial_frame == bytes.fromhex(partial)


TIMEOUT_TICKS = RX_TIMEOUT_CYCLES // 64_000  # 3125 loops at 1 kHz


@pytest.mark.parametrize(("silence", "dropped"), [(TIMEOUT_TICKS - 2, False), (TIMEOUT_TICKS + 2, True)])
def test_a_partial_frame_is_dropped_after_3_125_s_without_a_byte(silence, dropped):
    h = Host()
    h.send(bytes.fromhex("03"))  # a PING's header alone
    h.step(silence)
    h.send(PING)
    out = h.step(2)
    # dropped: the new PING is a frame of its own; kept: 03 | 03 00 (bad), then 03 waits
    assert out == (PING_ACK if dropped else b"")
    assert h.iface.partial_timeouts == (1 if dropped else 0)


def test_any_byte_restarts_the_timeout_even_one_that_completes_nothing():
    h = Host()
    h.send(bytes.fromhex("17"))  # SET_STATE_254: 257 bytes to come
    for _ in range(3):
        h.step(TIMEOUT_TICKS - 100)
        h.send(b"\x00")
    h.step(TIMEOUT_TICKS - 100)
    assert h.iface.partial_frame == bytes.fromhex("17 00 00 00") and h.iface.partial_timeouts == 0
    h.step(200)
    assert h.iface.partial_frame == b"" and h.iface.partial_timeouts == 1


def test_a_link_that_goes_down_drops_the_partial_frame():
    h = Host()
    h.send(bytes.fromhex("13 19"))
    h.step()
    h.port.disconnect()
    h.step()
    h.port.connect()
    h.send(PING)
    assert h.step() == PING_ACK
    assert h.iface.partial_disconnects == 1
