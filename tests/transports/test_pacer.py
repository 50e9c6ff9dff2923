"""The real-time pacer: a module's ticks paced to the wall clock, its endpoints pumped."""

from __future__ import annotations

import math
import threading
import time

import pytest

from firmware_sim.links.link import make_link
from firmware_sim.mcu.module import ModuleConfig
from firmware_sim.nav.firmware import build_module
from firmware_sim.transports.pacer import MultiPacer, Pacer
from firmware_sim.transports.pipe import QueueEndpoint

PING = bytes.fromhex("030003")
PING_ACK = bytes.fromhex("A00300A3")
INTERRUPT_COUNTER_1KHZ = bytes.fromhex("20 02 01 00 23")
OUTPUT_ACK = bytes.fromhex("A0 20 00 C0")
#: How long a test waits on the loop before it fails: a guard against a hang, not a speed limit.
WAIT_S = 30.0


def _ticked(ticks: int):
    """A predicate of a module: it has run *ticks* ticks."""
    return lambda mod: mod.clock.ticks >= ticks


def test_pacer_as_fast_as_possible_runs_and_stops_cleanly():
    m = build_module()
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
    m = build_module()
    pacer = Pacer(m, speed=1.0).start()
    try:
        t0 = time.monotonic()
        assert pacer.wait_until(_ticked(200), timeout=WAIT_S)  # 0.2 s of module time
        elapsed = time.monotonic() - t0
        st = pacer.status()
    finally:
        pacer.stop()
    assert elapsed >= 0.19  # never ahead of the wall clock
    assert st.running and st.virtual_s <= st.wall_s + 0.002
    assert st.loop_us_mean > 0 and st.packets == {"USB": 0, "BT": 0}


def slowed(module):
    """*module* with each loop taking 3 ms of CPU: too slow for 1 kHz on any machine."""
    real_step = module.step

    def slow_step():
        real_step()
        end = time.perf_counter() + 0.003
        while time.perf_counter() < end:
            pass
    module.step = slow_step
    return module


def test_pacer_counts_overruns_when_the_machine_is_too_slow():
    m = slowed(build_module())
    pacer = Pacer(m, speed=1.0, max_lag_s=0.05).start()
    try:
        assert pacer.wait_until(_ticked(60), timeout=WAIT_S)
    finally:
        pacer.stop()
    st = pacer.status()
    assert st.overruns > 0 and st.rebases > 0
    assert st.ticks == m.clock.ticks  # no tick skipped: virtual time stays whole


def test_pacer_control_channel_reports_errors():
    m = build_module(bt_port=make_link("bt"))
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
        Pacer(build_module(), speed=-1)


def test_pacer_speed_10_runs_ten_times_faster_than_the_wall_clock():
    m = build_module()
    pacer = Pacer(m, speed=10.0).start()
    try:
        t0 = time.monotonic()
        assert pacer.wait_until(_ticked(1000), timeout=WAIT_S)
        elapsed = time.monotonic() - t0
    finally:
        pacer.stop()
    assert m.clock.ticks >= 1000
    assert elapsed >= 0.095  # 1 s of module time, not sooner than 0.1 s of wall time


# --------------------------------------------------------------------------- many modules, one loop


def test_multipacer_runs_every_module_in_one_thread_each_on_its_own_port():
    modules = [build_module(bt_port=make_link("bt", seed=i)) for i in range(3)]
    eps = [QueueEndpoint(m.bt.port) for m in modules]
    loop = MultiPacer.of([(m, [ep]) for m, ep in zip(modules, eps, strict=True)], speed=1.0)
    with loop:
        for ep in eps:
            ep.write(PING)  # no fd: picked up by the idle pump (every 5 ms), the ack as soon as it arrives
        for ep in eps:
            assert ep.read(4, timeout=5) == PING_ACK
        threads = {loop.call(i, lambda mod: threading.get_ident()).result(5) for i in range(3)}
        assert loop.call(1, lambda mod: mod).result(5) is modules[1]  # controls reach their own module
        assert loop.wait_until(0, _ticked(100), timeout=WAIT_S)
        st = loop.status()
    assert len(threads) == 1 and threads != {threading.get_ident()}
    assert all(s.running for s in st)
    ticks = [p.ticks for p in loop.pacers]
    assert max(ticks) - min(ticks) <= 1 and min(ticks) >= 99  # modules take their ticks in turn
    # never ahead of the wall clock by more than the Bluetooth link's latency less a tick
    assert all(s.lookahead_ms == pytest.approx(19.0) for s in st)
    assert all(s.virtual_s <= s.wall_s + s.lookahead_ms / 1e3 + 0.002 for s in st)
    assert all(not m.bt.port.connected for m in modules) and all(ep.closed for ep in eps)
    assert not any(p.status().running for p in loop.pacers)


