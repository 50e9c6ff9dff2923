"""The pacer's parts that decide what a loop of many modules does, in frames and wall times given by
the test (no clock): which quiet endpoints are pumped, when bytes are due, which ticks a host's bytes
make run, which modules are advanced together — and that a group advanced together sends what each
module sends alone."""

from __future__ import annotations

import math
import socket
from types import SimpleNamespace

from firmware_sim.mcu.module import ModuleConfig
from firmware_sim.nav import lockstep
from firmware_sim.nav.firmware import build_module
from firmware_sim.sensors.imu_array import make_source
from firmware_sim.transports.pacer import MultiPacer, PacedModule, run_loop
from firmware_sim.transports.pacer.pumps import WATCHED_POLL, Pumps
from firmware_sim.transports.pacer.release import Releases
from firmware_sim.transports.pacer.schedule import Schedule
from protocol.frames import build_command
from protocol.ids import Command, StateId


class _QuietEndpoint:
    """An endpoint whose port never has bytes for the host; counts its pumps."""

    def __init__(self, fds: tuple[int, ...] = ()):
        self.fds = fds
        self.pumps = 0
        self.port = SimpleNamespace(host_pending=lambda: 0)

    def pump(self) -> None:
        self.pumps += 1

    def close(self) -> None:
        pass


def test_a_quiet_endpoint_whose_fd_is_watched_is_pumped_ten_times_less_often():
    """A pty a host holds (its fd wakes the loop on the host's bytes or leaving) needs the idle pump
    only for what the endpoint keeps; one without an fd (a pty nobody holds) needs it to notice a
    host that comes."""
    a, b = socket.socketpair()
    try:
        watched, unwatched = _QuietEndpoint((a.fileno(),)), _QuietEndpoint()
        pumps = Pumps([SimpleNamespace(endpoints=[watched]), SimpleNamespace(endpoints=[unwatched])],
                      idle_pump_s=0.005, poll=2)
        pumps.pump_all(0)
        frames = 200
        for f in range(1, frames + 1):
            pumps.pump_owned(0, False, f)
            pumps.pump_owned(1, False, f)
        assert unwatched.pumps == 1 + frames // 2
        assert watched.pumps == 1 + frames // (2 * WATCHED_POLL)
        pumps.pump_owned(0, True, frames + 1)  # bytes due: pumped at once
        assert watched.pumps == 2 + frames // (2 * WATCHED_POLL)
    finally:
        pumps.close()
        a.close()
        b.close()


class _Clock:
    """A host clock whose wall time is the cycle itself."""

    @staticmethod
    def wall_time(cycle: float) -> float:
        return cycle


def test_the_earliest_bytes_due_follow_every_module_s_links():
    """Of three modules' links, the earliest arrival at a host is the loop's next wake-up; bytes
    handed over (or that no host took) no longer count."""
    arrivals = [[5.0], [3.0], [None]]
    links = [[SimpleNamespace(next_host_arrival=lambda k=k: arrivals[k][0])] for k in range(3)]
    rel = Releases(3)
    for k in range(3):
        rel.attach(k, _Clock(), links[k], 0)  # type: ignore[arg-type]
        rel.update(k)
    assert rel.earliest() == 3.0
    arrivals[1][0] = 9.0
    rel.update(1)
    assert rel.earliest() == 5.0
    handed = []

    def hand_over(k: int) -> None:
        handed.append(k)
        arrivals[k][0] = None
        rel.update(k)

    rel.release_due(4.0, hand_over)
    assert handed == [] and rel.earliest() == 5.0
    rel.release_due(6.0, hand_over)
    assert handed == [0] and rel.earliest() == 9.0
    rel.release_due(9.5, lambda k: None)  # nobody took module 1's bytes: not looked at again
    assert rel.earliest() == math.inf
    arrivals[2][0] = 1.0
    rel.update(2)
    assert rel.earliest() == 1.0


