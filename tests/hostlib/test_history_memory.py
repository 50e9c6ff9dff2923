"""A long walk's host stays flat in memory: what the trackers keep of each step (the track, the
two feet's joint history, the aids' queues) is a few hundred bytes, in growing arrays, and the
whole walk is still there for a page opened late and the CSV at the end."""

from __future__ import annotations

import gc
import math
import tracemalloc

import numpy as np

from hostlib.aids.compass import StanceReading
from hostlib.fusion.feet import FOOT_SIDES, TwoFeetTracker
from hostlib.fusion.tracker import FusionSettings
from hostlib.track.rows import Rows
from hostlib.track.steps import rotation_z

DP = np.diag([1e-4, 1e-4, 1e-4, 1e-5])
FIELD_NED = 51.5 * np.array([math.cos(math.radians(72.5)), 0.0, math.sin(math.radians(72.5))])
STRIDE = 1.4  # m
STEP_PERIOD = 0.55  # s between the two feet's steps
#: What a fused step may leave behind in memory [B] (it is about 620: the two feet's joint history
#: 300, the stepping foot's own track 230, the compass innovations): a 30-minute walk, about 3300
#: steps of both feet, keeps about 2 MB (each step's poses and covariances as Python objects took
#: 2.3 kB).
BYTES_PER_STEP = 700


def _heading(n: int) -> float:
    """The walker's true heading at step *n*: a slow weave."""
    return 0.3 * math.sin(n / 200.0) if n >= 0 else 0.0


def _walk(tracker: TwoFeetTracker, steps: range, counter: dict[str, int]) -> None:
    """Steps *steps* of a walk, the feet in turn, each with its compass reading, and a GPS fix of
    the body every other step (about a second apart)."""
    for n in steps:
        side, t, heading = FOOT_SIDES[n % 2], STEP_PERIOD * (n + 1), _heading(n)
        if n % 2 == 0:
            tracker.add_fix(t, [0.5 * STRIDE * n * math.cos(heading), 0.5 * STRIDE * n * math.sin(heading)])
        counter[side] += 1
        dx = np.array([STRIDE, 0.0, 0.0, heading - _heading(n - 2)])
        reading = StanceReading(rotation_z(heading).T @ FIELD_NED, np.eye(3), 3)
        tracker.foot(side).add_step(dx, DP, counter[side] % 65536, 0.4, reading=reading, time_s=t)


def _mapped_bytes() -> int:
    """The resident bytes of the histories in mappings of their own (tracemalloc sees the heap only)."""
    return sum(r.resident_nbytes for r in gc.get_objects() if isinstance(r, Rows) and r.mapped)


def test_a_long_two_feet_walk_with_compass_and_gps_keeps_a_few_hundred_bytes_a_step():
    tracker = TwoFeetTracker(aids=FusionSettings(compass=True, gps=True))
    counter = dict.fromkeys(FOOT_SIDES, 0)
    _walk(tracker, range(400), counter)  # the heading aligned, the filter's arrays all made
    assert tracker.heading_aligned and tracker.fusion.gps_updates > 0
    gc.collect()
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0] + _mapped_bytes()
        _walk(tracker, range(400, 4400), counter)
        gc.collect()
        grown = tracemalloc.get_traced_memory()[0] + _mapped_bytes() - before
    finally:
        tracemalloc.stop()
    assert grown / 4000 < BYTES_PER_STEP
    assert tracker.pending_fixes() <= 1, "the fixes applied are let go"
    poses, covs = tracker.body_poses()
    assert poses.shape == (4401, 4) and covs.shape == (4401, 4, 4), "the whole walk is still there"
    assert np.hypot(*poses[0, :2]) < 0.1 and poses[-1, 0] > 0.9 * 0.5 * STRIDE * 4400


def test_rows_read_as_one_array_and_a_large_one_is_resident_only_where_filled():
    rows = Rows((2,), capacity=4)
    for k in range(100):
        rows.append([k, -k])
    assert len(rows) == 100 and not rows.mapped and rows.nbytes <= 2 * 100 * 2 * 8
    np.testing.assert_array_equal(rows.view()[:, 0], np.arange(100))
    rows.set_last([7, 7])
    copy = rows.copy()
    rows.append([1, 1])
    assert copy.shape == (100, 2) and copy[-1].tolist() == [7, 7]
    big = Rows((4, 4))
    for k in range(5000):
        big.append(np.full((4, 4), k))
    assert big.mapped and big.resident_nbytes == 5000 * 128 < big.nbytes
    assert big[-1][0, 0] == 4999 and big.view()[1234, 3, 3] == 1234
