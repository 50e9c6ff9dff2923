"""The transmission checks (protocol.md §6, §9): lossy streams, lossless stop-and-wait and its resend
interval, emptying the queue, the length byte, and the step-wise dead reckoning's packets."""

from __future__ import annotations

import numpy as np

from protocol.codec import decode_step
from protocol.frames import build_command, hexdump
from protocol.ids import Command, OutputMode, StateId

from ..driver import PULL, PULL_LOSSLESS, CheckFailed, DeviceDriver, Received
from . import U32, Check, Context, check, counter, diffs, packets, raw

#: The lossless resend interval, protocol.md §6.
RESEND_CYCLES = 128
#: A step packet: AA, number (2), length 0x3A, 58-byte payload, checksum (2).
STEP_PACKET_LEN = 64


@check("lossy", "lossy mode: a rate-1 output streams consecutive packets (numbers +1, counters +1), nothing "
       "resent, no acks needed")
def check_lossy(ctx: Context) -> str:
    d = ctx.driver
    s, _ = d.command(Command.OUTPUT_STATE, state_id=StateId.INTERRUPT_COUNTER, mode=1)
    pkts = packets(d.collect(2.0, until=lambda f: len(packets(f)) >= 40))
    d.command(Command.OUTPUT_ALL_OFF)
    ctx.proof("INTERRUPT_COUNTER every cycle, lossy, never acked", s, raw(pkts, 4))
    if len(pkts) < 40:
        ctx.fail(f"only {len(pkts)} packets in 2 s")
    nums = diffs([p.frame.number for p in pkts], 65536)
    cnts = diffs([counter(p) for p in pkts])
    if any(n != 1 for n in nums):
        ctx.fail(f"packet numbers step by {sorted(set(nums))} (a resend or a gap)", received=raw(pkts))
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


def _first_lossless_packet(ctx: Context) -> tuple[bytes, Received]:
    """Output INTERRUPT_COUNTER lossless at rate 1: the bytes sent and its first packet (the check
    fails without one)."""
    s, _ = ctx.driver.command(Command.OUTPUT_STATE, state_id=StateId.INTERRUPT_COUNTER,
                              mode=int(OutputMode.LOSSLESS) | 1)
    first = ctx.driver.next_packet(1.0)
    if first is None:
        ctx.fail("no packet after a lossless rate-1 output", s)
    return s, first


@check("lossless", "lossless mode is stop-and-wait: only the oldest packet is (re)sent until its ACK; an ACK "
       "with another number is ignored; after the ACK the next packet follows",
       duration="~0.6 s (3 resends)")
def check_lossless(ctx: Context) -> str:
    d = ctx.driver
    s, first = _first_lossless_packet(ctx)
    n1 = first.frame.number
    copies = [first] + _copies(d, n1, 1, 1.0)
    if len(copies) < 2:
        ctx.fail(f"packet 0x{n1:04X} was never resent while unacknowledged", s, first.raw)
    wrong = d.ack_packet((n1 + 7) % 65536)
    copies += _copies(d, n1, 1, 1.0)
    ctx.proof(f"rate-1 lossless; no ack, then ACK of 0x{(n1 + 7) % 65536:04X} (wrong)", s + wrong,
              raw(copies, 3))
    if len(copies) < 3:
        ctx.fail("the packet was not resent after an ACK with another number")
    if len({c.raw for c in copies}) != 1:
        ctx.fail("a resent packet differs from the original", received=raw(copies))
    ack = d.ack_packet(n1)
    nxt = d.next_packet(1.0)
    ctx.proof(f"ACK 0x{n1:04X}", ack, nxt.raw if nxt else b"")
    if nxt is None or nxt.frame.number != (n1 + 1) % 65536:
        ctx.fail(f"after the ACK expected packet 0x{(n1 + 1) % 65536:04X}")
    if (counter(nxt) - counter(first)) % U32 != 1:
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
                     raw(copies))
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
              f"{RESEND_COPIES} copies", sent, raw(copies) + raw(probes))
    if len(probes) < RESEND_COPIES:
        ctx.fail(f"only {len(probes)} of {RESEND_COPIES} probe packets arrived after the ACK")
    ca = counter(a)
    p = [counter(r) for r in probes]
    intervals = diffs(p)
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
    s, first = _first_lossless_packet(ctx)
    d.collect(0.05)
    off, ack = d.command(Command.OUTPUT_ALL_OFF)
    _, _, strays = d.wait_ticks(2 * RESEND_CYCLES + 44)
    ctx.proof(f"queue filling behind unacked 0x{first.frame.number:04X}; OUTPUT_ALL_OFF; wait 300 cycles",
              s + off, first.raw + ack.raw + raw(strays))
    if strays:
        ctx.fail(f"{len(strays)} queued packets still sent after OUTPUT_ALL_OFF", received=raw(strays))
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
    pkts = packets(d.collect(1.0, until=lambda f: len({p.frame.number for p in packets(f)}) >= 6))
    d.command(Command.OUTPUT_ALL_OFF)
    numbers = sorted({p.frame.number for p in pkts})
    ctx.proof(f"lossless rate 3, packet 0x{first.frame.number:04X} resent; then a lossy pull of GP_DT",
              s + s2, raw(copies, 2) + raw(pkts, 4))
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
    ctx.proof("STEPWISE_DEAD_RECKONING, ACK each packet", sent, raw(steps))
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


#: The transmission checks, in the order they run.
CHECKS: tuple[Check, ...] = (
    check_lossy,
    check_lossless,
    check_resend_interval,
    check_all_off,
    check_lossless_flag,
    check_packet_size,
    check_steps,
)