def test_a_host_s_bytes_are_taken_by_the_module_s_next_loop_at_once():
    """A host wrote 2.4 ticks after the start, when ticks 1 and 2 had run: the module that does not
    run ahead runs tick 3 at once (the loop that takes the bytes); a second command in the same
    tick, tick 4; a third waits for tick 3's interrupt — never more than two ticks past it."""
    one = Schedule(1, 1000.0, 1.0, 1, None)
    one.f = 2  # ticks 1 and 2 ran, at 1 and 2 ms
    assert one.ticks_due(0, 0.0024) == 2
    assert one.taking_bytes(0, 0.0024, 2, 2) == 3
    assert one.taking_bytes(0, 0.0026, 3, 2) == 4
    assert one.taking_bytes(0, 0.0028, 4, 2) == 4
    assert one.taking_bytes(0, 0.0031, 4, 2) == 5
    framed = Schedule(1, 1000.0, 1.0, 4, None)
    framed.f = 1  # frame 0 ran: ticks 1–4, at 4 ms; a host writes at 5.4 ms
    assert framed.taking_bytes(0, 0.0054, 4, 2) == 5  # the tick due, which takes the bytes
    assert framed.taking_bytes(0, 0.0094, 4, 2) == 8  # late: the ticks due, to the frame's end


def test_modules_of_one_phase_form_a_group():
    """Five modules over two phases: modules 0–2 due at once, then 3–4; one per module: no group."""
    assert Schedule(5, 1000.0, 1.0, 4, 2).phase_groups() == [3, 3, 3, 5, 5]
    assert Schedule(3, 1000.0, 1.0, 4, None).phase_groups() == [1, 2, 3]
    apart = Schedule(2, 1000.0, 1.0, 4, 1)
    apart.run_ahead([19.0, 0.0])  # one runs ahead, the other not: due at other times
    assert apart.phase_groups() == [1, 2]


def test_a_phase_group_advanced_together_sends_what_each_module_sends_alone(monkeypatch):
    """Three modules tracking at one phase, paced at 20× real time: each one's bytes, states and
    clock are those of the same module stepped alone for as many loops; the loop's thread runs
    every stretch itself, even where a lockstep could hand half to its helper thread (a frame
    never waits on a thread the machine's other processes can hold up)."""
    calls = []
    handed = []
    monkeypatch.setattr(lockstep, "_helper", lambda: SimpleNamespace(submit=lambda *a: handed.append(a)))
    monkeypatch.setattr(lockstep.fastpath, "group_releases_gil", lambda: True)

    class Counted(lockstep.Lockstep):
        def advance(self, max_ticks):  # type: ignore[no-untyped-def]
            calls.append(len(self.modules))
            return super().advance(max_ticks)

    monkeypatch.setattr(run_loop, "Lockstep", Counted)

    def module(seed: int):  # type: ignore[no-untyped-def]
        m = build_module(ModuleConfig(), sensors=make_source("stand:3+walk:4", seed=seed))
        m.usb.port.host_write(build_command(Command.STEPWISE_DEAD_RECKONING))
        return m

    paced = [module(s) for s in range(3)]
    loop = MultiPacer([PacedModule(m, speed=20.0) for m in paced], phases=1, frame_ticks=4)
    with loop:
        for i in range(3):
            assert loop.wait_until(i, lambda m: m.clock.ticks >= 6000, timeout=120)
    assert calls and set(calls) == {3} and not handed
    for s, m in enumerate(paced):
        alone = module(s)
        alone.run(m.clock.ticks)
        assert m.usb.port.host_read() == alone.usb.port.host_read()
        assert bytes(m.memory.arena) == bytes(alone.memory.arena)
        assert m.clock.now_cycles == alone.clock.now_cycles
        assert m.memory.read_wire(StateId.STEP_COUNTER) != b"\x00\x00"  # it tracked steps
