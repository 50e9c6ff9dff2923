"""Output dividers and phase sync (§5), packet assembly (§6), numbering, disconnection (§7, §9)."""

from __future__ import annotations

from firmware_sim.mcu.port import IdealPort
from protocol.frames import parse_state_packet
from protocol.ids import Command, ProcId, StateId

from .emu import Host, split_frames


def packets_per_tick(h: Host, n: int) -> list[bytes | None]:
    """The state packet (or None) of each of the next n loops, acks dropped."""
    out = []
    for data in h.per_tick(n):
        pk = [f for f in split_frames(data) if f[0] == 0xAA]
        assert len(pk) <= 1  # one packet per cycle
        out.append(pk[0] if pk else None)
    return out


def test_divider_fires_every_2_pow_d_minus_1_cycles_starting_at_once():
    for d in range(1, 8):
        h = Host()
        h.command(Command.OUTPUT_STATE, state_id=StateId.GP_ID, mode=d)
        pk = packets_per_tick(h, 200)
        fired = [i for i, p in enumerate(pk) if p is not None]
        D = 1 << (d - 1)
        assert fired == list(range(0, 200, D)), d


def test_slower_output_joins_the_packets_of_a_running_one():
    h = Host()
    h.command(Command.OUTPUT_STATE, state_id=StateId.GP_ID, mode=4)  # D = 8
    h.step(3)  # fired at 0; counter now 5
    h.command(Command.OUTPUT_STATE, state_id=StateId.INTERRUPT_COUNTER, mode=3)  # D = 4
    pk = packets_per_tick(h, 32)
    fired_gp = [i for i, p in enumerate(pk) if p is not None and len(p) in (7, 11)]
    fired_ic = [i for i, p in enumerate(pk) if p is not None and len(p) in (10, 11)]
    assert fired_gp == [5, 13, 21, 29]
    # counter = 5 mod 4 = 1: fires at 1, 5, 9, … and therefore in every packet of GP_ID
    assert fired_ic == list(range(1, 32, 4))
    assert set(fired_gp) <= set(fired_ic)


def test_counter_is_the_largest_counter_mod_d_of_running_outputs():
    h = Host()
    it = h.iface
    it.set_state_output(0x02, 5)  # D=16, counter 0
    it.counter[0x02] = 13
    it.set_state_output(0x03, 1)  # D=1 starts at 0
    it.counter[0x03] = 0
    it.set_state_output(0x05, 3)  # D=4: max(13 % 4, 0 % 4) = 1
    assert it.counter[0x05] == 1
    it.set_state_output(0x19, 4)  # D=8: max(13 % 8, 0, 1 % 8) = 5
    assert it.counter[0x19] == 5
    it.set_state_output(0x1A, 1)
    assert it.counter[0x1A] == 0 and it.divider[0x1A] == 1


def test_output_of_a_state_that_does_not_exist_is_ignored():
    h = Host()
    h.command(Command.OUTPUT_STATE, state_id=0xB0, mode=1)
    h.command(Command.OUTPUT_STATE, state_id=0x06, mode=0x20)
    assert len(split_frames(h.step(3))) == 2  # two acks, no packet
    assert h.iface.periodic_outputs == {} and h.iface.pulled == frozenset()


def test_states_are_assembled_in_ascending_id_order():
    h = Host()
    m = h.module
    m.memory[StateId.TH_ZUPT][...] = 0x11223344
    m.memory[StateId.GP_ID][...] = 0x55
    m.memory[StateId.STEP_COUNTER][...] = 0x6677
    for sid in (StateId.STEP_COUNTER, StateId.TH_ZUPT, StateId.GP_ID):
        h.command(Command.OUTPUT_STATE, state_id=sid, mode=0x20)
    pk = split_frames(h.step())[-1]
    assert pk[4:-2] == bytes.fromhex("55 11223344 6677")


def test_packet_is_capped_at_512_bytes_and_later_small_states_still_fit():
    h = Host()
    it = h.iface
    for sid in [StateId.P, *range(0x40, 0x60), 0x60, 0x61]:
        it.pull(sid)
    h.module.memory.imu_temp[0] = 0x0102
    pk = h.step()
    assert len(pk) == 512
    assert pk[3] == 506 % 256
    # P (180) + 27 raw IMU states (0x40..0x5A, 324) + 0x60 (2) = 506; 0x5B..0x5F and 0x61 left out
    assert pk[4 + 180 + 324:4 + 180 + 326] == bytes.fromhex("0102")
    assert it.states_left_out == 6
    assert h.step(2) == b""  # left-out pulled states are not kept


