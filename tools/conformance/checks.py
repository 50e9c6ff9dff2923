"""The conformance checks: one registry, each check written from protocol.md alone.

Every check starts from a quiet interface (:meth:`DeviceDriver.sync`: outputs
off, queue emptied, processing off, lossy), talks to the device, and either
returns a one-line verdict or raises :class:`CheckFailed`. It records the
exchanges that prove its verdict with :meth:`Context.proof`.

Timings are measured in the device's own loop cycles (the INTERRUPT_COUNTER
state it sends back), never with the host's clock, so a real module and an
emulator running faster than real time get the same verdicts. Wall-clock
deadlines only bound the waiting; checks that must wait state how long.

The checks of the group ``extensions`` look for the emulator's extensions of the protocol
(:mod:`protocol.extensions`, docs/protocol-extensions.md): present and right → PASS, present and
wrong → FAIL, absent → ABSENT, which is no failure (a real module has none of them).
"""

from __future__ import annotations

import random
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from protocol.codec import decode_step
from protocol.commands import CommandSet
from protocol.extensions import EXTENSION_STATES, HEIGHT_COMPENSATION_SLOT, height_compensation_on
from protocol.frames import build_command, checksum, hexdump
from protocol.ids import Command, OutputMode, StateId, ps_dt_id
from protocol.states import state_spec

from .driver import PULL, PULL_LOSSLESS, CheckFailed, CheckSkipped, DeviceDriver, ExtensionAbsent, Received
from .results import CheckResult, Proof, RunReport, Status

#: Golden bytes of protocol.md §2 (checked by hand there).
PING = bytes.fromhex("030003")
PING_ACK = bytes.fromhex("A00300A3")
SET_TH_ZUPT_100000 = bytes.fromhex("1319000186A00153")
SET_STATE_4_ACK = bytes.fromhex("A01300B3")
#: The lossless resend interval, protocol.md §6.
RESEND_CYCLES = 128
#: A step packet: AA, number (2), length 0x3A, 58-byte payload, checksum (2).
STEP_PACKET_LEN = 64

U32 = 1 << 32


@dataclass
class Context:
    """What a check gets: the driver and a place to put its proofs."""

    driver: DeviceDriver
    proofs: list[Proof] = field(default_factory=list)

    @property
    def cs(self) -> CommandSet:
        return self.driver.cs

    def proof(self, label: str, sent: bytes = b"", received: bytes = b"") -> None:
        self.proofs.append(Proof(label, bytes(sent), bytes(received)))

    def fail(self, message: str, sent: bytes = b"", received: bytes = b"") -> None:
        if sent or received:
            self.proof("evidence", sent, received)
        raise CheckFailed(message)

    # shared helpers -----------------------------------------------------------
    def mcu_id(self) -> bytes:
        sent, pkt = self.driver.pull(StateId.MCU_ID)
        self.proof("pull MCU_ID (0x04)", sent, pkt.raw)
        if len(pkt.frame.payload) != 15:
            self.fail(f"MCU_ID must be 15 bytes, got {len(pkt.frame.payload)}", sent, pkt.raw)
        return pkt.frame.payload


@dataclass(frozen=True)
class Check:
    """One conformance check: its name, what it shows, how long it takes, and the code."""

    name: str
    description: str
    duration: str
    fn: Callable[[Context], str | None]
    needs: tuple[Command, ...] = ()
    #: "protocol" (protocol.md) or "extensions" (the emulator's own: absent is no failure)
    group: str = "protocol"

    def applies_to(self, cs: CommandSet) -> bool:
        return all(cs.supports(m) for m in self.needs)


#: Every check, in the order they run.
CHECKS: dict[str, Check] = {}


def check(name: str, description: str, duration: str = "< 1 s", needs: tuple[Command, ...] = (),
          group: str = "protocol"):
    """Register a check function under *name*."""

    def deco(fn: Callable[[Context], str | None]) -> Callable[[Context], str | None]:
        if name in CHECKS:
            raise ValueError(f"duplicate check {name}")
        CHECKS[name] = Check(name, description, duration, fn, needs, group)
        return fn

    return deco


def _counter(r: Received, offset: int = 0) -> int:
    return int.from_bytes(r.frame.payload[offset:offset + 4], "big")


def _diffs(values: list[int], modulo: int = U32) -> list[int]:
    """Differences of consecutive values, modulo the counter's width."""
    return [(b - a) % modulo for a, b in zip(values[:-1], values[1:], strict=True)]


def _packets(frames: list[Received]) -> list[Received]:
    return [r for r in frames if r.is_packet]


def _raw(frames: list[Received], limit: int = 12) -> bytes:
    return b"".join(r.raw for r in frames[:limit])


# =========================================================================== framing


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
        ctx.fail("the module acknowledged an ACK", sent, _raw(acks))
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
        ctx.fail(f"{len(pings)} PING acks for one good and one bad PING", sent, _raw(pings))
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
                     sent[-16:], _raw(d.since(first)))
        stray = [r for r in d.since(first) if r.is_ack and r.frame.command_id not in (ping_id, pull_id)]
        if stray:
            ctx.fail(f"{label}: a frame of the garbage ran (acks {hexdump(_raw(stray))})", sent[:32],
                     _raw(stray))
        d.expect(lambda r: r.is_ack and r.frame.command_id == pull_id, 1.0)
        pkt = d.next_packet(1.0)
        if pkt is None or len(pkt.frame.payload) != 4:
            ctx.fail(f"{label}: no INTERRUPT_COUNTER after the PING", pull, _raw(d.since(first)))
        ticks = (_counter(pkt) - t0) % U32
        ctx.proof(f"{label}: {len(junk_bytes)} bytes, PING, pull INTERRUPT_COUNTER ({ticks} ticks)",
                  sent[-(len(PING) + len(pull) + 8):], ping.raw + pkt.raw)
        if ticks > RESYNC_DEADLINE_TICKS:
            ctx.fail(f"{label}: the PING ran {ticks} ticks after the count before the garbage, "
                     f"more than {RESYNC_DEADLINE_TICKS}")
        took.append(f"{label}: {len(junk_bytes)} B, {ticks} ticks")
    return "; ".join(took)


# =========================================================================== commands


@check("set-state", "SET_STATE_n writes a state (golden 13 19 00 01 86 A0 01 53), read back with a pull; "
       "size rule: only states of size <= n, copying the state's own size",
       needs=(Command.SET_STATE_1, Command.SET_STATE_4, Command.SET_STATE_12))
