"""The checks of the group ``extensions``: the emulator's extensions of the protocol
(:mod:`protocol.extensions`, docs/protocol-extensions.md): present and right → PASS, present and
wrong → FAIL, absent → ABSENT, which is no failure (a real module has none of them)."""

from __future__ import annotations

from protocol.extensions import EXTENSION_STATES, HEIGHT_COMPENSATION_SLOT, height_compensation_on
from protocol.frames import hexdump
from protocol.ids import Command, StateId, ps_dt_id
from protocol.states import state_spec

from ..driver import PULL, ExtensionAbsent
from . import Check, Context, check

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


#: The extensions checks, in the order they run.
CHECKS: tuple[Check, ...] = (
    check_extension_states,
    check_height_compensation,
)
