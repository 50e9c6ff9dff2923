"""The walk's live page without a browser: the bounded model (hostlib.web.model), where a page listens
(hostlib.web.address), and the feed (hostlib.web.feed) following a walk's trackers — a half-hour walk
of two feet held in bounded series, a track the GPS turned replaced whole, the compass readings where
the foot was."""

from __future__ import annotations

import argparse
import json
import math
import socket
import threading
from types import SimpleNamespace

import numpy as np
import pytest

from hostlib.aids.compass import StanceReading
from hostlib.fusion.feet import TwoFeetTracker
from hostlib.fusion.tracker import FusionSettings, FusionTracker
from hostlib.link.session import SessionStats
from hostlib.track.steps import rotation_z
from hostlib.web.address import bind_refusal, is_loopback, os_reason, page_url, web_address
from hostlib.web.feed import SERIES_CAPS, WalkFeed, ellipse
from hostlib.web.model import LiveModel, thin

DP = np.diag([1e-4, 1e-4, 1e-4, 1e-6])
FIELD_NED = 51.5 * np.array([math.cos(math.radians(72.5)), 0.0, math.sin(math.radians(72.5))])


# -- the model ------------------------------------------------------------------------------------

def test_thinning_keeps_the_first_point_the_newest_quarter_and_the_cap():
    points = list(range(1000))
    kept = thin(points, 100)
    assert len(kept) <= 100 and kept[0] == 0
    assert kept[-25:] == points[-25:], "the newest quarter whole"
    assert kept == sorted(kept)


def test_a_subscriber_gets_the_whole_model_then_each_change_once():
    model = LiveModel("walk", {"track": 8})
    model.update(append={"track": [[0, 1.0]]}, values={"a": 1})
    heard: list[dict] = []
    snapshot = json.loads(model.subscribe(lambda text: heard.append(json.loads(text))))
    assert snapshot["reset"] and snapshot["series"] == {"track": [[0, 1.0]]} and snapshot["values"]["a"] == 1
    model.update(append={"track": [[1, 2.0]]}, values={"a": 1, "b": float("nan")},
                 transient={"arrivals": [5.0]})
    assert heard == [{"seq": 2, "append": {"track": [[1, 2.0]]}, "values": {"b": None},
                      "transient": {"arrivals": [5.0]}}], "unchanged values are not sent again; NaN as null"
    model.update(values={"a": 1})
    assert len(heard) == 1, "nothing changed: no message"
    model.update(append={"track": [[k, float(k)] for k in range(2, 20)]})
    assert "track" in heard[-1]["series"], "past its cap the series is thinned and sent whole"
    assert len(model.points("track")) <= 8 and model.points("track")[0] == [0, 1.0]


def test_a_page_listens_on_the_loopback_interface_unless_a_host_is_named():
    assert web_address("8080") == ("127.0.0.1", 8080)
    assert web_address("0.0.0.0:0") == ("0.0.0.0", 0)
    assert web_address("[::1]:9000") == ("::1", 9000)
    for bad in ("x", "70000", ":80", "-1"):
        with pytest.raises(argparse.ArgumentTypeError):
            web_address(bad)
    assert is_loopback("127.0.0.1") and is_loopback("::1") and is_loopback("localhost")
    assert not is_loopback("0.0.0.0") and not is_loopback("192.0.2.1")
    assert page_url("0.0.0.0", 80) == "http://127.0.0.1:80/" and page_url("::1", 81) == "http://[::1]:81/"


def test_an_os_error_is_said_in_words_without_its_errno_or_address():
    in_use = OSError(98, "error while attempting to bind on address ('127.0.0.1', 80): address in use")
    assert bind_refusal("--web", ("127.0.0.1", 80), in_use) == "--web 127.0.0.1:80: Address already in use"
    unresolved = OSError(-2, "Name or service not known (while attempting to bind on address ('x', 1))")
    assert os_reason(unresolved) == "Name or service not known"
    assert os_reason(socket.gaierror(-2, "Name or service not known")) == "Name or service not known"
    missing = RuntimeError("aiohttp is missing")
    assert bind_refusal("--web", ("::1", 8), missing) == "--web [::1]:8: aiohttp is missing"


def test_the_ellipse_of_a_covariance():
    a, b, angle = ellipse(np.array([[4.0, 0.0], [0.0, 1.0]]))  # north 2 m, east 1 m
    assert (a, b) == pytest.approx((2.0, 1.0)) and abs(angle) == pytest.approx(90.0)
    r = rotation_z(math.radians(30.0))[:2, :2]
    a, b, angle = ellipse(r @ np.diag([9.0, 0.25]) @ r.T)
    assert (a, b) == pytest.approx((3.0, 0.5)) and angle == pytest.approx(60.0), "from east towards north"


# -- the feed on trackers driven directly ---------------------------------------------------------

class _Device:
    """What the feed reads of a device: its tracker, lock, counters and callbacks."""

    def __init__(self, name: str, tracker):
        self.name, self.tracker = name, tracker
        self.session_lock = threading.RLock()
        self.session = SimpleNamespace(stats=SessionStats())
        self.link_up, self.link_drops = True, 0
        self.callbacks: list = []

    def on_step(self, fn):
        self.callbacks.append(fn)
        return fn

    on_link = on_gap = on_step

    def remove_callback(self, fn):
        while fn in self.callbacks:
            self.callbacks.remove(fn)


