"""The main loop, PING/ACK and the golden frames of protocol.md, through IdealPort."""

from __future__ import annotations

import numpy as np

from firmware_sim.mcu.module import ModuleConfig
from firmware_sim.nav.firmware import build_module
from protocol.ids import Command, StateId

from .emu import Host, cmd


def test_ping_is_acked_with_golden_bytes():
    h = Host()
    h.send(bytes.fromhex("03 00 03"))
    assert h.step() == bytes.fromhex("A0 03 00 A3")
    assert h.iface.frames_executed == 1


def test_packet_ack_gets_no_command_ack():
    h = Host()
    h.send(bytes.fromhex("01 01 02 00 04"))
    assert h.step(3) == b""
    assert h.iface.frames_executed == 1


def test_every_other_command_is_acked_golden():
    h = Host()
    h.send(bytes.fromhex("22 00 22"))
    assert h.step() == bytes.fromhex("A0 22 00 C2")


def test_set_th_zupt_golden_frame():
    h = Host()
    h.send(bytes.fromhex("13 19 00 01 86 A0 01 53"))
    assert h.step() == bytes.fromhex("A0 13 00 B3")
    assert int(h.module.memory[StateId.TH_ZUPT]) == 100000


def test_loop_counts_interrupts_and_gp_dt():
    m = build_module()
    m.run(5)
    assert m.clock.ticks == 5 and m.clock.interrupts == 5
    assert int(m.memory[StateId.INTERRUPT_COUNTER]) == 5
    gp_dt = int(m.memory[StateId.GP_DT])
    assert 0 < gp_dt < m.clock.cycles_per_tick
    # each loop starts on its tick
    assert m.clock.loop_start == 5 * 64_000


def test_same_inputs_give_identical_bytes():
    def session() -> bytes:
        h = Host(trace=True)
        out = bytearray()
        h.command(Command.OUTPUT_STATE, state_id=StateId.INTERRUPT_COUNTER, mode=0x02)
        out += h.step(10)
        h.command(Command.RUN_PROC, proc_id=0x13, slot=0)
        h.command(Command.OUTPUT_STATE, state_id=0x40, mode=0x01)
        out += h.step(7)
        h.send(b"\xff\x00garbage" + cmd(Command.PING))
        out += h.step(3)
        return bytes(out)

    assert session() == session()


def test_mcu_serial_is_configurable_and_output_once():
    h = Host(mcu_serial=b"ABCDEFGHIJKLMNO")
    h.command(Command.MCU_ID)
    frames = h.frames()
    assert frames[0] == bytes.fromhex("A0 04 00 A4")
    pkt = frames[1]
    assert pkt[:4] == bytes.fromhex("AA 00 01 0F") and pkt[4:19] == b"ABCDEFGHIJKLMNO"
    assert h.step(5) == b""  # once


def test_memory_states_are_live_arrays():
    m = build_module(ModuleConfig(initial_states={StateId.TH_ZARU: 1234}))
    assert m.memory[StateId.TH_ZARU].shape == ()
    assert m.memory.read_wire(StateId.TH_ZARU) == (1234).to_bytes(4, "big")
    m.memory[0x41][...] = np.arange(6)
    assert m.memory.imu_raw[1].tolist() == [0, 1, 2, 3, 4, 5]
    assert m.memory.read_wire(0x41) == bytes.fromhex("0000 0001 0002 0003 0004 0005")


def test_counters_cover_loop_timing_and_both_interfaces():
    h = Host()
    h.send(b"\xff" + bytes.fromhex("03 00 04") + bytes.fromhex("03 00 03"))
    h.step(2)
    c = h.module.counters()
    assert c["loops"] == 2 and c["overruns"] == 0
    assert c["usb.bytes_discarded"] == 1 and c["usb.bad_checksums"] == 1
    assert c["usb.frames_executed"] == 1 and c["bt.frames_executed"] == 0


def test_trace_accepts_any_append_hook():
    seen = []

    class Hook:
        def append(self, entry):
            seen.append((entry.direction, entry.note))

    h = Host()
    h.module.trace = Hook()
    h.send(bytes.fromhex("03 00 03"))
    h.step()
    assert seen == [("in", "command"), ("out", "ack")]
