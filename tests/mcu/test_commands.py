"""Every command of protocol.md §3 and its exact effect, byte for byte through IdealPort."""

from __future__ import annotations

import numpy as np
import pytest

from firmware_sim.mcu.command_handlers import (
    ALIGNMENT_SEQUENCE,
    FRONTEND_SEQUENCE,
    STEPWISE_SEQUENCE,
    ZUPT_INS_SEQUENCE,
)
from firmware_sim.mcu.imu_bus import ScriptedSource
from firmware_sim.mcu.module import Module
from firmware_sim.nav.firmware import OPENSHOE, build_module
from protocol.frames import build_command_ack, checksum
from protocol.ids import NR_SLOTS, Command, ProcId, StateId

from .emu import Host, cmd, split_frames, with_checksum


def registered(ids) -> list[int]:
    """What the slots hold after writing *ids*: unregistered ids are empty slots."""
    out = [p if p in OPENSHOE.functions else 0 for p in ids]
    return out + [0] * (NR_SLOTS - len(out))


def ack(c: Command) -> bytes:
    return build_command_ack(int(c))


# ------------------------------------------------------------------ SET_STATE
@pytest.mark.parametrize(
    "meaning, n", [(Command.SET_STATE_1, 1), (Command.SET_STATE_4, 4), (Command.SET_STATE_12, 12),
                   (Command.SET_STATE_24, 24), (Command.SET_STATE_48, 48), (Command.SET_STATE_254, 254)]
)
def test_set_state_copies_the_states_own_size_if_it_fits(meaning, n):
    h = Host()
    mem = h.module.memory
    data = bytes(range(1, n + 1))
    for sid in (StateId.GP_ID, StateId.TH_ZUPT, StateId.POSITION, StateId.U_K, StateId.DP, StateId.P):
        before = mem.read_wire(sid)
        h.command(meaning, state_id=sid, data=data)
        assert h.step() == ack(meaning)
        size = mem.size(sid)
        assert mem.read_wire(sid) == (data[:size] if size <= n else before), hex(sid)


def test_set_state_of_an_id_without_state_is_ignored_but_acked():
    h = Host()
    h.command(Command.SET_STATE_4, state_id=0xB5, data=b"\1\2\3\4")
    assert h.step() == ack(Command.SET_STATE_4)


def test_set_state_bool_keeps_the_raw_byte():
    h = Host()
    h.command(Command.SET_STATE_1, state_id=StateId.ZUPT, data=b"\x02")
    h.step()
    assert h.module.memory.read_wire(StateId.ZUPT) == b"\x02"


# -------------------------------------------------------------------- outputs
def test_output_state_pull_sends_once_in_the_same_cycle():
    h = Host()
    h.command(Command.OUTPUT_STATE, state_id=StateId.INTERRUPT_COUNTER, mode=0x20)
    frames = h.frames()
    assert frames == [ack(Command.OUTPUT_STATE), with_checksum(bytes.fromhex("AA 00 01 04 00 00 00 01"))]
    assert h.step(3) == b""


def test_output_state_rate_zero_switches_off():
    h = Host()
    h.command(Command.OUTPUT_STATE, state_id=StateId.INTERRUPT_COUNTER, mode=0x01)
    assert len(h.frames(3)) == 4
    h.command(Command.OUTPUT_STATE, state_id=StateId.INTERRUPT_COUNTER, mode=0x00)
    assert h.frames(3) == [ack(Command.OUTPUT_STATE)]
    assert h.iface.periodic_outputs == {}


def test_output_multiple_states_ignores_zero_ids_and_sorts():
    h = Host()
    h.command(Command.OUTPUT_MULTIPLE_STATES, state_ids=[0x19, 0, 0x02, 0, 0xC0, 0, 0x05, 0], mode=0x20)
    mem = h.module.memory
    mem[StateId.TH_ZUPT][...] = 0x01020304
    mem[StateId.GP_ID][...] = 7
    frames = h.frames()
    assert frames[0] == ack(Command.OUTPUT_MULTIPLE_STATES)
    payload = frames[1][4:-2]
    assert payload == bytes.fromhex("00000001 07 01020304")


