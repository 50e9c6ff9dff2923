"""The aids' observer hook (hostlib.fusion.aided.AidedFilter.observe_aids): each compass reading and
GPS fix the filter takes is told, with where the measured point was and what became of it; the
filter computes the same with observers as without."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hostlib.aids.compass import StanceReading
from hostlib.fusion.aid_events import COMPASS_OUTCOMES, GPS_OUTCOMES, AidEvent
from hostlib.fusion.feet import TwoFeetTracker
from hostlib.fusion.tracker import FusionSettings, FusionTracker
from hostlib.track.steps import rotation_z

DP = np.diag([1e-4, 1e-4, 1e-4, 1e-6])
FIELD_NED = 51.5 * np.array([math.cos(math.radians(72.5)), 0.0, math.sin(math.radians(72.5))])


def _reading(true_heading: float) -> StanceReading:
    """A level board at *true_heading* in a field without declination."""
    return StanceReading(rotation_z(true_heading).T @ FIELD_NED, np.eye(3), 3)


def _walk(tracker: FusionTracker, headings: list[float]) -> None:
    """Steps of 0.7 m north, a second apart, each with the compass reading *headings[k]*."""
    for k, heading in enumerate(headings, start=1):
        tracker.add_step([0.7, 0.0, 0.0, 0.0], DP, k, reading=_reading(heading), time_s=float(k))


def test_each_compass_reading_is_told_with_where_the_foot_was_and_whether_it_was_used():
    seen: list[AidEvent] = []
    tracker = FusionTracker(FusionSettings(compass=True, compass_sigma_rad=math.radians(2.0)))
    assert tracker.observe_aids(seen.append) == seen.append
    _walk(tracker, [0.0] * 5 + [math.radians(90.0)] + [0.0] * 3)
    assert [e.outcome for e in seen] == ["aligned"] + ["used"] * 4 + ["rejected"] + ["used"] * 3
    assert all(e.aid == "compass" and e.pose == "pose" and e.outcome in COMPASS_OUTCOMES for e in seen)
    assert [e.step for e in seen] == list(range(1, 10))
    rejected = seen[5]
    assert not rejected.accepted and rejected.reading == pytest.approx(math.radians(90.0))
    assert rejected.innovation == pytest.approx(math.radians(90.0), abs=0.05)
    assert rejected.at == pytest.approx((6 * 0.7, 0.0), abs=1e-6), "the foot, where its step ended"
    assert math.isnan(seen[0].innovation) and seen[0].accepted
    assert tracker.fusion.compass_rejected == 1 and tracker.fusion.compass_updates == 7


def test_observers_change_nothing_the_filter_computes():
    headings = [0.1 * math.sin(k) for k in range(30)]
    quiet, heard = (FusionTracker(FusionSettings(compass=True)) for _ in range(2))
    heard.observe_aids(lambda _event: None)
    _walk(quiet, headings)
    _walk(heard, headings)
    assert np.array_equal(quiet.track.poses, heard.track.poses)
    assert np.array_equal(quiet.filter.P, heard.filter.P)


def test_each_gps_fix_is_told_with_its_outcome_and_the_walkers_point():
    seen: list[AidEvent] = []
    tracker = TwoFeetTracker(aids=FusionSettings(gps=True, gps_interval_s=5.0))
    tracker.observe_aids(seen.append)
    for t in range(12):
        tracker.add_body_fix(float(t), (0.7 * t, 0.0))
    for k in range(1, 12):
        for side in ("left", "right"):
            dx = [0.35 if k == 1 else 0.7, 0.0, 0.0, 0.0]
            tracker.foot(side).add_step(dx, DP, k, time_s=k + 0.5 * (side == "right"))
    outcomes = [e.outcome for e in seen]
    assert outcomes[0] == "origin" and set(outcomes) <= set(GPS_OUTCOMES)
    assert all(e.aid == "gps" for e in seen)
    assert "before alignment" in outcomes, "without a compass the course aligns the heading after 50 m"
    assert tracker.fusion.gps_before_alignment == outcomes.count("before alignment")
    fix = seen[3]
    assert fix.reading == (pytest.approx(2.1), 0.0) and fix.time_s == 3.0
    assert fix.innovation == pytest.approx(math.hypot(fix.reading[0] - fix.at[0], fix.reading[1] - fix.at[1]))


def test_an_observer_must_be_callable():
    with pytest.raises(TypeError, match="callable"):
        FusionTracker(FusionSettings(compass=True)).observe_aids("not a function")
