"""The in-process virtual-time pipe and the real-time pacer."""

from __future__ import annotations

import time

import pytest

from firmware_sim.link import make_link
from firmware_sim.module import Module
from firmware_sim.transports.pacer import Pacer
from firmware_sim.transports.pipe import QueueEndpoint, VirtualPipe

PING = bytes.fromhex("030003")
PING_ACK = bytes.fromhex("A00300A3")
INTERRUPT_COUNTER_1KHZ = bytes.fromhex("20 02 01 00 23")


def test_pipe_runs_ticks_only_while_the_host_waits():
    m = Module()
    pipe = VirtualPipe(m, "usb")
    pipe.write(PING)
    assert m.clock.ticks == 0
    assert pipe.read(4, timeout=1.0) == PING_ACK
    assert m.clock.ticks == 1
    assert pipe.read(1, timeout=0) == b"" and m.clock.ticks == 1
    assert pipe.read(1, timeout=0.5) == b"" and m.clock.ticks == 501
    pipe.run_for(0.1)
    assert m.clock.ticks == 601


def test_pipe_over_bluetooth_is_deterministic():
    def run(seed):
        pipe = VirtualPipe(Module(bt_port=make_link("bt", seed=seed)), "bt")
        pipe.write(PING)
        pipe.write(INTERRUPT_COUNTER_1KHZ)
        data = pipe.read(2000, timeout=2.0)
        return data, pipe.module.clock.ticks
    a = run(1)
    assert a[0].startswith(PING_ACK) and len(a[0]) == 2000
    assert a == run(1)


def test_bluetooth_pipe_is_limited_to_the_uart_rate():
    pipe = VirtualPipe(Module(bt_port=make_link("bt", seed=2)), "bt")
    pipe.write(bytes.fromhex("20 02 01 00 23"))  # 10-byte packets at 1 kHz = 10 kB/s: fits 11.52 kB/s
    pipe.write(bytes.fromhex("20 03 01 00 24"))  # + GP_DT: 14-byte packets = 14 kB/s: does not fit
    pipe.read(1, timeout=0.5)
    wire0 = pipe.port.counters.to_host.wire
    pipe.run_for(2.0)
    assert abs(pipe.port.counters.to_host.wire - wire0 - 2 * 11_520) <= 1  # the UART never idles
    assert pipe.module.bt.queue.dropped > 0  # and the module drops what does not fit
    assert pipe.port.counters.to_host.lost == 0  # the module drops whole packets, the link loses nothing


def test_unknown_interface_is_refused():
    with pytest.raises(ValueError, match="unknown interface"):
        VirtualPipe(Module(), "wifi")


def test_pacer_as_fast_as_possible_runs_and_stops_cleanly():
    m = Module()
    ep = QueueEndpoint(m.usb.port)
    pacer = Pacer(m, [ep], speed=0).start()
    ep.write(PING)
    assert ep.read(4, timeout=5) == PING_ACK
    assert pacer.call(lambda mod: mod.clock.ticks).result(5) > 0
    pacer.stop()
    st = pacer.status()
    assert not st.running and st.ticks == m.clock.ticks
    assert ep.closed and not m.usb.connected
    assert "overruns" in st.line()


def test_pacer_keeps_real_time_and_reports_status():
    m = Module()
    pacer = Pacer(m, speed=1.0).start()
    try:
        t0 = time.monotonic()
        # wait (bounded) until 0.2 s of module time passed
        fut = None
        while time.monotonic() - t0 < 5:
            fut = pacer.call(lambda mod: mod.clock.ticks)
            if fut.result(5) >= 200:
                break
        elapsed = time.monotonic() - t0
        st = pacer.status()
    finally:
        pacer.stop()
    assert fut is not None and fut.result() >= 200
    assert elapsed >= 0.19  # never ahead of the wall clock
    assert st.running and st.virtual_s <= st.wall_s + 0.002
    assert st.loop_us_mean > 0 and st.packets == {"USB": 0, "BT": 0}


def test_pacer_counts_overruns_when_the_machine_is_too_slow():
    m = Module()
    real_step = m.step

    def slow_step():
        real_step()
        end = time.perf_counter() + 0.003  # a 3 ms loop at 1 kHz
        while time.perf_counter() < end:
            pass
    m.step = slow_step
    pacer = Pacer(m, speed=1.0, max_lag_s=0.05).start()
    try:
        while pacer.call(lambda mod: mod.clock.ticks).result(5) < 60:
            pass
    finally:
        pacer.stop()
    st = pacer.status()
    assert st.overruns > 0 and st.rebases > 0
    assert st.ticks == m.clock.ticks  # no tick skipped: virtual time stays whole


def test_pacer_control_channel_reports_errors():
    m = Module(bt_port=make_link("bt"))
    pacer = Pacer(m, speed=0).start()
    try:
        pacer.call(lambda mod: mod.bt.port.stall(0.5)).result(5)
        assert pacer.call(lambda mod: mod.bt.port.counters.stalls).result(5) == 1
        with pytest.raises(ZeroDivisionError):
            pacer.call(lambda mod: 1 / 0).result(5)
    finally:
        pacer.stop()


def test_bad_speed_is_refused():
    with pytest.raises(ValueError, match="speed"):
        Pacer(Module(), speed=-1)


def test_pacer_speed_10_runs_ten_times_faster_than_the_wall_clock():
    m = Module()
    pacer = Pacer(m, speed=10.0).start()
    try:
        t0 = time.monotonic()
        while pacer.call(lambda mod: mod.clock.ticks).result(5) < 1000 and time.monotonic() - t0 < 10:
            pass
        elapsed = time.monotonic() - t0
    finally:
        pacer.stop()
    assert m.clock.ticks >= 1000
    assert elapsed >= 0.095  # 1 s of module time, not sooner than 0.1 s of wall time
