"""The command checks (protocol.md §3–§5, §9): states written and pulled, the identifiers, output
rates and their phase, several states at once, the processing functions and sequences, the modes'
outputs and the hardware-in-the-loop input."""

from __future__ import annotations

import numpy as np

from protocol.frames import build_command, hexdump
from protocol.ids import Command, OutputMode, StateId

from ..driver import PULL, Received
from . import U32, Check, Context, check, counter, diffs, packets, raw

#: Golden bytes of protocol.md §2 (checked by hand there).
SET_TH_ZUPT_100000 = bytes.fromhex("1319000186A00153")
SET_STATE_4_ACK = bytes.fromhex("A01300B3")


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
        ctx.fail(f"{len(strays)} more packets after a single pull", received=raw(strays))
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
        ctx.fail("MCU_ID output more than once", received=raw(strays))
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
        if strays or packets(d.since(first)[:1]):
            ctx.fail("GP_TEST produced output", received=raw(strays))
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
    steps = diffs(numbers, 65536)
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
        pkts = packets(d.collect(1.0 + 0.008 * div, until=lambda f: len(packets(f)) >= 8))
        ctx.proof(f"rate {rate} (every {div})", s, raw(pkts, 3))
        if len(pkts) < 8:
            ctx.fail(f"rate {rate}: only {len(pkts)} packets")
        steps = diffs([counter(p) for p in pkts])
        if any(st != div for st in steps):
            ctx.fail(f"rate {rate}: counters step by {steps}, expected every {div}", received=raw(pkts))
        seen.append(f"{rate}→{div}")
        s, _ = d.command(Command.OUTPUT_STATE, state_id=StateId.INTERRUPT_COUNTER, mode=0)
        _, _, strays = d.wait_ticks(2 * div + 10)
        if strays:
            ctx.fail(f"rate 0 did not switch the output off: {len(strays)} packets after", s, raw(strays))
    return "dividers " + ", ".join(seen) + "; rate 0 off"


def _periodic_pair(ctx: Context, first: tuple[int, int], second: tuple[int, int], n: int = 12
                   ) -> list[Received]:
    """Switch on state first[0] at rate first[1], wait until it fires, then second; packets after that."""
    d = ctx.driver
    s1, _ = d.command(Command.OUTPUT_STATE, state_id=first[0], mode=first[1])
    if d.next_packet(1.0) is None:
        ctx.fail(f"no packet after switching on state 0x{first[0]:02X}", s1)
    s2, _ = d.command(Command.OUTPUT_STATE, state_id=second[0], mode=second[1])
    pkts = packets(d.collect(2.0, until=lambda f: len(packets(f)) >= n))
    ctx.proof(f"0x{first[0]:02X} at rate {first[1]}, then 0x{second[0]:02X} at rate {second[1]}",
              s1 + s2, raw(pkts, 4))
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
                 received=raw(pkts))
    if sorted(set(sizes)) != [4, 19]:
        ctx.fail(f"payload sizes {sizes}, expected 4 (counter) and 19 (counter + MCU_ID)")
    both = [p for p in pkts if len(p.frame.payload) == 19]
    if any(p.frame.payload[4:] != mcu for p in both):
        ctx.fail("a combined packet is not counter · MCU_ID (ascending ids)", received=raw(both))
    steps = diffs([counter(p) for p in pkts])
    if any(s != 2 for s in steps):
        ctx.fail(f"INTERRUPT_COUNTER steps {steps}, expected 2")
    bsteps = diffs([counter(p) for p in both])
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
    pkts = packets(d.collect(1.0, until=lambda f: len(packets(f)) >= 5))
    ctx.proof("0x02 and 0x05 at rate 3 (every 4)", s, raw(pkts, 3))
    d.command(Command.OUTPUT_ALL_OFF)
    if len(pkts) < 5 or any(len(p.frame.payload) != 5 for p in pkts):
        ctx.fail(f"expected packets of 5 bytes (counter + GP_ID), got {[len(p.frame.payload) for p in pkts]}")
    steps = diffs([counter(p) for p in pkts])
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
    cycles = (counter(b) - counter(a)) % U32
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
    pkts = packets(d.collect(1.0, until=lambda f: len(packets(f)) >= 6))
    d.command(Command.OUTPUT_ALL_OFF)
    ctx.proof("NORMAL_IMU mode 03", s, raw(pkts, 3))
    if len(pkts) < 6 or any(len(p.frame.payload) != 28 for p in pkts):
        ctx.fail(f"expected 28-byte packets (IMU_TS + U_K), got sizes {[len(p.frame.payload) for p in pkts]}")
    steps = diffs([counter(p) for p in pkts])
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
    delay = round(((counter(out) - counter(first)) % U32) / 64000)
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


#: The commands checks, in the order they run.
CHECKS: tuple[Check, ...] = (
    check_set_state,
    check_pull,
    check_mcu_id,
    check_gp_id,
    check_numbering,
    check_rates,
    check_phase_sync,
    check_ascending,
    check_output_multiple,
    check_state_if_setup,
    check_imu_output,
    check_processing,
    check_run_proc,
    check_store_restore,
    check_normal_imu,
    check_bias_est_delay,
    check_hil,
)