def test_multipacer_runs_bluetooth_modules_ahead_yet_hosts_see_the_links_timing():
    # the last one on an ideal port
    modules = [build_module(bt_port=make_link("bt", seed=i)) for i in range(2)] + [build_module()]
    usb = build_module(bt_port=make_link("usb"))
    eps = [QueueEndpoint(m.bt.port) for m in modules + [usb]]
    loop = MultiPacer.of([(m, [ep]) for m, ep in zip(modules + [usb], eps, strict=True)], speed=1.0,
                         frame_ticks=4)
    with loop:
        assert loop.wait_until(0, _ticked(50), timeout=WAIT_S)
        # running ahead, a module's links are on the host's clock; never ahead (USB), on its own
        clocks = [loop.call(k, lambda mod: mod.bt.port.host_clock is not None).result(5) for k in (0, 1, 3)]
        assert clocks == [True, True, False]
        eps = eps[:3]
        rtt = []
        for ep in eps:
            t0 = time.monotonic()
            ep.write(PING)
            assert ep.read(4, timeout=5) == PING_ACK
            rtt.append(time.monotonic() - t0)
        st = loop.status()
    # Bluetooth: 19 ms ahead (latency less a tick); an overrun only past 19 + 20 - 4 ms of lateness
    assert [s.lookahead_ms for s in st] == pytest.approx([19.0, 19.0, 0.0, 0.0])
    assert [s.overrun_limit_ms for s in st] == pytest.approx([35.0, 35.0, 4.0, 4.0])
    # running ahead never brings the ack sooner than 20 ms there and 20 ms back on the air
    assert min(rtt[:2]) >= 0.040
    assert all(m.bt.port.host_clock is None for m in modules[:2])  # back on the module's clock


class _DeafEndpoint:
    """An endpoint on a link that never reads what reaches its host (a pty nobody opened)."""

    fds: tuple[int, ...] = ()

    def __init__(self, port) -> None:
        self.port = port
        self.pumps = 0

    def pump(self) -> None:
        self.pumps += 1

    def close(self) -> None:
        pass


def test_bytes_due_at_a_host_nobody_reads_do_not_make_the_loop_spin():
    link = make_link("bt", seed=0)
    m = build_module(bt_port=link)
    ep = _DeafEndpoint(link)
    link.host_write(PING)  # its ack reaches the host side ~40-80 ms in, and stays there unread
    loop = MultiPacer.of([(m, [ep])], speed=1.0, frame_ticks=4)
    with loop:
        assert loop.wait_until(0, _ticked(200), timeout=WAIT_S)
    assert link.counters.to_host.sent == 4  # the ack was sent, and is due at the host
    # at most two pumps per 4-tick frame (its own, one release), not a busy loop on bytes nobody takes
    assert ep.pumps <= loop.pacers[0].ticks // 2


class _CountingEndpoint:
    """An endpoint whose port never has bytes for the host; counts its pumps."""

    fds: tuple[int, ...] = ()

    def __init__(self) -> None:
        self.pumps = 0
        self.port = self

    def host_pending(self) -> int:
        return 0

    def pump(self) -> None:
        self.pumps += 1

    def close(self) -> None:
        pass