def test_output_state_lossless_bit_sets_and_clears_the_flag():
    h = Host()
    h.command(Command.OUTPUT_STATE, state_id=0x02, mode=0x31)
    h.step()
    assert h.iface.lossless
    h.command(Command.OUTPUT_STATE, state_id=0x03, mode=0x21)
    h.step()
    assert not h.iface.lossless  # a lossy request turns lossless off again (§9)


def test_output_all_off_golden_and_effects():
    h = Host()
    m = h.module
    h.command(Command.OUTPUT_STATE, state_id=0x02, mode=0x01)
    h.send(bytes.fromhex("23 05 20 02 32 B0 B0 FF FF 00 00 03 DA"))  # STATE_IF_SETUP
    h.step(2)
    assert m.cond_output.from_mask == 1
    h.send(bytes.fromhex("22 00 22"))
    out = h.step(3)
    assert out.startswith(bytes.fromhex("A0 22 00 C2"))
    assert out == bytes.fromhex("A0 22 00 C2")  # nothing after it
    assert h.iface.periodic_outputs == {}
    assert m.cond_output.state_ids == [0] * 10 and m.cond_output.from_mask == 0


def test_state_if_setup_copies_its_checksum_bytes_as_ids_9_and_10():
    h = Host()
    m = h.module
    frame = bytes.fromhex("23 05 20 02 32 B0 B0 FF FF 00 00 03 DA")
    assert checksum(frame[:-2]) == 0x03DA
    h.send(frame)
    h.command(Command.RUN_PROC, proc_id=ProcId.STATE_OUTPUT_IF, slot=0)
    assert h.step() == ack(Command.STATE_IF_SETUP) + ack(Command.RUN_PROC)
    assert m.cond_output.state_ids == [0x02, 0x32, 0xB0, 0xB0, 0xFF, 0xFF, 0, 0, 0x03, 0xDA]
    assert m.cond_output.flag_id == 0x05 and m.cond_output.mode == 0x20
    assert h.step(2) == b""  # flag GP_ID false
    m.memory[StateId.GP_ID][...] = 1
    gp_dt_before = m.memory.read_wire(StateId.GP_DT)  # GP_DT of the previous loop is what goes out
    frames = h.frames()
    # ids 0x02 (interrupt counter), 0x03 (GP_DT, the checksum MSB!), 0x32; 0xDA has no state
    payload = frames[0][4:-2]
    assert len(frames) == 1
    assert payload == (4).to_bytes(4, "big") + gp_dt_before + b"\0\0"


def test_output_imu_rd_selects_imus_and_kinds_plus_timestamp():
    h = Host()
    mem = h.module.memory
    mem.imu_raw[0] = [1, 2, 3, 4, 5, 6]
    mem.imu_raw[2] = [7, 8, 9, 10, 11, 12]
    mem.imu_temp[2] = -3
    mem.imu_mag[2] = [100, -100, 5]
    mem[StateId.IMU_TS][...] = 0xDEADBEEF
    h.command(Command.OUTPUT_IMU_RD, imu_selector=0b0101, mode=0x20 | 0x40 | 0x80 | 0x08)
    frames = h.frames()
    assert frames[0] == ack(Command.OUTPUT_IMU_RD)
    payload = frames[1][4:-2]
    expect = (bytes.fromhex("DEADBEEF")
              + np.array([1, 2, 3, 4, 5, 6], ">i2").tobytes()   # 0x40
              + np.array([7, 8, 9, 10, 11, 12], ">i2").tobytes()  # 0x42
              + np.array([0], ">i2").tobytes()  # 0x60
              + np.array([-3], ">i2").tobytes()  # 0x62
              + np.array([0, 0, 0], ">i2").tobytes()  # 0x90
              + np.array([100, -100, 5], ">i2").tobytes())  # 0x92
    assert payload == expect