def check_set_state(ctx: Context) -> str:
    d = ctx.driver
    original = d.pull(StateId.TH_ZUPT)[1].frame.payload
    gp_original = d.pull(StateId.GP_ID)[1].frame.payload
    try:
        sent = d.write(SET_TH_ZUPT_100000)
        ack = d.expect(d.ack_of(Command.SET_STATE_4), 1.0)
        ctx.proof("SET_STATE_4 TH_ZUPT = 100000", sent, ack.raw if ack else b"")
        if ack is None or ack.raw != SET_STATE_4_ACK:
            ctx.fail(f"expected ack {hexdump(SET_STATE_4_ACK)}")
        s, p = d.pull(StateId.TH_ZUPT)
        ctx.proof("pull TH_ZUPT", s, p.raw)
        if p.frame.payload != bytes.fromhex("000186A0"):
            ctx.fail(f"TH_ZUPT reads {hexdump(p.frame.payload)}, expected 00 01 86 A0")
        # SET_STATE_1 on a 4-byte state: ignored (acked)
        s, _ = d.command(Command.SET_STATE_1, state_id=StateId.TH_ZUPT, data=b"\x07")
        s2, p = d.pull(StateId.TH_ZUPT)
        ctx.proof("SET_STATE_1 on 4-byte TH_ZUPT (ignored), pull", s + s2, p.raw)
        if p.frame.payload != bytes.fromhex("000186A0"):
            ctx.fail(f"SET_STATE_1 changed a 4-byte state: TH_ZUPT = {hexdump(p.frame.payload)}")
        # SET_STATE_12 on the 1-byte GP_ID: copies 1 byte
        s, _ = d.command(Command.SET_STATE_12, state_id=StateId.GP_ID,
                         data=bytes([0x5A]) + bytes(range(1, 12)))
        s2, p = d.pull(StateId.GP_ID)
        ctx.proof("SET_STATE_12 GP_ID = 5A 01 02 …, pull GP_ID", s + s2, p.raw)
        if p.frame.payload != b"\x5a":
            ctx.fail(f"GP_ID reads {hexdump(p.frame.payload)}, expected 5A (state size copied)")
    finally:
        d.command(Command.SET_STATE_4, state_id=StateId.TH_ZUPT, data=original)
        d.command(Command.SET_STATE_1, state_id=StateId.GP_ID, data=gp_original)
    return "written, read back, size rule holds"


@check("pull", "OUTPUT_STATE with mode 0x20 outputs the state exactly once, in the next packet")
def check_pull(ctx: Context) -> str:
    d = ctx.driver
    sent, pkt = d.pull(StateId.INTERRUPT_COUNTER)
    ctx.proof("pull INTERRUPT_COUNTER", sent, pkt.raw)
    if len(pkt.frame.payload) != 4:
        ctx.fail(f"payload must be the 4-byte counter, got {hexdump(pkt.frame.payload)}")
    _, _, strays = d.wait_ticks(50)
    if strays:
        ctx.fail(f"{len(strays)} more packets after a single pull", received=_raw(strays))
    return "one packet, then nothing"


@check("mcu-id", "MCU_ID outputs state 0x04 (15-byte serial number) once")
def check_mcu_id(ctx: Context) -> str:
    d = ctx.driver
    sent, ack = d.command(Command.MCU_ID)
    pkt = d.next_packet(1.0)
    ctx.proof("MCU_ID", sent, ack.raw + (pkt.raw if pkt else b""))
    if pkt is None or len(pkt.frame.payload) != 15:
        ctx.fail("expected one packet with the 15-byte serial number")
    if ctx.mcu_id() != pkt.frame.payload:
        ctx.fail("MCU_ID's packet differs from state 0x04")
    _, _, strays = d.wait_ticks(20)
    if strays:
        ctx.fail("MCU_ID output more than once", received=_raw(strays))
    return f"serial {hexdump(pkt.frame.payload)}"


@check("gp-id", "GP_ID (0x05) is a user byte: SET_STATE_1 then pull reads it back; GP_TEST does nothing",
       needs=(Command.SET_STATE_1, Command.GP_TEST))
def check_gp_id(ctx: Context) -> str:
    d = ctx.driver
    original = d.pull(StateId.GP_ID)[1].frame.payload
    try:
        s, _ = d.command(Command.SET_STATE_1, state_id=StateId.GP_ID, data=b"\xa5")
        s2, p = d.pull(StateId.GP_ID)
        ctx.proof("SET_STATE_1 GP_ID = A5, pull", s + s2, p.raw)
        if p.frame.payload != b"\xa5":
            ctx.fail(f"GP_ID reads {hexdump(p.frame.payload)}, expected A5")
        first = d.cursor
        s, ack = d.command(Command.GP_TEST, a=0xDEADBEEF, b=0x01234567)
        _, _, strays = d.wait_ticks(10)
        ctx.proof("GP_TEST", s, ack.raw)
        if strays or _packets(d.since(first)[:1]):
            ctx.fail("GP_TEST produced output", received=_raw(strays))
    finally:
        d.command(Command.SET_STATE_1, state_id=StateId.GP_ID, data=original)
    return "A5 read back"


@check("packet-numbering", "packet numbers go up by exactly 1 per packet on an interface")
def check_numbering(ctx: Context) -> str:
    d = ctx.driver
    numbers = []
    for _ in range(5):
        s, p = d.pull(StateId.INTERRUPT_COUNTER)
        numbers.append(p.frame.number)
        ctx.proof(f"pull #{len(numbers)}", s, p.raw)
    steps = _diffs(numbers, 65536)
    if any(s != 1 for s in steps):
        ctx.fail(f"packet numbers {[f'0x{n:04X}' for n in numbers]} do not go up by 1")
    return f"0x{numbers[0]:04X} … 0x{numbers[-1]:04X}"


@check("output-rates", "OUTPUT_STATE rate d fires every 2^(d-1) loop cycles (measured with INTERRUPT_COUNTER "
       "in the packets); rate 0 switches it off", duration="~1 s")
def check_rates(ctx: Context) -> str:
    d = ctx.driver
    seen = []
    for rate in (1, 2, 3, 5):
        div = 1 << (rate - 1)
        s, _ = d.command(Command.OUTPUT_STATE, state_id=StateId.INTERRUPT_COUNTER, mode=rate)
        pkts = _packets(d.collect(1.0 + 0.008 * div, until=lambda f: len(_packets(f)) >= 8))
        ctx.proof(f"rate {rate} (every {div})", s, _raw(pkts, 3))
        if len(pkts) < 8:
            ctx.fail(f"rate {rate}: only {len(pkts)} packets")
        steps = _diffs([_counter(p) for p in pkts])
        if any(st != div for st in steps):
            ctx.fail(f"rate {rate}: counters step by {steps}, expected every {div}", received=_raw(pkts))
        seen.append(f"{rate}→{div}")
        s, _ = d.command(Command.OUTPUT_STATE, state_id=StateId.INTERRUPT_COUNTER, mode=0)
        _, _, strays = d.wait_ticks(2 * div + 10)
        if strays:
            ctx.fail(f"rate 0 did not switch the output off: {len(strays)} packets after", s, _raw(strays))
    return "dividers " + ", ".join(seen) + "; rate 0 off"


