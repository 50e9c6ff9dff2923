"""A GPS receiver read live: each fix put on the module's clock by the latest step, held until a
step came, queued only under the tracker's lock; with a module on each foot, on each foot's own
clock and the joint filter's latest, under both feet's locks; garbled lines and missing fixes
counted; a receiver read in its own thread, whose loss is reported once.

The host's clock is a fake one the tests set (no sleeps); the reader thread is waited on through
events with deadlines.
"""

from __future__ import annotations

import math
import threading
from dataclasses import replace

import numpy as np
import pytest
import serial

from firmware_sim.sensors.gps import DEFAULT_ORIGIN
from hostlib.fusion.tracker import FusionSettings, FusionTracker
from hostlib.run.gps_stream import FixClock, GpsStream, LiveFixes

from .protocol_fakegps import EXACT, epochs

DP = np.eye(4) * 1e-4


class HostClock:
    """The host's clock, set by the test."""

    def __init__(self, now: float = 0.0):
        self.now = now

    def __call__(self) -> float:
        return self.now


class RecordingTracker:
    """What LiveFixes uses of a tracker: the steps' module times and add_fix, which records each
    fix and checks it is queued under *lock*."""

    def __init__(self, lock: threading.Lock):
        self.lock = lock
        self.step_times: list[float] = []
        self.fixes: list[tuple[float, tuple[float, float]]] = []

    def add_fix(self, time_s: float, north_east) -> None:
        assert self.lock.locked(), "a fix is queued only while the steps' lock is held"
        self.fixes.append((time_s, tuple(float(v) for v in north_east)))


def test_a_fix_gets_the_module_time_of_the_latest_step_plus_the_host_time_since_it():
    clock = HostClock(100.0)
    times = FixClock(clock)
    assert times.module_time(99.0) is None, "no step yet: nothing to map to"
    times.step(7.0)  # arrived now, at host time 100
    assert times.anchor == (7.0, 100.0)
    assert times.module_time(100.4) == pytest.approx(7.4)
    times.step(8.0, host_s=101.1)
    assert times.module_time(101.3) == pytest.approx(8.2)
    assert times.module_time(100.9) == pytest.approx(8.2), "never before the fix before"
    times.step(math.nan, host_s=500.0)  # a packet without T_INT_K: the anchor stays
    assert times.anchor == (8.0, 101.1)
    assert times.module_time(101.6) == pytest.approx(8.5)


def test_fixes_are_held_until_a_tracker_and_a_step_then_queued_on_the_module_clock():
    clock = HostClock(10.0)
    live = LiveFixes(clock)
    lines = epochs(4)  # GGA, RMC per epoch; 1 m north a second
    for k in range(2):  # two epochs before the walk
        clock.now = 10.0 + k
        live.line(lines[2 * k])
        live.line(lines[2 * k + 1])
    assert live.held == 2 and live.queued == 0
    assert live.origin == pytest.approx(DEFAULT_ORIGIN, abs=1e-6), "the first fix is the origin"
    lock = threading.Lock()
    tracker = RecordingTracker(lock)
    live.attach(tracker, lock)
    live.stepped()  # no step summed yet
    assert live.held == 2
    tracker.step_times.append(50.0)
    live.stepped(host_s=11.5)
    assert [t for t, _ in tracker.fixes] == pytest.approx([48.5, 49.5])
    clock.now = 12.25
    live.line(lines[4])
    live.line(lines[5])
    assert [t for t, _ in tracker.fixes] == pytest.approx([48.5, 49.5, 50.75])
    north_east = np.array([ne for _, ne in tracker.fixes])
    np.testing.assert_allclose(north_east, [[0, 0], [1, 0], [2, 0]], atol=0.02)  # NMEA's 1e-5'
    assert live.held == 0 and live.queued == 3
    assert (live.stats.fixes, live.stats.other) == (3, 3)


def test_garbled_lines_and_epochs_without_a_fix_are_counted_and_queue_nothing():
    live = LiveFixes(HostClock())
    outage = epochs(3, replace(EXACT, outages=((0.0, 9.0),)))
    for line in [b"\x00garbage", "$GPGGA,1*00", "", *outage]:
        assert live.line(line) is None
    assert (live.stats.garbled, live.stats.missing_fix, live.stats.fixes) == (3, 3, 0)
    assert live.held == 0 and live.origin is None