def test_output_imu_rd_only_inertial_sets_lossless_from_mode():
    h = Host()
    h.command(Command.OUTPUT_IMU_RD, imu_selector=0b1, mode=0x40 | 0x10 | 0x01)
    h.step()
    assert h.iface.lossless
    assert h.iface.periodic_outputs == {0x01: 1, 0x40: 1}


def test_set_imu_bandwidth_reaches_the_sensors_values_above_6_ignored():
    src = ScriptedSource()
    m = build_module(sensors=src)
    h = Host(m)
    h.command(Command.SET_IMU_BANDWIDTH, dlpf_cfg=4)
    assert h.step() == ack(Command.SET_IMU_BANDWIDTH)
    assert src.dlpf_cfg == 4
    h.command(Command.SET_IMU_BANDWIDTH, dlpf_cfg=7)
    assert h.step() == ack(Command.SET_IMU_BANDWIDTH)
    assert src.dlpf_cfg == 4


def test_gp_test_and_ping_do_nothing_but_ack():
    h = Host()
    h.command(Command.GP_TEST, a=1, b=2)
    h.command(Command.PING)
    assert h.step() == ack(Command.GP_TEST) + bytes.fromhex("A0 03 00 A3")


# ----------------------------------------------------------- process sequence
def test_run_proc_rules():
    h = Host()
    seq = h.module.sequence
    h.command(Command.RUN_PROC, proc_id=ProcId.READ_INERTIAL, slot=3)
    h.step()
    assert seq.slots[3] == ProcId.READ_INERTIAL
    h.command(Command.RUN_PROC, proc_id=0x30, slot=3)  # id >= 0x30 ignored
    h.command(Command.RUN_PROC, proc_id=ProcId.READ_INERTIAL, slot=12)  # slot >= 12 ignored
    h.step()
    assert seq.slots[3] == ProcId.READ_INERTIAL and seq.slots.count(0) == 11
    h.command(Command.RUN_PROC, proc_id=0x2F, slot=3)  # unregistered id < 0x30 empties
    h.step()
    assert seq.slots == [0] * 12


def test_run_mult_proc_fills_slots_0_to_7():
    h = Host()
    seq = h.module.sequence
    seq.set_slot(9, ProcId.EMPTY_PROCESS_SEQUENCE)
    ids = [ProcId.READ_INERTIAL, 0x2F, ProcId.STATE_OUTPUT_IF, 0x40, 0, 0, 0, ProcId.STATE_OUTPUT_ONCE_IF]
    seq.set_slot(3, ProcId.RESTORE_PROC_SEQU)  # slot 3 gets 0x40 (>= 0x30): unchanged
    h.command(Command.RUN_MULT_PROC, proc_ids=ids)
    h.module.usb.receive()  # execute without running the sequence
    assert seq.slots[:8] == [0x13, 0, 0x05, 0x02, 0, 0, 0, 0x06]
    assert seq.slots[9] == ProcId.EMPTY_PROCESS_SEQUENCE


def test_all_proc_off_store_restore_commands():
    h = Host()
    seq = h.module.sequence
    seq.set_slots([ProcId.STATE_OUTPUT_IF, ProcId.STATE_OUTPUT_ONCE_IF])
    h.command(Command.STORE_AND_EMPTY)
    h.step()
    assert seq.slots == [0] * 12 and seq.storage[:2] == [5, 6]
    h.command(Command.RESTORE_PROC_SEQU)
    h.step()
    assert seq.slots[:2] == [5, 6] and seq.storage[:2] == [5, 6]
    h.command(Command.ALL_PROC_OFF)
    assert h.step() == ack(Command.ALL_PROC_OFF)
    assert seq.slots == [0] * 12


def test_reset_proc_setup_sets_the_flag_restore_if_watches():
    h = Host()
    m = h.module
    m.sequence.storage[:1] = [ProcId.STATE_OUTPUT_IF]
    m.sequence.set_slot(0, ProcId.RESTORE_PROC_SEQU_IF)
    h.command(Command.RESET_PROC_SETUP, flag_id=StateId.GP_ID)
    h.step(3)
    assert m.restore_if_flag == StateId.GP_ID and m.sequence.slots[0] == ProcId.RESTORE_PROC_SEQU_IF
    m.memory[StateId.GP_ID][...] = 1
    h.step()
    assert m.sequence.slots[0] == ProcId.STATE_OUTPUT_IF


