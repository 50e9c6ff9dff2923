"""The framing checks (protocol.md §1, §2, §7): the ping, acknowledgements, bytes that are no
command, wrong checksums, the parser's timeout and its resynchronisation after garbage."""

from __future__ import annotations

import random
from typing import Any

from protocol.commands import CommandSet
from protocol.frames import build_command, checksum, hexdump
from protocol.ids import Command, StateId

from ..driver import PULL
from . import U32, Check, Context, check, counter, raw

#: Golden bytes of protocol.md §2 (checked by hand there).
PING = bytes.fromhex("030003")
PING_ACK = bytes.fromhex("A00300A3")


@check("ping", "framing and checksum: PING 03 00 03 is answered by exactly A0 03 00 A3 (checksum MSB first)")
def check_ping(ctx: Context) -> str:
    d = ctx.driver
    sent = d.write(PING)
    got = d.read_raw(4, 1.0)
    ctx.proof("ping", sent, got)
    if got != PING_ACK:
        ctx.fail(f"expected {hexdump(PING_ACK)}, got {hexdump(got) or 'nothing'}")
    return "ack is byte-exact"


@check("acks", "every valid command of the numbering is acknowledged with A0 · id · checksum")
def check_acks(ctx: Context) -> str:
    d = ctx.driver
    gp = d.pull(StateId.GP_ID)[1].frame.payload
    sweep: list[tuple[Command, dict[str, Any]]] = [
        (Command.PING, {}),
        (Command.MCU_ID, {}),
        (Command.GP_TEST, {"a": 0x01020304, "b": 0x05060708}),
        (Command.SET_IMU_BANDWIDTH, {"dlpf_cfg": 7}),  # values >= 7 are ignored
        (Command.SET_STATE_1, {"state_id": StateId.GP_ID, "data": gp}),  # writes back its own value
        (Command.SET_STATE_4, {"state_id": 0xB5, "data": b""}),  # ids >= 0xB0 have no state
        (Command.SET_STATE_12, {"state_id": 0xB5, "data": b""}),
        (Command.SET_STATE_24, {"state_id": 0xB5, "data": b""}),
        (Command.SET_STATE_48, {"state_id": 0xB5, "data": b""}),
        (Command.SET_STATE_254, {"state_id": 0xB5, "data": b""}),
        (Command.OUTPUT_STATE, {"state_id": 0xB5, "mode": 0}),
        (Command.OUTPUT_MULTIPLE_STATES, {"state_ids": [0] * 8, "mode": 0}),
        (Command.STATE_IF_SETUP, {"flag_id": 0, "mode": 0, "state_ids": [0] * 8}),
        (Command.OUTPUT_IMU_RD, {"imu_selector": 0, "mode": 0}),
        (Command.RUN_PROC, {"proc_id": 0x30, "slot": 0}),  # id >= 0x30: ignored
        (Command.RUN_MULT_PROC, {"proc_ids": [0] * 8}),
        (Command.RESET_PROC_SETUP, {"flag_id": StateId.INIT_DONE}),
        (Command.STORE_AND_EMPTY, {}),
        (Command.RESTORE_PROC_SEQU, {}),
        (Command.MIMU_FRONTEND, {}),
        (Command.NORMAL_IMU, {"mode": 0}),
        (Command.NORMAL_IMU_WITH_BIAS_EST, {"mode": 0}),
        (Command.RESET_ZUPT_AIDED_INS, {}),
        (Command.SETUP_DEBUG_PROC, {"proc_ids": [0] * 10, "state_ids": [0] * 10, "interface": 1}),
        (Command.INPUT_IMU_RD, {"timestamp": 0, "imu": [[0] * 6] * 4}),
        (Command.ALL_PROC_OFF, {}),
        (Command.STEPWISE_DEAD_RECKONING, {}),
        (Command.OUTPUT_ALL_OFF, {}),
    ]
    swept = {m for m, _ in sweep}
    missing = [spec.name for spec in ctx.cs.values() if spec.acked and spec.command not in swept]
    assert not missing, f"sweep misses {missing}"  # a bug in this suite, not the device
    n = 0
    for meaning, fields in sweep:
        if not d.supports(meaning):
            continue
        sent, ack = d.command(meaning, **fields)
        ctx.proof(meaning.name, sent, ack.raw)
        n += 1
    return f"{n} commands, {n} acks"