def test_length_byte_is_payload_length_mod_256():
    h = Host()
    for sid in [StateId.P, *range(0x40, 0x4A)]:
        h.iface.pull(sid)
    data = h.step()
    assert len(data) == 306 and data[3] == 300 - 256
    assert parse_state_packet(data).payload == bytes(300)


def test_packet_numbers_start_at_1_and_wrap_through_0():
    h = Host()
    h.command(Command.OUTPUT_STATE, state_id=StateId.GP_ID, mode=1)
    numbers = [int.from_bytes(p[1:3], "big") for p in packets_per_tick(h, 3)]
    assert numbers == [1, 2, 3]
    h.iface.packet_number = 0xFFFD
    numbers = [int.from_bytes(p[1:3], "big") for p in packets_per_tick(h, 4)]
    assert numbers == [0xFFFE, 0xFFFF, 0x0000, 0x0001]


def test_no_state_due_means_no_packet_and_no_number_used():
    h = Host()
    h.command(Command.OUTPUT_STATE, state_id=StateId.GP_ID, mode=3)  # every 4th
    pk = packets_per_tick(h, 9)
    assert [int.from_bytes(p[1:3], "big") for p in pk if p] == [1, 2, 3]


def test_interfaces_keep_separate_outputs_and_numbers():
    h_usb = Host()
    m = h_usb.module
    h_bt = Host(m, interface=2)
    h_usb.command(Command.OUTPUT_STATE, state_id=StateId.GP_ID, mode=1)
    h_bt.command(Command.OUTPUT_STATE, state_id=StateId.INTERRUPT_COUNTER, mode=2)
    m.run(4)
    usb = split_frames(h_usb.port.host_read())
    bt = split_frames(h_bt.port.host_read())
    assert [f[:4].hex() for f in usb][1:] == ["aa000101", "aa000201", "aa000301", "aa000401"]
    assert [f[:4].hex() for f in bt][1:] == ["aa000104", "aa000204"]


def test_disconnected_interface_neither_receives_nor_transmits_and_pulls_stay_pending():
    port = IdealPort()
    h = Host()
    h.module.usb.port = port
    h.port = port
    m = h.module
    # conditional output: pull the interrupt counter every loop while GP_ID is true
    h.send(bytes.fromhex("23 05 20 02 00 00 00 00 00 00 00") + b"\x00\x4a")
    h.command(Command.RUN_PROC, proc_id=ProcId.STATE_OUTPUT_IF, slot=0)
    h.command(Command.OUTPUT_STATE, state_id=StateId.GP_DT, mode=2)  # periodic, D = 2
    h.step()
    counter_before = h.iface.counter[StateId.GP_DT]
    m.memory[StateId.GP_ID][...] = 1
    port.disconnect()
    assert port.host_write(bytes.fromhex("03 00 03")) == 0
    port._rx += bytes.fromhex("03 00")  # bytes already in the ring are not read either
    m.run(10)
    assert port.host_read() == b""
    assert h.iface.frames_executed == 3 and port.rx_pending() == 2
    assert h.iface.counter[StateId.GP_DT] == counter_before  # dividers frozen
    # 0x4A rides along: it is the frame's checksum LSB (the STATE_IF_SETUP quirk)
    assert h.iface.pulled == {StateId.INTERRUPT_COUNTER, 0x4A}
    port.connect()
    port._rx.clear()
    m.step()
    pk = split_frames(port.host_read())
    # the first packet after reconnecting carries only the latest value
    assert len(pk) == 1
    assert int.from_bytes(pk[0][4:8], "big") == m.clock.interrupts


def test_disconnect_discards_a_partial_frame():
    h = Host()
    h.send(bytes.fromhex("13 19 00"))
    h.step()
    assert h.iface.partial_frame == bytes.fromhex("13 19 00")
    h.port.disconnect()
    h.step()
    assert h.iface.partial_frame == b"" and h.iface.partial_disconnects == 1
    h.port.connect()
    h.send(bytes.fromhex("03 00 03"))
    assert h.step() == bytes.fromhex("A0 03 00 A3")


def test_a_response_goes_out_on_the_interface_the_command_came_from():
    m = Host().module
    usb, bt = Host(m), Host(m, interface=2)
    bt.send(bytes.fromhex("03 00 03"))
    bt.command(Command.OUTPUT_STATE, state_id=StateId.GP_ID, mode=0x20)
    m.step()
    assert usb.port.host_read() == b""
    frames = split_frames(bt.port.host_read())
    assert frames[0] == bytes.fromhex("A0 03 00 A3") and frames[2][:3] == bytes.fromhex("AA 00 01")
    assert m.usb.packet_number == 0 and m.bt.packet_number == 1