def test_multipacer_pumps_a_quiet_endpoint_only_every_idle_interval():
    quiet = _CountingEndpoint()
    lone = _CountingEndpoint()
    loop = MultiPacer([Pacer(build_module(), [quiet])], idle_pump_s=0.01).start()
    solo = Pacer(build_module(), [lone]).start()  # a lone pacer pumps on every pass
    try:
        assert loop.wait_until(0, _ticked(200), timeout=WAIT_S)
        assert solo.wait_until(_ticked(200), timeout=WAIT_S)
    finally:
        loop.stop()
        solo.stop()
    assert quiet.pumps <= loop.pacers[0].ticks / 10 + 2
    assert lone.pumps >= solo.ticks / 8  # (it runs at most 8 ticks between two passes)


def test_multipacer_counts_overruns_per_module_and_keeps_virtual_time_whole():
    fast, slow = build_module(), slowed(build_module())
    loop = MultiPacer([Pacer(fast, speed=1.0, max_lag_s=0.05), Pacer(slow, speed=1.0, max_lag_s=0.05)])
    with loop:
        assert loop.wait_until(1, _ticked(60), timeout=WAIT_S)
    a, b = loop.status()
    assert b.loop_us_mean > 2000 and a.loop_us_mean < b.loop_us_mean  # each module's own step time
    assert a.overruns > 0 and b.overruns > 0 and a.rebases == b.rebases > 0
    assert a.ticks == fast.clock.ticks and b.ticks == slow.clock.ticks and abs(a.ticks - b.ticks) <= 1


def test_multipacer_blames_the_module_that_raised():
    good, bad = build_module(), build_module()

    def broken():
        raise RuntimeError("sensor bus hung")
    bad.step = broken
    loop = MultiPacer([Pacer(good, speed=0), Pacer(bad, speed=0)])
    with pytest.raises(RuntimeError, match="sensor bus"):
        loop.run(duration_s=5)
    assert isinstance(loop.pacers[1].error, RuntimeError) and loop.pacers[0].error is None
    assert loop.error is loop.pacers[1].error and not loop.running


def test_multipacer_refuses_modules_it_cannot_pace_together():
    with pytest.raises(ValueError, match="one rate"):
        MultiPacer([Pacer(build_module()), Pacer(build_module(ModuleConfig(rate_hz=500.0)))])
    with pytest.raises(ValueError, match="one speed"):
        MultiPacer([Pacer(build_module(), speed=1.0), Pacer(build_module(), speed=2.0)])
    with pytest.raises(ValueError, match="at least one"):
        MultiPacer([])
    p = Pacer(build_module())
    MultiPacer([p, Pacer(build_module())])
    with pytest.raises(ValueError, match="another loop"):
        MultiPacer([p])


@pytest.mark.parametrize("spin_load", [None, 0.0])  # sleeping between deadlines, or polling
def test_multipacer_spreads_the_modules_over_the_period_and_none_runs_early(spin_load):
    modules = [build_module(), build_module()]
    times: list[list[float]] = [[], []]
    for m, log in zip(modules, times, strict=True):
        real = m.step

        def step(real=real, log=log):
            log.append(time.perf_counter())
            real()
        m.step = step
    loop = MultiPacer([Pacer(m) for m in modules], spin_load=spin_load)
    with loop:
        assert loop.wait_until(1, _ticked(50), timeout=WAIT_S)  # module 0 runs first in each frame
    period = 1e-3
    for phase, log in zip((0.0, 0.5), times, strict=True):
        assert len(log) >= 50
        assert all(t - loop.t_start >= (k + 1 + phase) * period for k, t in enumerate(log))  # never early


# --------------------------------------------------------------------------- waiting on ticks


@pytest.mark.parametrize("speed", [1.0, 0.0, math.inf])
def test_wait_ticks_returns_once_the_module_ran_that_many_more_ticks(speed):
    m = build_module()
    with Pacer(m, speed=speed) as pacer:
        before = pacer.ticks
        assert pacer.wait_ticks(50, timeout=WAIT_S)
        assert pacer.ticks >= before + 50
        assert pacer.call(lambda mod: mod.clock.ticks).result(5) >= before + 50
        assert pacer.wait_ticks(0, timeout=0)  # nothing to wait for