# ------------------------------------------------------------- mode commands
def test_stepwise_dead_reckoning_sets_up_exactly_as_written():
    h = Host()
    m = h.module
    m.memory[StateId.STEP_COUNTER][...] = 9
    m.memory[StateId.INIT_DONE][...] = True
    h.command(Command.OUTPUT_STATE, state_id=0x02, mode=0x01)
    h.step()
    h.port.host_read()
    h.send(bytes.fromhex("34 00 34"))
    h.module.usb.receive()
    assert h.module.usb.queue.frames[0].data == bytes.fromhex("A0 34 00 D4")
    assert len(h.module.usb.queue) == 1  # queue emptied before the ack
    slots = registered(ALIGNMENT_SEQUENCE)
    slots[11] = ProcId.RESTORE_PROC_SEQU_IF
    assert m.sequence.slots == slots
    assert m.sequence.storage == registered(STEPWISE_SEQUENCE)
    assert m.restore_if_flag == StateId.INIT_DONE and not m.memory.flag(StateId.INIT_DONE)
    assert int(m.memory[StateId.STEP_COUNTER]) == 0
    assert h.iface.lossless and h.iface.periodic_outputs == {}
    c = m.cond_output
    assert (c.flag_id, c.mode, c.from_mask) == (StateId.FILTER_RESET_FLAG, 0x20, 1)
    assert c.state_ids == [0x30, 0x31, 0x32] + [0] * 7


def test_step_packet_is_the_golden_64_bytes():
    """protocol.md §2's example step, sent through the conditional output 0x34 sets up."""
    h = Host()
    m = h.module
    h.send(bytes.fromhex("34 00 34"))
    m.usb.receive()
    m.sequence.empty()
    m.sequence.set_slot(0, ProcId.STATE_OUTPUT_IF)  # the tracking sequence's output slot alone
    m.memory[StateId.DX][...] = [0.5, 0.01, -0.002, 0.0174]
    m.memory[StateId.DP][...] = [1e-4, 0, 0, 0, 1e-4, 0, 0, 1e-4, 0, 1e-5]
    m.memory[StateId.STEP_COUNTER][...] = 1
    m.memory[StateId.FILTER_RESET_FLAG][...] = True
    out = h.step(2)
    golden = bytes.fromhex(
        "AA 00 01 3A 3F 00 00 00 3C 23 D7 0A BB 03 12 6F 3C 8E 8A 72 38 D1 B7 17"
        "00 00 00 00 00 00 00 00 00 00 00 00 38 D1 B7 17 00 00 00 00 00 00 00 00"
        "38 D1 B7 17 00 00 00 00 37 27 C5 AC 00 01 0C BE")
    # the ack goes first; lossless: the step goes out on the next cycle, once until acked
    assert out == bytes.fromhex("A0 34 00 D4") + golden


def test_zupt_aided_ins_sets_alignment_and_stored_sequence_without_outputs():
    h = Host()
    m = h.module
    h.command(Command.OUTPUT_STATE, state_id=0x02, mode=0x01)
    h.step()
    h.command(Command.OUTPUT_STATE, state_id=0x05, mode=0x12)  # lossless, periodic
    h.send(bytes.fromhex("33 00 33"))
    m.usb.receive()
    slots = registered(ALIGNMENT_SEQUENCE)
    slots[11] = ProcId.RESTORE_PROC_SEQU_IF
    assert m.sequence.slots == slots
    assert m.sequence.storage == registered(ZUPT_INS_SEQUENCE)
    assert m.restore_if_flag == StateId.INIT_DONE
    # outputs switched off, queue emptied (only the ack left), lossless flag untouched
    assert h.iface.periodic_outputs == {} and h.iface.lossless
    assert [f.data for f in h.iface.queue.frames] == [bytes.fromhex("A0 33 00 D3")]
    assert m.cond_output.from_mask == 0


