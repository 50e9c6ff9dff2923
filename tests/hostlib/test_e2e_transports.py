"""The host SDK over real OS transports to a real-time emulated module: a pty path
(as a Bluetooth /dev/rfcomm0 would be) and socket://, including a dropped link."""

from __future__ import annotations

import sys
import threading

import pytest

pytest.importorskip("firmware_sim.transports.tcp")

from firmware_sim.link import make_link  # noqa: E402
from firmware_sim.module import Module  # noqa: E402
from firmware_sim.transports.pacer import Pacer  # noqa: E402
from firmware_sim.transports.pty import PtyEndpoint  # noqa: E402
from firmware_sim.transports.tcp import TcpEndpoint  # noqa: E402
from hostlib.device import Device  # noqa: E402
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
    module = Module(usb_port=make_link("usb", seed=1))
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
    module = Module(bt_port=make_link("bt", seed=4))
    ep = TcpEndpoint(module.bt.port)
    url = f"socket://{ep.address[0]}:{ep.address[1]}"
    with Pacer(module, [ep], speed=1.0) as pacer:
        with Device(url, ack_timeout=2.0, reconnect_interval=0.05) as dev:
            down, up = threading.Event(), threading.Event()
            dev.add_callback("link", lambda ev: (up if ev.up else down).set())
            dev.output_state(StateId.INTERRUPT_COUNTER, 5 | OutputMode.LOSSLESS)
            before = collect(dev, 10)
            pacer.call(lambda m: ep._hangup()).result(5)  # the module side drops the link
            assert down.wait(10) and up.wait(10)
            after = collect(dev, 10)
            dev.output_all_off()
        numbers = [p.number for p in before + after]
        assert len(numbers) == 20 and numbers == sorted(set(numbers))  # nothing twice, in order
        assert dev.stats["link_drops"] == 1 and dev.stats["reconnects"] == 1
