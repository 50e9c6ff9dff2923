"""The host SDK over real OS transports to a real-time emulated module: a pty path
(as a Bluetooth /dev/rfcomm0 would be) and socket://, including a dropped link."""

from __future__ import annotations

import sys
import threading

import pytest

pytest.importorskip("firmware_sim.transports.tcp")

from firmware_sim.links.link import make_link  # noqa: E402
from firmware_sim.nav.firmware import build_module
from firmware_sim.transports.pacer import Pacer  # noqa: E402
from firmware_sim.transports.pty_endpoint import PtyEndpoint  # noqa: E402
from firmware_sim.transports.tcp import TcpEndpoint  # noqa: E402
from hostlib.link.device import Device  # noqa: E402
from protocol.ids import OutputMode, StateId  # noqa: E402


def collect(dev: Device, n: int, timeout: float = 10.0) -> list:
    got = []
    for pkt in dev.packets(timeout=timeout):
        got.append(pkt)
        if len(got) == n:
            break
    return got


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="pty pairing relies on Linux")
def test_device_over_a_pty_path(tmp_path):
    module = build_module(usb_port=make_link("usb", seed=1))
    ep = PtyEndpoint(module.usb.port, tmp_path / "rfcomm0")
    with Pacer(module, [ep], speed=1.0):
        with Device(str(ep.link_path), ack_timeout=2.0) as dev:
            assert not dev.serialize_io
            dev.ping()
            dev.output_state(StateId.INTERRUPT_COUNTER, 3 | OutputMode.LOSSLESS)
            got = collect(dev, 50)
            dev.output_all_off()
        numbers = [p.number for p in got]
        assert len(got) == 50 and numbers == sorted(set(numbers))
        assert dev.stats["acks_sent"] >= 50


def test_device_over_tcp_survives_a_dropped_link():
    module = build_module(bt_port=make_link("bt", seed=4))
    ep = TcpEndpoint(module.bt.port)
    url = f"socket://{ep.address[0]}:{ep.address[1]}"
    with Pacer(module, [ep], speed=1.0) as pacer:
        with Device(url, ack_timeout=2.0, reconnect_interval=0.05) as dev:
            down, up = threading.Event(), threading.Event()
            dev.on_link(lambda ev: (up if ev.up else down).set())
            dev.output_state(StateId.INTERRUPT_COUNTER, 5 | OutputMode.LOSSLESS)
            before = collect(dev, 10)
            pacer.call(lambda m: ep._hangup()).result(5)  # the module side drops the link
            assert down.wait(10) and up.wait(10)
            after = collect(dev, 10)
            dev.output_all_off()
        numbers = [p.number for p in before + after]
        assert len(numbers) == 20 and numbers == sorted(set(numbers))  # nothing twice, in order
        assert dev.stats["link_drops"] == 1 and dev.stats["reconnects"] == 1


def _walking_source():
    try:
        from firmware_sim.sensors import make_source
    except ImportError:
        pytest.skip("the emulator has no walking sensor scenarios yet")
    return make_source("stand:3+walk:20+stand:3", seed=1)


@pytest.mark.slow
def test_steps_missed_while_the_link_is_down_are_reported_as_a_gap():
    """The module keeps tracking while nobody listens; after the reconnect only the latest step
    comes (protocol.md §9): the host reports the missing steps instead of hiding them."""
    import serial

    from firmware_sim.mcu.module import ModuleConfig
    from firmware_sim.mcu.port import IdealPort

    src = _walking_source()
    link = make_link("bt", seed=1)
    module = build_module(ModuleConfig(rate_hz=src.rate_hz), src, usb_port=IdealPort(connected=False),
                          bt_port=link)
    ep = TcpEndpoint(link)
    url = f"socket://{ep.address[0]}:{ep.address[1]}"
    allow = threading.Event()
    allow.set()

    def factory():  # the host may reconnect only when the test allows it
        if not allow.wait(30):
            raise serial.SerialException("reconnect not allowed yet")
        return serial.serial_for_url(url, timeout=0.05)

    with Pacer(module, [ep], speed=4.0) as pacer:

        def module_steps() -> int:
            return pacer.call(lambda m: int(m.memory[StateId.STEP_COUNTER])).result(5)

        def counted(steps: int):
            return lambda m: int(m.memory[StateId.STEP_COUNTER]) >= steps

        with Device(port_factory=factory, ack_timeout=2.0, reconnect_interval=0.05) as dev:
            down = threading.Event()
            dev.on_link(lambda ev: ev.up or down.set())
            dev.start_stepwise_dead_reckoning()
            for ev in dev.steps(timeout=30):
                if ev.pose[0] > 3.0:
                    break
            allow.clear()
            pacer.call(lambda m: ep._hangup()).result(5)
            assert down.wait(10)
            first = module_steps()
            assert pacer.wait_until(counted(first + 3), timeout=60)  # the module tracks on, unheard
            allow.set()
            for ev in dev.steps(timeout=30):
                if ev.pose[0] > 8.0:
                    break
            gaps, stats = list(dev.gap_events), dev.stats
    assert len(gaps) == 1 and gaps[0].missing >= 2
    assert stats["missing_steps"] == gaps[0].missing and stats["duplicate_steps"] == 0
    assert stats["reconnects"] == 1