def _periodic_pair(ctx: Context, first: tuple[int, int], second: tuple[int, int], n: int = 12
                   ) -> list[Received]:
    """Switch on state first[0] at rate first[1], wait until it fires, then second; packets after that."""
    d = ctx.driver
    s1, _ = d.command(Command.OUTPUT_STATE, state_id=first[0], mode=first[1])
    if d.next_packet(1.0) is None:
        ctx.fail(f"no packet after switching on state 0x{first[0]:02X}", s1)
    s2, _ = d.command(Command.OUTPUT_STATE, state_id=second[0], mode=second[1])
    pkts = _packets(d.collect(2.0, until=lambda f: len(_packets(f)) >= n))
    ctx.proof(f"0x{first[0]:02X} at rate {first[1]}, then 0x{second[0]:02X} at rate {second[1]}",
              s1 + s2, _raw(pkts, 4))
    d.command(Command.OUTPUT_ALL_OFF)
    if len(pkts) < n:
        ctx.fail(f"only {len(pkts)} packets")
    return pkts


@check("phase-sync", "§5 timing: MCU_ID at divider 4, then INTERRUPT_COUNTER at divider 2: the slower "
       "state lands only in packets with the faster one")
def check_phase_sync(ctx: Context) -> str:
    mcu = ctx.mcu_id()
    pkts = _periodic_pair(ctx, (StateId.MCU_ID, 3), (StateId.INTERRUPT_COUNTER, 2), n=12)
    sizes = [len(p.frame.payload) for p in pkts]
    if 15 in sizes:
        ctx.fail(f"MCU_ID came without INTERRUPT_COUNTER (payload sizes {sizes}): not in phase",
                 received=_raw(pkts))
    if sorted(set(sizes)) != [4, 19]:
        ctx.fail(f"payload sizes {sizes}, expected 4 (counter) and 19 (counter + MCU_ID)")
    both = [p for p in pkts if len(p.frame.payload) == 19]
    if any(p.frame.payload[4:] != mcu for p in both):
        ctx.fail("a combined packet is not counter · MCU_ID (ascending ids)", received=_raw(both))
    steps = _diffs([_counter(p) for p in pkts])
    if any(s != 2 for s in steps):
        ctx.fail(f"INTERRUPT_COUNTER steps {steps}, expected 2")
    bsteps = _diffs([_counter(p) for p in both])
    if any(s != 4 for s in bsteps):
        ctx.fail(f"MCU_ID packets {bsteps} cycles apart, expected 4")
    return f"{len(both)} of {len(pkts)} packets carry both, every 4 cycles"


@check("ascending-ids", "states requested in descending id order arrive in ascending order in one packet")
def check_ascending(ctx: Context) -> str:
    d = ctx.driver
    mcu = ctx.mcu_id()
    msgs = []
    if d.supports(Command.OUTPUT_MULTIPLE_STATES):
        gp = d.pull(StateId.GP_ID)[1].frame.payload
        s, _ = d.command(Command.OUTPUT_MULTIPLE_STATES, state_ids=[0x05, 0x04, 0x02, 0, 0, 0, 0, 0],
                         mode=PULL)
        p = d.next_packet(1.0)
        ctx.proof("OUTPUT_MULTIPLE_STATES 05 04 02, pull", s, p.raw if p else b"")
        if p is None:
            ctx.fail("no packet")
        if p.frame.payload[4:] != mcu + gp or len(p.frame.payload) != 20:
            ctx.fail("payload is not INTERRUPT_COUNTER · MCU_ID · GP_ID", s, p.raw)
        msgs.append("multiple-states pull 05 04 02 → 02 04 05")
    pkts = _periodic_pair(ctx, (StateId.MCU_ID, 2), (StateId.INTERRUPT_COUNTER, 2), n=6)
    for p in pkts:
        if len(p.frame.payload) != 19 or p.frame.payload[4:] != mcu:
            ctx.fail("a packet is not INTERRUPT_COUNTER · MCU_ID", received=p.raw)
    msgs.append("periodic 04 then 02 → 02 04")
    return "; ".join(msgs)


@check("output-multiple", "OUTPUT_MULTIPLE_STATES: 8 ids (0x00 = none) at one rate",
       needs=(Command.OUTPUT_MULTIPLE_STATES,))
def check_output_multiple(ctx: Context) -> str:
    d = ctx.driver
    s, _ = d.command(Command.OUTPUT_MULTIPLE_STATES, state_ids=[0, 0x02, 0, 0x05, 0, 0, 0, 0], mode=3)
    pkts = _packets(d.collect(1.0, until=lambda f: len(_packets(f)) >= 5))
    ctx.proof("0x02 and 0x05 at rate 3 (every 4)", s, _raw(pkts, 3))
    d.command(Command.OUTPUT_ALL_OFF)
    if len(pkts) < 5 or any(len(p.frame.payload) != 5 for p in pkts):
        ctx.fail(f"expected packets of 5 bytes (counter + GP_ID), got {[len(p.frame.payload) for p in pkts]}")
    steps = _diffs([_counter(p) for p in pkts])
    if any(x != 4 for x in steps):
        ctx.fail(f"counter steps {steps}, expected 4")
    return f"{len(pkts)} packets every 4 cycles"


@check("state-if-setup", "STATE_IF_SETUP reads 10 ids: its own checksum bytes (here 02 04) become ids 9 and "
       "10, so INTERRUPT_COUNTER and MCU_ID ride along (§9)",
       needs=(Command.STATE_IF_SETUP, Command.RUN_PROC, Command.SET_STATE_1, Command.ALL_PROC_OFF))