@check("ack-not-acked", "the packet ACK (0x01) is never acknowledged; a PING right after it is")
def check_ack_not_acked(ctx: Context) -> str:
    d = ctx.driver
    first = d.cursor
    sent = d.write(bytes.fromhex("0112340047") + PING)
    got = d.read_raw(4, 1.0)
    ctx.proof("ACK 0x1234 then PING", sent, got)
    if got != PING_ACK:
        ctx.fail(f"the first bytes back must be the PING's ack {hexdump(PING_ACK)}, got {hexdump(got)}")
    d.wait_ticks(20)
    acks = [r for r in d.since(first) if r.is_ack and r.frame.command_id == 0x01]
    if acks:
        ctx.fail("the module acknowledged an ACK", sent, raw(acks))
    return "no A0 01 … came back"


@check("garbage", "bytes that are not command ids are skipped; a command after them is executed")
def check_garbage(ctx: Context) -> str:
    d = ctx.driver
    junk = bytes(b for b in (0xFF, 0x55, 0xA0, 0xAA, 0x00, 0x02, 0x50, 0xB3, 0x7F, 0xE1, 0x09)
                 if not ctx.cs.is_command(b))
    sent = d.write(junk + PING)
    got = d.read_raw(4, 1.0)
    ctx.proof(f"{len(junk)} garbage bytes, then PING", sent, got)
    if got != PING_ACK:
        ctx.fail(f"expected the PING's ack {hexdump(PING_ACK)} after garbage, "
                 f"got {hexdump(got) or 'nothing'}")
    return f"{len(junk)} garbage bytes skipped"


@check("bad-checksum", "a frame with a wrong checksum is dropped silently (no ack, no effect)")
def check_bad_checksum(ctx: Context) -> str:
    d = ctx.driver
    first = d.cursor
    bad = bytes.fromhex("030004")
    sent = d.write(bad + PING)
    got = d.read_raw(4, 1.0)
    ctx.proof("PING with checksum 00 04, then a good PING", sent, got)
    if got != PING_ACK:
        ctx.fail(f"expected one ack {hexdump(PING_ACK)} (for the good PING), got {hexdump(got) or 'nothing'}")
    d.wait_ticks(20)
    pings = [r for r in d.since(first) if r.is_ack and r.frame.command_id == 0x03]
    if len(pings) != 1:
        ctx.fail(f"{len(pings)} PING acks for one good and one bad PING", sent, raw(pings))
    if d.supports(Command.SET_STATE_4):
        before = d.pull(StateId.TH_ZUPT)[1].frame.payload
        frame = bytearray(build_command(Command.SET_STATE_4, state_id=StateId.TH_ZUPT,
                                        data=bytes(4 - i for i in range(4))))
        frame[-1] ^= 0x01
        s2 = d.write(bytes(frame))
        d.wait_ticks(5)
        after_sent, after = d.pull(StateId.TH_ZUPT)
        ctx.proof("SET_STATE_4 TH_ZUPT with a bad checksum, then pull TH_ZUPT", s2 + after_sent, after.raw)
        if after.frame.payload != before:
            ctx.fail(f"a bad-checksum SET_STATE changed TH_ZUPT from {hexdump(before)} to "
                     f"{hexdump(after.frame.payload)}")
    return "bad frame dropped without ack"


@check("parser-timeout", "a partial frame is discarded after ~3 s of silence (2·10^8 cycles)",
       duration="3.5 s (waits out the parser timeout)")
def check_parser_timeout(ctx: Context) -> str:
    d = ctx.driver
    partial = bytes.fromhex("2002")  # OUTPUT_STATE needs 5 bytes
    sent = d.write(partial)
    d.collect(3.5)
    sent += d.write(PING)
    got = d.read_raw(4, 1.0)
    ctx.proof("2 bytes of OUTPUT_STATE, 3.5 s silence, PING", sent, got)
    if got != PING_ACK:
        ctx.fail(f"the partial frame was not discarded: expected {hexdump(PING_ACK)}, got "
                 f"{hexdump(got) or 'nothing'}")
    return "stale partial frame dropped"


#: Check "garbage-resync": the garbage bytes before its PING, and the most device ticks (1 kHz) from
#: the tick count read before the garbage to the PING's execution. A module following protocol.md §7
#: needs a few ticks to parse it (400 bytes per loop); the rest is the link: the count's way back to the
#: host, the garbage's way to the module (1 kB over Bluetooth's 115200 baud: 90 ms) and the latency
#: (20–40 ms each way): about 0.2 s, within 0.5 s.
RESYNC_GARBAGE_BYTES = 1024
RESYNC_DEADLINE_TICKS = 500
#: The seed of the check's random garbage (the same bytes on every run).
RESYNC_SEED = 20150115