def test_a_fusion_tracker_applies_each_live_fix_at_the_first_step_at_or_after_its_time():
    clock = HostClock(0.0)
    live = LiveFixes(clock)
    tracker = FusionTracker(FusionSettings(gps=True))
    live.attach(tracker, threading.Lock())
    lines = epochs(3)
    live.line(lines[0], host_s=0.0)  # held: no step yet
    tracker.add_step([0.7, 0, 0, 0], DP, 1, time_s=20.0)
    live.stepped(host_s=1.0)  # the held fix: 20 + (0 − 1) = 19 s
    live.line(lines[2], host_s=1.5)  # 20.5 s
    assert tracker.pending_fixes() == 2
    tracker.add_step([0.7, 0, 0, 0], DP, 2, time_s=20.4)
    live.stepped(host_s=1.4)
    assert tracker.pending_fixes() == 1, "the fix of 19 s applied at the step of 20.4 s; 20.5 s waits"
    tracker.add_step([0.7, 0, 0, 0], DP, 3, time_s=21.0)
    assert tracker.pending_fixes() == 0


def test_a_receiver_read_in_its_own_thread_gives_its_fixes_and_its_loss_is_said_once():
    port = serial.serial_for_url("loop://", timeout=0.05)
    gone = threading.Event()
    reports: list[str] = []

    def report(text: str) -> None:
        reports.append(text)
        gone.set()

    live = LiveFixes()
    with GpsStream("loop://", live, report=report, open_port=lambda url, **kw: port) as stream:
        lines = epochs(2)
        port.write(b"junk\r\n" + lines[0].encode()[:20])  # a sentence split across two reads
        port.write(lines[0].encode()[20:] + b"\r\n" + lines[1].encode() + b"\r\n")
        first = stream.wait_first_fix(timeout=10.0)
        assert first is not None and first.line == 2
        assert live.stats.garbled == 1
        port.close()  # the receiver is pulled out
        assert gone.wait(10.0)
        assert stream.lost is not None
    assert len(reports) == 1 and "the GPS receiver loop:// is gone" in reports[0]
    assert "tracking goes on without it" in reports[0]


def test_a_receiver_that_never_gives_a_fix_is_not_waited_for_beyond_the_deadline():
    port = serial.serial_for_url("loop://", timeout=0.05)
    with GpsStream("loop://", LiveFixes(), open_port=lambda url, **kw: port) as stream:
        assert stream.wait_first_fix(timeout=0.01) is None


class FeetLocks:
    """Both feet's session locks, recording whether both were held whenever a fix was queued."""

    def __init__(self):
        self.locks = {side: threading.Lock() for side in ("left", "right")}
        self.queued_without_both = 0

    def check(self, add_fix):
        """*add_fix*, counting the fixes queued without both locks held."""
        def add(time_s, north_east):
            self.queued_without_both += not all(lock.locked() for lock in self.locks.values())
            add_fix(time_s, north_east)
        return add


def test_with_two_feet_each_foot_takes_a_fix_on_its_own_module_clock_and_the_joint_filter_on_the_latest():
    from hostlib.fusion.feet import TwoFeetTracker

    clock = HostClock(0.0)
    live = LiveFixes(clock)
    tracker = TwoFeetTracker(aids=FusionSettings(gps=True))
    locks = FeetLocks()
    tracker.add_body_fix = locks.check(tracker.add_body_fix)
    for side in ("left", "right"):
        tracker.foot(side).add_fix = locks.check(tracker.foot(side).add_fix)
    live.attach(tracker, locks.locks["left"], locks.locks["right"])
    lines = epochs(3)
    # the two modules were powered on apart: the left one's clock reads 100 s, the right one's 5000 s
    tracker.left.add_step([0.7, 0, 0, 0], DP, 1, time_s=100.0)
    live.stepped(host_s=1.0, module="left")
    live.line(lines[0], host_s=1.2)  # left: 100.2 s; right: no step yet, held for it
    assert (tracker.left.pending_fixes(), tracker.right.pending_fixes(), tracker.pending_fixes()) == (1, 0, 1)
    assert live.held == 1 and live.queued == 1
    tracker.right.add_step([0.7, 0, 0, 0], DP, 1, time_s=5000.0)
    live.stepped(host_s=1.5, module="right")  # the held fix on the right clock: 5000 + (1.2 − 1.5)
    assert tracker.right.pending_fixes() == 1 and live.held == 0
    assert tracker.pending_fixes() == 0, "the joint filter reached 100.2 s with the right foot's step"
    live.line(lines[2], host_s=2.0)  # left: 101.0 s, right: 5000.5 s; the joint filter: the latest
    tracker.left.add_step([0.7, 0, 0, 0], DP, 2, time_s=101.1)
    assert tracker.left.pending_fixes() == 0, "both fixes reached on the left foot's clock"
    assert tracker.pending_fixes() == 1, "the joint filter is at 5000 s: the second fix (5000.5 s) waits"
    tracker.right.add_step([0.7, 0, 0, 0], DP, 2, time_s=5000.6)
    assert (tracker.right.pending_fixes(), tracker.pending_fixes()) == (0, 0)
    assert locks.queued_without_both == 0, "every fix was queued holding both feet's locks"
    assert live.queued == 2