def test_wait_ticks_is_false_on_timeout_when_no_loop_runs():
    idle = Pacer(build_module())  # never started
    assert idle.wait_ticks(1, timeout=0.05) is False
    stopped = Pacer(build_module(), speed=0).start()
    assert stopped.wait_ticks(10, timeout=WAIT_S)
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
    waiter = threading.Thread(target=lambda: got.append(pacer.wait_until(never, timeout=2 * WAIT_S)))
    waiter.start()
    assert tested.wait(WAIT_S)  # the waiter waits, its predicate tested after ticks
    pacer.stop()
    waiter.join(WAIT_S)
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
        assert pacer.wait_until(five_packets, timeout=WAIT_S)
        loop_thread = pacer.call(lambda mod: threading.get_ident()).result(5)
        assert pacer.call(lambda mod: mod.usb.packets_assembled).result(5) >= 5
    assert {t for t, _ in seen} == {loop_thread} != {threading.get_ident()}
    assert [n for _, n in seen] == sorted(n for _, n in seen) and seen[-1][1] >= 5
    data = ep.read(54, timeout=0)
    assert data[:4] == OUTPUT_ACK and len(data) == 54  # the ack, then five 10-byte packets reached the host


def test_wait_until_raises_what_the_predicate_raises_and_the_loop_goes_on():
    with Pacer(build_module()) as pacer:
        with pytest.raises(ZeroDivisionError):
            pacer.wait_until(lambda mod: 1 / 0, timeout=WAIT_S)
        assert pacer.wait_ticks(5, timeout=WAIT_S)
        assert pacer.status().running and pacer.error is None


def test_multipacer_waits_on_each_module():
    modules = [build_module(), build_module()]
    with MultiPacer.of([(m, []) for m in modules], frame_ticks=4) as loop:
        assert loop.wait_ticks(1, 40, timeout=WAIT_S)
        assert loop.wait_until(0, _ticked(40), timeout=WAIT_S)
        assert loop.wait_until(1, lambda mod: mod is modules[1], timeout=WAIT_S)
    assert all(p.ticks >= 40 for p in loop.pacers)
    assert loop.wait_ticks(0, 1, timeout=0.05) is False  # stopped



def test_an_fd_closed_outside_a_pump_is_no_longer_watched_after_a_refresh():
    """What a control call that hangs a host up does between two pumps: the endpoint's socket is
    closed, and a select on it fails (the loop ended so); refreshed, the selector forgets it."""
    import socket
    from types import SimpleNamespace

    from firmware_sim.transports.pacer.pumps import Pumps

    a, b = socket.socketpair()
    ep = SimpleNamespace(fds=(a.fileno(),), pump=lambda: None, close=lambda: None)
    pumps = Pumps([SimpleNamespace(endpoints=[ep])], idle_pump_s=0, poll=1)
    try:
        pumps.pump(0, 0)
        b.send(b"x")
        assert pumps.select(0) == [0], "the endpoint's fd is watched"
        a.close()
        ep.fds = ()
        with pytest.raises(OSError):
            pumps.select(0)
        pumps.refresh()
        assert pumps.select(0) is None, "nothing left to watch"
    finally:
        b.close()


def test_the_loop_refreshes_what_it_watches_after_control_calls(monkeypatch):
    from firmware_sim.transports.pacer.pumps import Pumps

    refreshed = threading.Event()
    monkeypatch.setattr(Pumps, "refresh", lambda self: refreshed.set())
    m = build_module()
    with Pacer(m, [QueueEndpoint(m.usb.port)], speed=1.0) as pacer:
        assert pacer.wait_ticks(50, timeout=WAIT_S)
        assert not refreshed.is_set(), "no control call, nothing to refresh"
        pacer.call(lambda mod: None).result(WAIT_S)
        assert refreshed.wait(WAIT_S)
