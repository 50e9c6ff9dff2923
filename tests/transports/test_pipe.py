"""The in-process virtual-time pipe."""

from __future__ import annotations

import pytest

from firmware_sim.links.link import make_link
from firmware_sim.nav.firmware import build_module
from firmware_sim.transports.pipe import VirtualPipe

PING = bytes.fromhex("030003")
PING_ACK = bytes.fromhex("A00300A3")
INTERRUPT_COUNTER_1KHZ = bytes.fromhex("20 02 01 00 23")


def test_pipe_runs_ticks_only_while_the_host_waits():
    m = build_module()
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
        pipe = VirtualPipe(build_module(bt_port=make_link("bt", seed=seed)), "bt")
        pipe.write(PING)
        pipe.write(INTERRUPT_COUNTER_1KHZ)
        data = pipe.read(2000, timeout=2.0)
        return data, pipe.module.clock.ticks
    a = run(1)
    assert a[0].startswith(PING_ACK) and len(a[0]) == 2000
    assert a == run(1)


def test_bluetooth_pipe_is_limited_to_the_uart_rate():
    pipe = VirtualPipe(build_module(bt_port=make_link("bt", seed=2)), "bt")
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
        VirtualPipe(build_module(), "wifi")