def _run(tracker, aids: bool = True) -> SimpleNamespace:
    if isinstance(tracker, TwoFeetTracker):
        modules = [SimpleNamespace(side=side, dev=_Device(f"/dev/{side}", tracker.foot(side)), failure=None)
                   for side in ("left", "right")]
    else:
        modules = [SimpleNamespace(side=None, dev=_Device("/dev/shoe", tracker), failure=None)]
    return SimpleNamespace(modules=modules, tracker=tracker, aids=SimpleNamespace() if aids else None,
                           receiver=None)


def test_half_an_hour_of_two_feet_at_a_step_a_second_stays_within_the_caps():
    """A module at 60 steps a minute on each foot for 30 minutes: 3600 fused steps and 1800 fixes,
    the feed updating every 30 steps; every series stays within its cap, the message a late page
    gets stays small, and the track still spans the whole walk."""
    feet = TwoFeetTracker(aids=FusionSettings(gps=True))
    run = _run(feet)
    feed = WalkFeed(run)
    feed.refresh_s = 3600.0  # this test's updates only: the steps come far faster than a walker's
    feed.start()
    try:
        turn = math.radians(0.5)
        for k in range(1, 1801):
            if k % 2:
                feet.add_body_fix(float(k), (0.0, 0.0))
            for side, t in (("left", float(k)), ("right", k + 0.5)):
                feet.foot(side).add_step([0.7, 0.0, 0.0, turn], DP, k, time_s=t)
            if k % 150 == 0:
                feed.update()
    finally:
        feed.close()
    sizes = feed.model.sizes()
    assert all(sizes[name] <= cap for name, cap in SERIES_CAPS.items() if name in sizes), sizes
    assert sizes["track"] > SERIES_CAPS["track"] // 2 and sizes["fixes"] > SERIES_CAPS["fixes"] // 2
    track = feed.model.points("track")
    assert track[0][0] == 0 and track[-1][0] == 3600, "from the start to the last step"
    assert len(feed.model.snapshot()) < 300_000, "what a page opened late is sent"
    assert feed.model.value("state") == "ended" and not run.modules[0].dev.callbacks
    links = feed.model.value("links")
    assert [link["step_packets"] for link in links] == [1800, 1800]


def _reading(true_heading: float) -> StanceReading:
    return StanceReading(rotation_z(true_heading).T @ FIELD_NED, np.eye(3), 3)


def test_when_the_gps_course_turns_the_whole_walk_the_page_is_given_the_track_anew():
    """The module's frame starts 90° off: walking east, it says north; once the fixes have come 50 m,
    their course turns the whole track (and its past) east."""
    tracker = FusionTracker(FusionSettings(gps=True))
    feed = WalkFeed(_run(tracker))
    heard: list[dict] = []
    feed.model.subscribe(lambda text: heard.append(json.loads(text)))
    feed.start()
    try:
        for k in range(1, 121):
            tracker.add_fix(float(k - 1), (0.0, 0.7 * (k - 1)))
            tracker.add_step([0.7, 0.0, 0.0, 0.0], DP, k, time_s=float(k))
            feed.update()
    finally:
        feed.close()
    assert tracker.fusion.heading_aligned_by == "gps"
    assert any("track" in m.get("series", {}) for m in heard[2:]), "the turned track replaced whole"
    track = feed.model.points("track")
    assert len(track) == 121
    north, east = track[-1][1], track[-1][2]
    assert east == pytest.approx(84.0, abs=3.0) and abs(north) < 3.0, "the whole walk now runs east"
    assert track[60][2] == pytest.approx(42.0, abs=3.0), "its past too"
    fixes = feed.model.points("fixes")
    assert fixes[0][2] == 0, "the origin"
    assert {f[2] for f in fixes} >= {1, 3}, "fixes before the alignment, and updates"


def test_the_compass_readings_are_drawn_where_the_foot_was_used_or_rejected():
    tracker = FusionTracker(FusionSettings(compass=True, compass_sigma_rad=math.radians(2.0)))
    feed = WalkFeed(_run(tracker))
    feed.start()
    try:
        for k in range(1, 10):
            heading = math.radians(90.0) if k == 6 else 0.0
            tracker.add_step([0.7, 0.0, 0.0, 0.0], DP, k, reading=_reading(heading), time_s=float(k))
        feed.update()
    finally:
        feed.close()
    compass = feed.model.points("compass")
    assert [c[3] for c in compass] == [1] * 5 + [0] + [1] * 3, "used, one rejected"
    north, east, heading, _used, foot, k = compass[5]
    assert (north, east, k, foot) == (pytest.approx(4.2, abs=1e-3), pytest.approx(0.0, abs=1e-3), 6, 0)
    assert heading == pytest.approx(90.0, abs=0.5)
    aids = feed.model.value("aids")
    assert aids["compass_updates"] == 7 and aids["compass_rejected"] == 1 and aids["aligned_by"] == "compass"
    assert aids["compass_field_rejected"] == 0