def check_state_if_setup(ctx: Context) -> str:
    d = ctx.driver
    mcu = ctx.mcu_id()
    gp = d.pull(StateId.GP_ID)[1].frame.payload
    # ids 05 B0 D9: B0 and D9 have no state; the sum makes the checksum 02 04.
    frame = build_command(Command.STATE_IF_SETUP, flag_id=StateId.FILTER_RESET_FLAG, mode=PULL,
                          state_ids=[0x05, 0xB0, 0xD9, 0, 0, 0, 0, 0])
    assert frame[-2:] == b"\x02\x04", hexdump(frame)
    d.command(Command.ALL_PROC_OFF)
    sent = d.write(frame)
    if d.expect(d.ack_of(Command.STATE_IF_SETUP), 1.0) is None:
        ctx.fail("no ack for STATE_IF_SETUP", sent)
    s2, _ = d.command(Command.RUN_PROC, proc_id=0x06, slot=0)  # STATE_OUTPUT_ONCE_IF
    s3, _ = d.command(Command.SET_STATE_1, state_id=StateId.FILTER_RESET_FLAG, data=b"\x01")
    p = d.next_packet(1.0)
    ctx.proof("STATE_IF_SETUP flag 0x33 ids 05 B0 D9 (checksum 02 04), RUN_PROC 06, flag ← 1",
              sent + s2 + s3, p.raw if p else b"")
    d.command(Command.ALL_PROC_OFF)
    if p is None:
        ctx.fail("the conditional output sent nothing")
    want = mcu + gp
    if len(p.frame.payload) != 20 or p.frame.payload[4:] != want:
        ctx.fail(f"expected INTERRUPT_COUNTER · MCU_ID · GP_ID (20 bytes, the checksum bytes read as ids), "
                 f"got {len(p.frame.payload)} bytes {hexdump(p.frame.payload)}")
    return "checksum bytes 02 04 output as states"


@check("imu-output", "OUTPUT_IMU_RD: IMUs 0,1 × inertial, temperature, magnetometer plus the timestamp, "
       "in ascending ids (4 + 2·12 + 2·2 + 2·6 = 44 bytes)")
def check_imu_output(ctx: Context) -> str:
    d = ctx.driver
    mode = int(OutputMode.INERTIAL | OutputMode.TEMPERATURE | OutputMode.MAGNETOMETER | OutputMode.PULL)
    s, _ = d.command(Command.OUTPUT_IMU_RD, imu_selector=0b11, mode=mode)
    p = d.next_packet(1.0)
    ctx.proof("OUTPUT_IMU_RD IMUs 0,1 mode E8", s, p.raw if p else b"")
    if p is None or len(p.frame.payload) != 44:
        ctx.fail(f"expected a 44-byte payload, got {len(p.frame.payload) if p else 'no packet'}")
    ts = d.pull(StateId.IMU_TS)[1].frame.payload
    if p.frame.payload[:4] != ts:
        ctx.fail(f"payload does not start with IMU_TS {hexdump(ts)}")
    return "44 bytes, IMU_TS first"


@check("processing", "a mode command starts the process sequence (IMU_TS advances); processing off stops it",
       needs=(Command.ALL_PROC_OFF,))
def check_processing(ctx: Context) -> str:
    d = ctx.driver
    start = Command.MIMU_FRONTEND if d.supports(Command.MIMU_FRONTEND) else Command.RESET_ZUPT_AIDED_INS
    s, _ = d.command(start)
    d.wait_ticks(5)
    a = d.pull(StateId.IMU_TS)[1]
    d.wait_ticks(5)
    b = d.pull(StateId.IMU_TS)[1]
    ctx.proof(f"{start.name}, IMU_TS twice", s, a.raw + b.raw)
    if a.frame.payload == b.frame.payload:
        ctx.fail("IMU_TS did not advance: the sensors are not read")
    s, _ = d.command(Command.ALL_PROC_OFF)
    c = d.pull(StateId.IMU_TS)[1]
    d.wait_ticks(5)
    e = d.pull(StateId.IMU_TS)[1]
    ctx.proof("ALL_PROC_OFF, IMU_TS twice", s, c.raw + e.raw)
    if c.frame.payload != e.frame.payload:
        ctx.fail("IMU_TS still advances with the process sequence empty")
    cycles = (_counter(b) - _counter(a)) % U32
    return f"IMU_TS advanced {cycles} cycles while on, frozen when off"


def _imu_ts_advances(ctx: Context, label: str, sent: bytes) -> bool:
    """Pull IMU_TS, let 5 ticks pass, pull again: True if the sensors were read meanwhile."""
    d = ctx.driver
    a = d.pull(StateId.IMU_TS)[1]
    d.wait_ticks(5)
    b = d.pull(StateId.IMU_TS)[1]
    ctx.proof(f"{label}; IMU_TS twice", sent, a.raw + b.raw)
    return a.frame.payload != b.frame.payload


@check("run-proc", "RUN_PROC puts a processing function in a slot (READ_INERTIAL → IMU_TS advances, its "
       "PS_DT records cycles); an unregistered id empties the slot; slot >= 12 or id >= 0x30 is ignored",
       needs=(Command.RUN_PROC, Command.ALL_PROC_OFF))
def check_run_proc(ctx: Context) -> str:
    d = ctx.driver
    read = 0x13  # READ_INERTIAL
    s, _ = d.command(Command.RUN_PROC, proc_id=read, slot=3)
    if not _imu_ts_advances(ctx, "RUN_PROC READ_INERTIAL → slot 3", s):
        ctx.fail("READ_INERTIAL in slot 3 does not read the sensors")
    s2, ps = d.pull(0x83)
    ctx.proof("pull PS_DT3 (0x83)", s2, ps.raw)
    if int.from_bytes(ps.frame.payload, "big") == 0:
        ctx.fail("PS_DT3 is 0 although slot 3 runs READ_INERTIAL")
    s, _ = d.command(Command.RUN_PROC, proc_id=0x00, slot=3)
    if _imu_ts_advances(ctx, "RUN_PROC 0x00 → slot 3 (empties it)", s):
        ctx.fail("an unregistered id did not empty the slot")
    s, _ = d.command(Command.RUN_PROC, proc_id=read, slot=12)
    s2, _ = d.command(Command.RUN_PROC, proc_id=0x30 + read, slot=4)
    if _imu_ts_advances(ctx, "RUN_PROC into slot 12, and id 0x43 into slot 4 (both ignored)", s + s2):
        ctx.fail("RUN_PROC with slot >= 12 or id >= 0x30 was not ignored")
    return "placed, emptied, out-of-range ignored"


@check("store-restore", "STORE_AND_EMPTY stores the sequence and empties it; RESTORE_PROC_SEQU brings it "
       "back",
       needs=(Command.RUN_PROC, Command.STORE_AND_EMPTY, Command.RESTORE_PROC_SEQU))