def test_mimu_frontend_sequence():
    h = Host()
    m = h.module
    m.sequence.set_slot(11, ProcId.STATE_OUTPUT_IF)
    h.command(Command.MIMU_FRONTEND)
    m.usb.receive()
    assert m.sequence.slots == registered(FRONTEND_SEQUENCE)


def test_normal_imu_outputs_timestamp_and_u_k_with_the_mode():
    h = Host()
    m = h.module
    h.command(Command.OUTPUT_STATE, state_id=0x05, mode=0x01)
    h.step()
    h.command(Command.NORMAL_IMU, mode=0x12)  # lossless, every 2nd cycle
    m.usb.receive()
    assert m.sequence.slots == registered([ProcId.READ_INERTIAL, ProcId.FRONTEND_PREPROC])
    assert h.iface.lossless
    assert h.iface.periodic_outputs == {0x01: 2, 0x13: 2}
    assert len(h.iface.queue) == 1  # queue emptied, then the ack


def test_normal_imu_with_bias_est_starts_output_after_128_cycles():
    h = Host()
    m = h.module
    h.command(Command.NORMAL_IMU_WITH_BIAS_EST, mode=0x01)
    first = h.step()
    assert first == ack(Command.NORMAL_IMU_WITH_BIAS_EST)
    expect = registered(FRONTEND_SEQUENCE + (ProcId.STATE_OUTPUT_IF_COUNTER,))
    assert m.sequence.slots == expect
    command_interrupts = m.clock.interrupts
    outs = h.per_tick(130)
    first_packet = next(i for i, o in enumerate(outs) if o)
    assert m.clock.interrupts - command_interrupts == 130
    assert first_packet == 127  # the loop whose interrupt count is the command's + 128
    assert h.iface.periodic_outputs == {0x01: 1, 0x13: 1}
    assert all(outs[first_packet:])


# ------------------------------------------------------- hardware in the loop
def test_hil_pair_feeds_raw_data_and_returns_states_after_processing():
    h = Host()
    m = h.module
    states = [StateId.IMU_TS, 0x40, 0x41, 0x43, StateId.INTERRUPT_COUNTER, 0, 0, 0, 0, 0]
    h.command(Command.SETUP_DEBUG_PROC, proc_ids=[0] * 10, state_ids=states, interface=1)
    assert h.step() == ack(Command.SETUP_DEBUG_PROC)
    assert m.sequence.slots == [0] * 12
    assert m.sequence.storage == [0] * 10 + [ProcId.STATE_OUTPUT_ONCE_IF, ProcId.STORE_AND_EMPTY_PROC_SEQU]
    assert h.step(5) == b""  # waits for input
    imu = np.arange(24, dtype=np.int16).reshape(4, 6) - 5
    for k in range(2):
        h.command(Command.INPUT_IMU_RD, timestamp=1000 + k, imu=(imu + k).tolist())
        frames = h.frames()
        assert frames[0] == ack(Command.INPUT_IMU_RD)
        payload = frames[1][4:-2]
        expect = ((1000 + k).to_bytes(4, "big") + (m.clock.interrupts).to_bytes(4, "big")
                  + (imu[[0, 1, 3]] + k).astype(">i2").tobytes())
        assert payload == expect
        assert m.sequence.slots == [0] * 12  # it re-stored itself
        assert h.step(2) == b""


def test_hil_processing_functions_run_once_per_input(temp_functions):
    calls = []
    temp_functions(0x2A, lambda m: calls.append(int(m.memory[StateId.IMU_TS])))
    h = Host()
    h.command(Command.SETUP_DEBUG_PROC, proc_ids=[0x2A] + [0] * 9, state_ids=[1] + [0] * 9, interface=1)
    h.step(3)
    assert calls == []
    h.command(Command.INPUT_IMU_RD, timestamp=77, imu=[[0] * 6] * 4)
    h.step(3)
    assert calls == [77]


