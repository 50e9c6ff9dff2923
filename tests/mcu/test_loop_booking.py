"""A runner that executes whole loops outside Module.step books them through public methods, and
the module ends up exactly as after that many steps."""

from __future__ import annotations

import pytest

from firmware_sim.mcu.clock import Clock
from firmware_sim.mcu.firmware import RUNTIME_ONLY
from firmware_sim.mcu.module import Module
from protocol.ids import StateId


def test_loops_on_time_leave_the_clock_as_loop_after_loop():
    stepped, booked = Clock(start_cycles=2 ** 32 - 100_000), Clock(start_cycles=2 ** 32 - 100_000)
    for _ in range(5):
        stepped.wait_for_tick()
        stepped.spend(40_000)
        stepped.end_loop()
    last = booked.loops_on_time(5, 40_000)
    assert last == stepped.loop_start
    for attr in ("now_cycles", "ticks", "interrupts", "overruns", "missed_ticks", "last_loop_cycles",
                 "loop_start"):
        assert getattr(booked, attr) == getattr(stepped, attr), attr
    assert booked.cycles_until_next_tick() == stepped.cycles_until_next_tick()


def test_loops_on_time_refuse_a_loop_longer_than_a_tick_or_a_late_clock():
    clock = Clock()
    with pytest.raises(ValueError):
        clock.loops_on_time(2, clock.cycles_per_tick + 1)
    clock.spend(clock.cycles_per_tick + 1)
    with pytest.raises(ValueError):
        clock.loops_on_time(1, 100)


def test_booked_loops_equal_stepped_loops_of_an_empty_sequence():
    """With nothing in the sequence, booking n idle loops of the loop's own cycles is n steps."""
    stepped, booked = Module(firmware=RUNTIME_ONLY), Module(firmware=RUNTIME_ONLY)
    for _ in range(7):
        stepped.step()
    c = booked.costs
    booked.account_loops(7, c.loop_overhead + 2 * c.rx_poll)
    for sid in (StateId.INTERRUPT_COUNTER, StateId.GP_DT):
        assert booked.memory.read_wire(sid) == stepped.memory.read_wire(sid)
    assert booked.counters() == stepped.counters()
    assert booked.sequence.runs == stepped.sequence.runs
    stepped.clock.wait_for_tick()
    booked.clock.wait_for_tick()
    assert booked.clock.now_cycles == stepped.clock.now_cycles


def test_finish_loop_transmits_and_closes_the_loop():
    module = Module(firmware=RUNTIME_ONLY)
    module.bt.pull(StateId.INTERRUPT_COUNTER)
    c = module.costs
    module.account_loops(3, c.loop_overhead + 2 * c.rx_poll)
    assert module.bt.port.host_read() == b""
    module.finish_loop()
    assert module.bt.port.host_read()[:1] == b"\xaa"
    idle_loop = c.loop_overhead + 2 * c.rx_poll
    assert int(module.memory[StateId.GP_DT]) == module.clock.last_loop_cycles > idle_loop


def test_an_interface_is_idle_until_an_output_or_a_partial_frame():
    module = Module(firmware=RUNTIME_ONLY)
    assert module.usb.is_idle()
    module.usb.feed(b"\x03")  # the first byte of a PING
    assert not module.usb.is_idle()
    assert module.bt.is_idle()
    module.bt.set_state_output(StateId.GP_DT, 1)
    assert not module.bt.is_idle()


def test_idle_transmissions_count_down_a_waiting_packets_resend_delay():
    module = Module(firmware=RUNTIME_ONLY)
    bt = module.bt
    bt.set_lossless(True)
    bt.pull(StateId.INTERRUPT_COUNTER)
    module.step()  # the packet goes out and waits for its ACK
    delay = bt.queue.delay_counter
    bt.count_idle_transmissions(5)
    assert bt.queue.delay_counter == (delay + 5) % bt.queue.resend_cycles