def check_store_restore(ctx: Context) -> str:
    d = ctx.driver
    s, _ = d.command(Command.RUN_PROC, proc_id=0x13, slot=0)
    s2, _ = d.command(Command.STORE_AND_EMPTY)
    if _imu_ts_advances(ctx, "READ_INERTIAL in slot 0, STORE_AND_EMPTY", s + s2):
        ctx.fail("the sequence still runs after STORE_AND_EMPTY")
    s, _ = d.command(Command.RESTORE_PROC_SEQU)
    if not _imu_ts_advances(ctx, "RESTORE_PROC_SEQU", s):
        ctx.fail("the stored sequence did not come back")
    return "stored, emptied, restored"


@check("normal-imu", "NORMAL_IMU: read + preproc, IMU_TS and U_K output at the mode's rate (28-byte packets, "
       "IMU_TS ≈ 4 × 64000 cycles apart at rate 3)", needs=(Command.NORMAL_IMU,))
def check_normal_imu(ctx: Context) -> str:
    d = ctx.driver
    s, _ = d.command(Command.NORMAL_IMU, mode=3)
    pkts = _packets(d.collect(1.0, until=lambda f: len(_packets(f)) >= 6))
    d.command(Command.OUTPUT_ALL_OFF)
    ctx.proof("NORMAL_IMU mode 03", s, _raw(pkts, 3))
    if len(pkts) < 6 or any(len(p.frame.payload) != 28 for p in pkts):
        ctx.fail(f"expected 28-byte packets (IMU_TS + U_K), got sizes {[len(p.frame.payload) for p in pkts]}")
    steps = _diffs([_counter(p) for p in pkts])
    # the read happens at a point of the loop that moves a little (commands, link work): ±2 %
    if any(abs(x - 4 * 64000) > 5000 for x in steps):
        ctx.fail(f"IMU_TS steps {steps}, expected ≈ 256000 cycles (every 4 loops at 64 MHz)")
    u_k = np.frombuffer(pkts[-1].frame.payload[4:], dtype=">f4")
    if not np.all(np.isfinite(u_k)):
        ctx.fail(f"U_K is not finite: {u_k}")
    return f"{len(pkts)} packets every 4 loops"


@check("bias-est-delay", "NORMAL_IMU_WITH_BIAS_EST starts output only after 128 loop cycles (buffers filled)",
       needs=(Command.NORMAL_IMU_WITH_BIAS_EST,))
def check_bias_est_delay(ctx: Context) -> str:
    d = ctx.driver
    start = build_command(Command.NORMAL_IMU_WITH_BIAS_EST, mode=3)
    pull = build_command(Command.OUTPUT_STATE, state_id=StateId.IMU_TS, mode=PULL)
    sent = d.write(start + pull)  # one write: both run in the same loop cycle
    first = d.expect(lambda r: r.is_packet and len(r.frame.payload) == 4, 1.0)
    out = d.expect(lambda r: r.is_packet and len(r.frame.payload) == 28, 2.0)
    d.command(Command.OUTPUT_ALL_OFF)
    ctx.proof("NORMAL_IMU_WITH_BIAS_EST mode 03 and a pull of IMU_TS in one write", sent,
              (first.raw if first else b"") + (out.raw if out else b""))
    if first is None or out is None:
        ctx.fail("expected the pulled IMU_TS and then the periodic output")
    delay = round(((_counter(out) - _counter(first)) % U32) / 64000)
    if not 127 <= delay <= 134:  # 128, or one less when the two commands straddle a cycle
        ctx.fail(f"output started {delay:.0f} loop cycles after the command, expected 128 (+ up to 3 for "
                 "the divider and the link)")
    return f"first output {delay:.0f} loop cycles after the command"


@check("hardware-in-the-loop", "SETUP_DEBUG_PROC + INPUT_IMU_RD: raw samples fed by the host come back "
       "in the conditional output on the named interface (IMU_TS and IMU0 raw as sent)",
       needs=(Command.SETUP_DEBUG_PROC, Command.INPUT_IMU_RD))
def check_hil(ctx: Context) -> str:
    d = ctx.driver
    timestamp = 0x12345678
    imu = [[100 * i + k - 300 for k in range(6)] for i in range(4)]
    want = timestamp.to_bytes(4, "big") + b"".join(v.to_bytes(2, "big", signed=True) for v in imu[0])
    tried = []
    for iface, name in ((1, "USB"), (2, "Bluetooth")):
        s1, _ = d.command(Command.SETUP_DEBUG_PROC, proc_ids=[0] * 10,
                          state_ids=[StateId.IMU_TS, 0x40] + [0] * 8, interface=iface)
        s2, _ = d.command(Command.INPUT_IMU_RD, timestamp=timestamp, imu=imu)
        p = d.next_packet(0.3)
        ctx.proof(f"SETUP_DEBUG_PROC on {name} (states 01, 40), INPUT_IMU_RD", s1 + s2, p.raw if p else b"")
        if p is None:
            tried.append(name)
            continue
        if p.frame.payload != want:
            ctx.fail(f"expected IMU_TS · IMU0 raw = {hexdump(want)}, got {hexdump(p.frame.payload)}")
        return f"this link is the module's {name} interface; samples came back as sent"
    ctx.fail(f"no conditional output on this link for interface byte 1 or 2 (tried {', '.join(tried)})")
    return ""


# =========================================================================== transmission


@check("lossy", "lossy mode: a rate-1 output streams consecutive packets (numbers +1, counters +1), nothing "
       "resent, no acks needed")
def check_lossy(ctx: Context) -> str:
    d = ctx.driver
    s, _ = d.command(Command.OUTPUT_STATE, state_id=StateId.INTERRUPT_COUNTER, mode=1)
    pkts = _packets(d.collect(2.0, until=lambda f: len(_packets(f)) >= 40))
    d.command(Command.OUTPUT_ALL_OFF)
    ctx.proof("INTERRUPT_COUNTER every cycle, lossy, never acked", s, _raw(pkts, 4))
    if len(pkts) < 40:
        ctx.fail(f"only {len(pkts)} packets in 2 s")
    nums = _diffs([p.frame.number for p in pkts], 65536)
    cnts = _diffs([_counter(p) for p in pkts])
    if any(n != 1 for n in nums):
        ctx.fail(f"packet numbers step by {sorted(set(nums))} (a resend or a gap)", received=_raw(pkts))
    if any(c != 1 for c in cnts):
        ctx.fail(f"counters step by {sorted(set(cnts))}, expected 1")
    return f"{len(pkts)} packets, consecutive"


