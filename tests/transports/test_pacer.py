"""The real-time pacer: a module's ticks paced to the wall clock, its endpoints pumped."""

from __future__ import annotations

import threading

import pytest

from firmware_sim.nav.firmware import build_module
from firmware_sim.transports.pacer import MultiPacer, Pacer
from firmware_sim.transports.pipe import QueueEndpoint

INTERRUPT_COUNTER_1KHZ = bytes.fromhex("20 02 01 00 23")
OUTPUT_ACK = bytes.fromhex("A0 20 00 C0")

# --------------------------------------------------------------------------- waiting on ticks


@pytest.mark.parametrize("speed", [1.0, 0.0])
def test_wait_ticks_returns_once_the_module_ran_that_many_more_ticks(speed):
    m = build_module()
    with Pacer(m, speed=speed) as pacer:
        before = pacer.ticks
        assert pacer.wait_ticks(50, timeout=10)
        assert pacer.ticks >= before + 50
        assert pacer.call(lambda mod: mod.clock.ticks).result(5) >= before + 50
        assert pacer.wait_ticks(0, timeout=0)  # nothing to wait for


def test_wait_ticks_is_false_on_timeout_when_no_loop_runs():
    idle = Pacer(build_module())  # never started
    assert idle.wait_ticks(1, timeout=0.05) is False
    stopped = Pacer(build_module(), speed=0).start()
    assert stopped.wait_ticks(10, timeout=10)
    stopped.stop()
    ticks = stopped.ticks
    assert stopped.wait_ticks(1, timeout=0.05) is False
    assert stopped.wait_until(lambda mod: True, timeout=0.05) is False
    assert stopped.ticks == ticks


def test_a_wait_returns_false_when_the_loop_stops_under_it():
    pacer = Pacer(build_module()).start()
    tested = threading.Event()

    def never(mod) -> bool:
        tested.set()
        return False
    got: list[bool] = []
    waiter = threading.Thread(target=lambda: got.append(pacer.wait_until(never, timeout=60)))
    waiter.start()
    assert tested.wait(10)  # the waiter waits, its predicate tested after ticks
    pacer.stop()
    waiter.join(30)
    assert got == [False]


def test_wait_until_sees_the_module_in_the_loop_thread():
    m = build_module()
    ep = QueueEndpoint(m.usb.port)
    seen: list[tuple[int, int]] = []

    def five_packets(mod) -> bool:
        seen.append((threading.get_ident(), mod.usb.packets_assembled))
        return mod.usb.packets_assembled >= 5

    with Pacer(m, [ep]) as pacer:
        ep.write(INTERRUPT_COUNTER_1KHZ)
        assert pacer.wait_until(five_packets, timeout=10)
        loop_thread = pacer.call(lambda mod: threading.get_ident()).result(5)
        assert pacer.call(lambda mod: mod.usb.packets_assembled).result(5) >= 5
    assert {t for t, _ in seen} == {loop_thread} != {threading.get_ident()}
    assert [n for _, n in seen] == sorted(n for _, n in seen) and seen[-1][1] >= 5
    data = ep.read(54, timeout=0)
    assert data[:4] == OUTPUT_ACK and len(data) == 54  # the ack, then five 10-byte packets reached the host


def test_wait_until_raises_what_the_predicate_raises_and_the_loop_goes_on():
    with Pacer(build_module()) as pacer:
        with pytest.raises(ZeroDivisionError):
            pacer.wait_until(lambda mod: 1 / 0, timeout=10)
        assert pacer.wait_ticks(5, timeout=10)
        assert pacer.status().running and pacer.error is None


def test_multipacer_waits_on_each_module():
    modules = [build_module(), build_module()]
    with MultiPacer.of([(m, []) for m in modules], frame_ticks=4) as loop:
        assert loop.wait_ticks(1, 40, timeout=10)
        assert loop.wait_until(0, lambda mod: mod.clock.ticks >= 40, timeout=10)
        assert loop.wait_until(1, lambda mod: mod is modules[1], timeout=10)
    assert all(p.ticks >= 40 for p in loop.pacers)
    assert loop.wait_ticks(0, 1, timeout=0.05) is False  # stopped