def test_hil_output_goes_to_the_named_interface():
    m = build_module()
    usb, bt = Host(m), Host(m, interface=2)
    usb.command(Command.SETUP_DEBUG_PROC, proc_ids=[0] * 10, state_ids=[1] + [0] * 9, interface=2)
    m.step()
    usb.command(Command.INPUT_IMU_RD, timestamp=5, imu=[[0] * 6] * 4)
    m.step()
    assert usb.port.host_read() == ack(Command.SETUP_DEBUG_PROC) + ack(Command.INPUT_IMU_RD)
    assert split_frames(bt.port.host_read())[0][4:-2] == (5).to_bytes(4, "big")


# -------------------------------------------------------------- both numberings
def test_2014_numbering_runs_the_same_meanings():
    h = Host(command_set="2014")
    m = h.module
    h.send(bytes.fromhex("14 00 14"))
    assert h.step() == bytes.fromhex("A0 14 00 B4")
    assert m.sequence.storage == registered(STEPWISE_SEQUENCE)
    h.send(bytes.fromhex("21 00 21"))  # all outputs off
    assert h.step() == bytes.fromhex("A0 21 00 C1")
    assert m.cond_output.from_mask == 0
    h.send(bytes.fromhex("27 00 27"))  # processing off
    h.step()
    assert m.sequence.slots == [0] * 12
    h.send(cmd(Command.SET_STATE_1, state_id=5, data=b"\1"))  # 0x12 is not a 2014 command
    h.step()
    assert int(m.memory[StateId.GP_ID]) == 0


def test_2014_ids_under_the_current_numbering_get_silence_then_time_out():
    h = Host()
    h.send(bytes.fromhex("14 00 14"))  # an incomplete SET_STATE_12 (needs 16 bytes)
    assert h.step(10) == b""
    assert h.iface.partial_frame == bytes.fromhex("14 00 14")
    h.send(bytes.fromhex("03 00 03"))  # swallowed by the partial frame
    assert h.step() == b""
    ticks_to_timeout = 200_000_000 // 64_000
    assert h.step(ticks_to_timeout - 5) == b""
    assert h.iface.partial_timeouts == 0
    assert h.step(10) == b""
    assert h.iface.partial_timeouts == 1 and h.iface.partial_frame == b""
    h.send(bytes.fromhex("03 00 03"))
    assert h.step() == bytes.fromhex("A0 03 00 A3")


def test_an_old_app_sending_21_00_21_gets_silence():
    h = Host()
    h.send(bytes.fromhex("21 00 21"))
    assert h.step(20) == b""
    assert h.iface.frames_executed == 0


def test_hil_values_are_copied_at_transmission_after_processing(temp_functions):
    def double(m: Module) -> None:
        m.memory.imu_raw[0] *= 2

    temp_functions(0x2A, double)
    h = Host()
    h.command(Command.SETUP_DEBUG_PROC, proc_ids=[0x2A] + [0] * 9, state_ids=[0x40] + [0] * 9, interface=1)
    h.step()
    h.command(Command.INPUT_IMU_RD, timestamp=1, imu=[[1, 2, 3, 4, 5, 6]] + [[0] * 6] * 3)
    payload = h.frames()[1][4:-2]
    assert payload == np.array([2, 4, 6, 8, 10, 12], ">i2").tobytes()


def test_hil_with_read_inertial_in_the_list_overwrites_the_input():
    src = ScriptedSource(np.full((1, 4, 6), 9, dtype=np.int16))
    h = Host(build_module(sensors=src))
    h.command(Command.SETUP_DEBUG_PROC, proc_ids=[ProcId.READ_INERTIAL] + [0] * 9,
              state_ids=[0x40] + [0] * 9, interface=1)
    h.step()
    h.command(Command.INPUT_IMU_RD, timestamp=1, imu=[[1, 2, 3, 4, 5, 6]] * 4)
    payload = h.frames()[1][4:-2]
    assert payload == np.full(6, 9, ">i2").tobytes()