def _copies(d: DeviceDriver, number: int, count: int, timeout: float) -> list[Received]:
    """Wait until *count* copies of packet *number* arrived; fail on any other data packet."""
    got: list[Received] = []
    deadline = d.clock() + timeout * d.time_scale
    while len(got) < count:
        r = d.expect(lambda r: r.is_packet, max(0.0, (deadline - d.clock()) / d.time_scale))
        if r is None:
            break
        if r.frame.number != number:
            raise CheckFailed(f"lossless: packet 0x{r.frame.number:04X} was sent while 0x{number:04X} "
                              f"was unacknowledged: {hexdump(r.raw)}")
        got.append(r)
    return got


@check("lossless", "lossless mode is stop-and-wait: only the oldest packet is (re)sent until its ACK; an ACK "
       "with another number is ignored; after the ACK the next packet follows",
       duration="~0.6 s (3 resends)")
def check_lossless(ctx: Context) -> str:
    d = ctx.driver
    s, _ = d.command(Command.OUTPUT_STATE, state_id=StateId.INTERRUPT_COUNTER,
                     mode=int(OutputMode.LOSSLESS) | 1)
    first = d.next_packet(1.0)
    if first is None:
        ctx.fail("no packet after a lossless rate-1 output", s)
    n1 = first.frame.number
    copies = [first] + _copies(d, n1, 1, 1.0)
    if len(copies) < 2:
        ctx.fail(f"packet 0x{n1:04X} was never resent while unacknowledged", s, first.raw)
    wrong = d.ack_packet((n1 + 7) % 65536)
    copies += _copies(d, n1, 1, 1.0)
    ctx.proof(f"rate-1 lossless; no ack, then ACK of 0x{(n1 + 7) % 65536:04X} (wrong)", s + wrong,
              _raw(copies, 3))
    if len(copies) < 3:
        ctx.fail("the packet was not resent after an ACK with another number")
    if len({c.raw for c in copies}) != 1:
        ctx.fail("a resent packet differs from the original", received=_raw(copies))
    ack = d.ack_packet(n1)
    nxt = d.next_packet(1.0)
    ctx.proof(f"ACK 0x{n1:04X}", ack, nxt.raw if nxt else b"")
    if nxt is None or nxt.frame.number != (n1 + 1) % 65536:
        ctx.fail(f"after the ACK expected packet 0x{(n1 + 1) % 65536:04X}")
    if (_counter(nxt) - _counter(first)) % U32 != 1:
        ctx.fail("the next packet is not the one assembled a cycle later (queued packets lost)")
    ack2 = d.ack_packet(nxt.frame.number)
    nxt2 = d.next_packet(1.0)
    ctx.proof(f"ACK 0x{nxt.frame.number:04X}", ack2, nxt2.raw if nxt2 else b"")
    if nxt2 is None or nxt2.frame.number != (n1 + 2) % 65536:
        ctx.fail(f"after the second ACK expected packet 0x{(n1 + 2) % 65536:04X}")
    d.command(Command.OUTPUT_ALL_OFF)
    return f"0x{n1:04X} sent {len(copies)}× until acked, then 0x{nxt.frame.number:04X}"


#: Copies of the unacknowledged packet the resend check waits for (one probe after each).
RESEND_COPIES = 5


@check("resend-interval", "an unacknowledged lossless packet is resent every 128 loop cycles, measured with "
       "INTERRUPT_COUNTER probes pulled right after each of 5 copies (least-squares slope)",
       duration="~0.8 s")
def check_resend_interval(ctx: Context) -> str:
    d = ctx.driver
    s, _ = d.command(Command.OUTPUT_STATE, state_id=StateId.INTERRUPT_COUNTER, mode=PULL_LOSSLESS)
    a = d.next_packet(1.0)
    if a is None:
        ctx.fail("no packet for a lossless pull", s)
    na = a.frame.number
    sent = s
    copies = [a]
    probe = build_command(Command.OUTPUT_STATE, command_set=ctx.cs, state_id=StateId.INTERRUPT_COUNTER,
                          mode=PULL_LOSSLESS)
    sent += d.write(probe)
    for _ in range(RESEND_COPIES - 1):
        more = _copies(d, na, 1, 1.5)
        if not more:
            ctx.fail(f"packet 0x{na:04X} not resent within 1.5 s (copies so far: {len(copies)})", sent,
                     _raw(copies))
        copies += more
        sent += d.write(probe)
    # Release the queue: ACK each packet; the probes follow in order (command acks between them).
    probes: list[Received] = []
    sent += d.ack_packet(na)
    deadline = d.clock() + 3.0 * d.time_scale
    while len(probes) < RESEND_COPIES and d.clock() < deadline:
        r = d.next_packet(0.5)
        if r is None:
            continue
        if r.frame.number == na or any(r.frame.number == p.frame.number for p in probes):
            continue  # a resend
        probes.append(r)
        sent += d.ack_packet(r.frame.number)
    ctx.proof(f"lossless pull 0x{na:04X} (never acked); a probe pull after each of its "
              f"{RESEND_COPIES} copies", sent, _raw(copies) + _raw(probes))
    if len(probes) < RESEND_COPIES:
        ctx.fail(f"only {len(probes)} of {RESEND_COPIES} probe packets arrived after the ACK")
    ca = _counter(a)
    p = [_counter(r) for r in probes]
    intervals = _diffs(p)
    since = np.array([(x - ca) % U32 for x in p], dtype=np.float64)
    # least-squares slope of probe time over copy number: the resend interval, with the
    # host's round-trip jitter averaged out
    mean = float(np.polyfit(np.arange(len(since)), since, 1)[0])
    rtt = int(since[0])
    tol = max(16.0, rtt / 2)
    msg = (f"probes {since.astype(int).tolist()} cycles after the packet's assembly: resends "
           f"{mean:.1f} cycles apart on average (intervals {intervals}, round trip ≈ {rtt})")
    if abs(mean - RESEND_CYCLES) > tol:
        ctx.fail(msg + f"; expected {RESEND_CYCLES} ± {tol:.0f}")
    return msg


@check("all-off-empties-queue", "OUTPUT_ALL_OFF empties the interface's packet queue: no more (re)sends of "
       "queued lossless packets", duration="~0.4 s")
def check_all_off(ctx: Context) -> str:
    d = ctx.driver
    s, _ = d.command(Command.OUTPUT_STATE, state_id=StateId.INTERRUPT_COUNTER,
                     mode=int(OutputMode.LOSSLESS) | 1)
    first = d.next_packet(1.0)
    if first is None:
        ctx.fail("no packet after a lossless rate-1 output", s)
    d.collect(0.05)
    off, ack = d.command(Command.OUTPUT_ALL_OFF)
    _, _, strays = d.wait_ticks(2 * RESEND_CYCLES + 44)
    ctx.proof(f"queue filling behind unacked 0x{first.frame.number:04X}; OUTPUT_ALL_OFF; wait 300 cycles",
              s + off, first.raw + ack.raw + _raw(strays))
    if strays:
        ctx.fail(f"{len(strays)} queued packets still sent after OUTPUT_ALL_OFF", received=_raw(strays))
    return "nothing sent after the ack"