def closed_garbage(cs: CommandSet, n: int, seed: int = RESYNC_SEED) -> bytes:
    """At least *n* random bytes in which, by protocol.md §7, every frame a command id opens also
    closes (it takes the next payload + 2 bytes, whatever they are) with a wrong checksum: a parser
    following §7 runs none of them and expects a command id right after the last. The last frame is
    the numbering's longest, with that command id again as its last payload byte: a parser that
    looked for a header inside a dropped frame would take the bytes after the garbage into a frame."""
    rng = random.Random(seed)
    longest = max(cs.values(), key=lambda spec: spec.payload_len)
    out = bytearray()
    frame = bytearray()
    need = 0  # bytes the open frame still takes
    while len(out) < n - longest.payload_len - 3 or need:
        b = rng.randrange(256)
        if not need:
            if cs.is_command(b):
                frame[:] = bytes([b])
                need = cs[b].payload_len + 2
        else:
            frame.append(b)
            need -= 1
            if not need and checksum(bytes(frame[:-2])) == int.from_bytes(frame[-2:], "big"):
                b ^= 0x01  # this one would run: spoil its checksum
        out.append(b)
    payload = bytes(rng.randrange(256) for _ in range(longest.payload_len - 1)) + bytes([longest.wire_id])
    body = bytes([longest.wire_id]) + payload
    wrong = (checksum(body) + 1) & 0xFFFF
    return bytes(out) + body + wrong.to_bytes(2, "big")


@check("garbage-resync", f"after {RESYNC_GARBAGE_BYTES} bytes of garbage a PING is answered within "
       f"{RESYNC_DEADLINE_TICKS} ms of device time: garbage without a command id, then random garbage "
       "whose every frame closes inside it with a wrong checksum (§7: after a frame, good or bad, the "
       "next byte is a header; no garbage frame runs)")
def check_garbage_resync(ctx: Context) -> str:
    d = ctx.driver
    junk = bytes(b for b in range(256) if not ctx.cs.is_command(b))
    garbage = {"no command id": (junk * (RESYNC_GARBAGE_BYTES // len(junk) + 1))[:RESYNC_GARBAGE_BYTES],
               "frames with wrong checksums": closed_garbage(ctx.cs, RESYNC_GARBAGE_BYTES)}
    ping_id, pull_id = d.wire_id(Command.PING), d.wire_id(Command.OUTPUT_STATE)
    pull = build_command(Command.OUTPUT_STATE, command_set=ctx.cs, state_id=StateId.INTERRUPT_COUNTER,
                         mode=PULL)
    took = []
    for label, junk_bytes in garbage.items():
        t0 = d.ticks()
        first = d.mark()
        # the pull after the PING tells when the PING ran (the same loop or the next)
        sent = d.write(junk_bytes + PING + pull)
        ping = d.expect(lambda r: r.is_ack and r.frame.command_id == ping_id, 2.0)
        if ping is None:
            ctx.fail(f"{label}: no ack of the PING after {len(junk_bytes)} bytes of garbage",
                     sent[-16:], raw(d.since(first)))
        stray = [r for r in d.since(first) if r.is_ack and r.frame.command_id not in (ping_id, pull_id)]
        if stray:
            ctx.fail(f"{label}: a frame of the garbage ran (acks {hexdump(raw(stray))})", sent[:32],
                     raw(stray))
        d.expect(lambda r: r.is_ack and r.frame.command_id == pull_id, 1.0)
        pkt = d.next_packet(1.0)
        if pkt is None or len(pkt.frame.payload) != 4:
            ctx.fail(f"{label}: no INTERRUPT_COUNTER after the PING", pull, raw(d.since(first)))
        ticks = (counter(pkt) - t0) % U32
        ctx.proof(f"{label}: {len(junk_bytes)} bytes, PING, pull INTERRUPT_COUNTER ({ticks} ticks)",
                  sent[-(len(PING) + len(pull) + 8):], ping.raw + pkt.raw)
        if ticks > RESYNC_DEADLINE_TICKS:
            ctx.fail(f"{label}: the PING ran {ticks} ticks after the count before the garbage, "
                     f"more than {RESYNC_DEADLINE_TICKS}")
        took.append(f"{label}: {len(junk_bytes)} B, {ticks} ticks")
    return "; ".join(took)


#: The framing checks, in the order they run.
CHECKS: tuple[Check, ...] = (
    check_ping,
    check_acks,
    check_ack_not_acked,
    check_garbage,
    check_bad_checksum,
    check_parser_timeout,
    check_garbage_resync,
)