@check("lossless-flag", "a lossy request (mode bit 0x10 clear) turns lossless mode off again: the queued "
       "packets then flow without ACKs (§9)")
def check_lossless_flag(ctx: Context) -> str:
    d = ctx.driver
    s, _ = d.command(Command.OUTPUT_STATE, state_id=StateId.INTERRUPT_COUNTER,
                     mode=int(OutputMode.LOSSLESS) | 3)
    first = d.next_packet(1.0)
    if first is None:
        ctx.fail("no packet after a lossless output", s)
    copies = [first] + _copies(d, first.frame.number, 1, 1.0)
    if len(copies) < 2:
        ctx.fail("lossless mode is not on: the packet was not resent", s, first.raw)
    s2 = d.send(Command.OUTPUT_STATE, state_id=StateId.GP_DT, mode=PULL)  # lossy pull: flag off
    pkts = _packets(d.collect(1.0, until=lambda f: len({p.frame.number for p in _packets(f)}) >= 6))
    d.command(Command.OUTPUT_ALL_OFF)
    numbers = sorted({p.frame.number for p in pkts})
    ctx.proof(f"lossless rate 3, packet 0x{first.frame.number:04X} resent; then a lossy pull of GP_DT",
              s + s2, _raw(copies, 2) + _raw(pkts, 4))
    if len(numbers) < 6:
        ctx.fail(f"after the lossy request only packets {[f'0x{n:04X}' for n in numbers]} came without ACKs")
    return f"{len(numbers)} packets flowed unacknowledged"


@check("packet-size", "the length byte is the payload length mod 256 (279 bytes → 0x17); a packet never "
       "exceeds 512 bytes: states that would overflow it are left out (§9)",
       needs=(Command.OUTPUT_MULTIPLE_STATES,))
def check_packet_size(ctx: Context) -> str:
    d = ctx.driver
    # P 180 + U_K 24 + U_NEW 24 + U_INT_K 24 + MCU_ID 15 + 3 × 4 = 279 bytes
    ids = [StateId.P, StateId.U_K, StateId.U_NEW, StateId.U_INT_K, StateId.MCU_ID,
           StateId.IMU_TS, StateId.INTERRUPT_COUNTER, StateId.GP_DT]
    s, _ = d.command(Command.OUTPUT_MULTIPLE_STATES, state_ids=ids, mode=PULL)
    p = d.next_packet(1.0)
    ctx.proof("pull of 8 states, 279 bytes", s, p.raw if p else b"")
    if p is None:
        ctx.fail("no packet for a 279-byte pull", s, d.received_log[-64:])
    if len(p.frame.payload) != 279 or p.raw[3] != 0x17:
        ctx.fail(f"expected a 279-byte payload announced as 0x17, got {len(p.frame.payload)} bytes, "
                 f"length byte 0x{p.raw[3]:02X}")
    # all 32 IMU id slots × inertial, temperature, magnetometer: 4 + 32 × 20 = 644 bytes requested
    mode = int(OutputMode.INERTIAL | OutputMode.TEMPERATURE | OutputMode.MAGNETOMETER | OutputMode.PULL)
    s, _ = d.command(Command.OUTPUT_IMU_RD, imu_selector=0xFFFFFFFF, mode=mode)
    q = d.next_packet(1.0)
    ctx.proof("OUTPUT_IMU_RD of all 32 IMU slots (644 bytes asked)", s, q.raw if q else b"")
    if q is None:
        ctx.fail("no packet for an oversized request")
    if len(q.raw) > 512:
        ctx.fail(f"a {len(q.raw)}-byte packet exceeds the 512-byte cap")
    return f"0x17 for 279 bytes; capped request gave a {len(q.raw)}-byte packet"


@check("step-packets", "step-wise dead reckoning: one 64-byte lossless packet per step (length 0x3A, DX · DP "
       "· STEP_COUNTER), step counters 1, 2, 3 …", duration="up to 20 s (alignment, then 3 steps)",
       needs=(Command.STEPWISE_DEAD_RECKONING,))
def check_steps(ctx: Context) -> str:
    d = ctx.driver
    s, _ = d.command(Command.STEPWISE_DEAD_RECKONING)
    steps: list[Received] = []
    deadline = d.clock() + 20.0 * d.time_scale
    sent = s
    dupes = 0
    while len(steps) < 3 and d.clock() < deadline:
        r = d.next_packet(0.5)
        if r is None:
            continue
        sent += d.ack_packet(r.frame.number)
        if steps and r.frame.number == steps[-1].frame.number:
            dupes += 1
            continue
        steps.append(r)
    d.command(Command.OUTPUT_ALL_OFF)
    ctx.proof("STEPWISE_DEAD_RECKONING, ACK each packet", sent, _raw(steps))
    if len(steps) < 3:
        ctx.fail(f"only {len(steps)} step packets in 20 s")
    for r in steps:
        if len(r.raw) != STEP_PACKET_LEN or r.raw[3] != 0x3A:
            ctx.fail(f"a step packet must be 64 bytes with length byte 3A: {hexdump(r.raw)}")
    decoded = [decode_step(r.frame.payload) for r in steps]
    counters = [st.counter for st in decoded]
    if counters != list(range(counters[0], counters[0] + len(counters))) or counters[0] != 1:
        ctx.fail(f"step counters {counters}, expected 1, 2, 3")
    if not all(np.all(np.isfinite(st.dx)) for st in decoded):
        ctx.fail("a step's dx is not finite")
    return f"steps {counters}, {dupes} resends skipped"


# =========================================================================== emulator extensions

#: A THETA_INIT the settable check writes: pitch 0.125, roll −0.25 rad (float32, exact).
THETA_INIT_PROBE = bytes.fromhex("3E000000BE800000")


def _pull_beside_counter(ctx: Context, state_id: int) -> bytes | None:
    """Pull INTERRUPT_COUNTER and *state_id* in one packet: the state's bytes, or None when the
    packet holds the counter alone (the device has no such state: ids without one are ignored)."""
    d = ctx.driver
    ids = [StateId.INTERRUPT_COUNTER, state_id] + [0] * 6
    sent, _ = d.command(Command.OUTPUT_MULTIPLE_STATES, state_ids=ids, mode=PULL)
    pkt = d.next_packet(1.0)
    ctx.proof(f"pull INTERRUPT_COUNTER and 0x{state_id:02X}", sent, pkt.raw if pkt else b"")
    if pkt is None:
        ctx.fail(f"no packet for a pull of INTERRUPT_COUNTER and 0x{state_id:02X}")
    payload = pkt.frame.payload
    if len(payload) == 4:
        return None
    size = state_spec(state_id).size
    if len(payload) != 4 + size:
        ctx.fail(f"state 0x{state_id:02X} answers with {len(payload) - 4} bytes, expected {size}",
                 received=pkt.raw)
    return payload[4:]


@check("ext-states", "emulator extension states 0x34 SWING_TIME (4 bytes), 0x35 THETA_INIT (8, settable "
       "with SET_STATE_12), 0x36 THETA_GROUND (8) answer a pull with their sizes; absent on a real module",
       needs=(Command.OUTPUT_MULTIPLE_STATES, Command.SET_STATE_12), group="extensions")
def check_extension_states(ctx: Context) -> str:
    d = ctx.driver
    found = {sid: _pull_beside_counter(ctx, sid) for sid in sorted(EXTENSION_STATES)}
    present = [sid for sid, value in found.items() if value is not None]
    if not present:
        raise ExtensionAbsent("states 0x34–0x36 answer as unknown ids (a real module has none)")
    if len(present) < len(found):
        missing = ", ".join(f"0x{sid:02X}" for sid in found if sid not in present)
        ctx.fail(f"only some extension states exist: {missing} missing")
    original = found[StateId.THETA_INIT]
    try:
        s, ack = d.command(Command.SET_STATE_12, state_id=StateId.THETA_INIT, data=THETA_INIT_PROBE)
        ctx.proof("SET_STATE_12 THETA_INIT = (0.125, −0.25) rad", s, ack.raw)
        got = _pull_beside_counter(ctx, StateId.THETA_INIT)
        if got != THETA_INIT_PROBE:
            ctx.fail(f"THETA_INIT reads {hexdump(got or b'')} after SET_STATE_12 {hexdump(THETA_INIT_PROBE)}")
    finally:
        d.command(Command.SET_STATE_12, state_id=StateId.THETA_INIT, data=original)
    return "present: 0x34 (4 bytes), 0x35 (8, settable), 0x36 (8)"


@check("ext-height-compensation", "emulator extension function 0x25 HEIGHT_COMPENSATION: in step-wise "
       "tracking (after the first step packet), RUN_PROC(0x25, 10) puts a function in slot 10 (PS_DT10, "
       "cleared first, counts cycles); absent on a real module (the slot stays empty)",
       duration="up to 20 s (alignment, then the first step)",
       needs=(Command.STEPWISE_DEAD_RECKONING, Command.RUN_PROC, Command.SET_STATE_4), group="extensions")
def check_height_compensation(ctx: Context) -> str:
    d = ctx.driver
    slot = HEIGHT_COMPENSATION_SLOT
    s, _ = d.command(Command.STEPWISE_DEAD_RECKONING)
    first = d.next_packet(20.0)
    if first is None:
        ctx.fail("no step packet within 20 s of STEPWISE_DEAD_RECKONING: tracking does not run", s)
    sent = s + d.ack_packet(first.frame.number)
    off, _ = d.command(Command.OUTPUT_ALL_OFF)  # no more step packets; tracking keeps running
    ctx.proof("STEPWISE_DEAD_RECKONING, the first step packet acked, outputs off", sent + off, first.raw)
    clear, _ = d.command(Command.SET_STATE_4, state_id=ps_dt_id(slot), data=bytes(4))
    meaning, fields = height_compensation_on()
    run, _ = d.command(meaning, **fields)
    d.wait_ticks(5)
    s2, pkt = d.pull(ps_dt_id(slot))
    ctx.proof(f"PS_DT{slot} = 0, RUN_PROC(0x25, {slot}), 5 ticks, pull PS_DT{slot}", clear + run + s2,
              pkt.raw)
    cycles = int.from_bytes(pkt.frame.payload, "big")
    if cycles == 0:
        raise ExtensionAbsent(f"RUN_PROC(0x25, {slot}) left slot {slot} empty (a real module has no "
                              "function 0x25)")
    return f"present: slot {slot} runs it, PS_DT{slot} = {cycles} cycles"


# =========================================================================== runner


def select(names: list[str] | None = None) -> list[Check]:
    """The checks to run, in registry order; unknown names raise ValueError listing the known ones."""
    if not names:
        return list(CHECKS.values())
    unknown = [n for n in names if n not in CHECKS]
    if unknown:
        raise ValueError(f"unknown check(s) {unknown}; known: {', '.join(CHECKS)}")
    return [c for c in CHECKS.values() if c.name in names]


def run_check(driver: DeviceDriver, chk: Check) -> CheckResult:
    """Run one check from a quiet interface; never raises (failures become results)."""
    ctx = Context(driver)
    t0 = time.monotonic()
    if not chk.applies_to(driver.cs):
        lacking = [m.name for m in chk.needs if not driver.cs.supports(m)]
        return CheckResult(chk.name, Status.SKIP,
                           f"the {driver.cs.name} numbering has no {', '.join(lacking)}")
    try:
        driver.sync()
        driver.mark()
        message = chk.fn(ctx) or ""
        status = Status.PASS
    except CheckSkipped as exc:
        status, message = Status.SKIP, str(exc)
    except ExtensionAbsent as exc:
        status, message = Status.ABSENT, str(exc)
    except CheckFailed as exc:
        status, message = Status.FAIL, str(exc)
    except Exception as exc:  # noqa: BLE001 - a broken link or a suite bug is reported, not raised
        status, message = Status.ERROR, f"{type(exc).__name__}: {exc}"
    return CheckResult(chk.name, status, message, ctx.proofs, time.monotonic() - t0)


def run(driver: DeviceDriver, names: list[str] | None = None, url: str = "",
        on_result: Callable[[CheckResult], None] | None = None) -> RunReport:
    """Run the selected checks in order; *on_result* is called after each."""
    report = RunReport(url, driver.cs.name)
    try:
        driver.sync()
        dead = ""
    except CheckFailed as exc:  # a device that never answers: say so once, do not wait per check
        dead = f"device does not answer: {exc}"
    for chk in select(names):
        if dead:
            result = CheckResult(chk.name, Status.FAIL, dead)
        else:
            result = run_check(driver, chk)
        report.results.append(result)
        if on_result is not None:
            on_result(result)
    if not dead:
        try:
            driver.sync()
        except Exception:  # noqa: BLE001 - leaving the device as quiet as we can
            pass
    return report
