"""A walk as its live page shows it: :class:`WalkFeed` keeps a :class:`~hostlib.web.model.LiveModel`
up to date with a :class:`~hostlib.run.tracking_run.TrackingRun` while its modules walk.

What it shows (the series, each bounded: :data:`SERIES_CAPS`):

* ``track`` — the walker's pose after each step: one module's track, or with two feet the fused
  body's. A point is ``[k, north, east, height, heading°, a, b, angle°, distance]``: the step's index
  in the track, the position [m] (height = −z), the heading from north towards east, the 1σ
  ellipse of the horizontal position (half axes a ≥ b [m], the major axis's angle from east
  towards north) and the distance walked to it [m];
* ``left``, ``right`` — with two feet, where each foot came to rest: ``[k, north, east]`` after each
  of its steps (k: the fused step);
* ``fixes`` — the GPS fixes the filter took: ``[north, east, outcome, t]`` (outcome: 0 the origin,
  1 before the heading was aligned, 2 between two updates, 3 an update; t: module time [s]);
* ``compass`` — the compass readings the filter used or rejected: ``[north, east, heading°,
  used, foot, k]`` at the foot (or the module) that read it (heading: the reading plus the
  declination, true; used: 1 used or aligned, 0 rejected; foot: 0 the only module or the left, 1
  the right).

and the values: ``links`` (each module: its port, foot, link up or down, failure, state packets,
step packets, steps that moved the foot, gaps and steps missing in them, garbage bytes, distance),
``body`` (the last pose, its heading and 1σ), ``aids`` (what the compass and GPS did, the
receiver's counts), ``state`` (``"walking"``, then ``"ended"``). Each update also carries, not
kept, when each step packet in it arrived at the host (``transient.arrivals``, seconds of the
epoch): a page tells how late it drew them.

The feed hears of news from the devices' callbacks (a step, a gap, the link going down or up) and
notes the aids' readings from the tracker's aid observer
(:meth:`~hostlib.fusion.aided.AidedFilter.observe_aids`: each is taken while a step is summed, and
that step's callback follows); its own thread then takes a snapshot under the devices' session
locks and turns it into one message. The past of the track can change (an aid turns the whole walk when it
aligns the heading): the feed compares what the model holds with the tracker's track and replaces
the series when they differ. An update costs the feed's thread about as much as copying the
tracker's history; updates are at least :attr:`WalkFeed.min_interval_s` apart and at least four
times their own cost, so a long walk never takes more than a fifth of a core for its page.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections import deque
from collections.abc import Callable
from contextlib import ExitStack
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from protocol.board import FOOT_SIDES

from ..fusion.aided import AidedFilter
from ..fusion.feet import TwoFeetTracker
from .model import LiveModel

if TYPE_CHECKING:
    from ..fusion.aid_events import AidEvent
    from ..run.tracking_run import TrackingRun

__all__ = ["FIX_OUTCOMES", "SERIES_CAPS", "WalkFeed", "ellipse", "walk_model"]

log = logging.getLogger(__name__)

#: The most points each series of the walk's page holds (older ones are thinned past it).
SERIES_CAPS = {"track": 2000, "left": 1000, "right": 1000, "fixes": 600, "compass": 600}
#: The codes of a GPS fix's outcome in the ``fixes`` series.
FIX_OUTCOMES = {"origin": 0, "before alignment": 1, "skipped": 2, "used": 3}
#: Step arrivals and aid readings noted between two updates, at most (older ones are forgotten).
NOTED = 4096
#: How far a stored point may lie from the tracker's for the same step [m] before the series is
#: taken as changed (the stored ones are rounded to the millimetre).
SAME_M = 0.002


def walk_model() -> LiveModel:
    """An empty model of a walk's page."""
    return LiveModel("walk", SERIES_CAPS)


def ellipse(cov: np.ndarray) -> tuple[float, float, float]:
    """The 1σ ellipse of a horizontal position's covariance *cov* (2×2, north and east): its half
    axes a ≥ b [m] and the major axis's angle from east towards north [°]."""
    cnn, cne, cee = float(cov[0, 0]), float(cov[0, 1]), float(cov[1, 1])
    mean, half = 0.5 * (cee + cnn), math.hypot(0.5 * (cee - cnn), cne)
    a, b = math.sqrt(max(mean + half, 0.0)), math.sqrt(max(mean - half, 0.0))
    return a, b, math.degrees(0.5 * math.atan2(2.0 * cne, cee - cnn))


@dataclass
class _Snapshot:
    """What one update reads, under the devices' locks."""

    poses: np.ndarray  # (n + 1, 4) the track's (or the body's)
    covs: np.ndarray  # (n + 1, 4, 4)
    feet: dict[str, np.ndarray]  # side → (n + 1, 4) fused poses (two feet)
    stepped: dict[str, np.ndarray]  # side → the rows its steps made (two feet)
    links: list[dict[str, Any]]
    aids: dict[str, Any] | None
    arrivals: list[float]
    events: list[AidEvent]


class WalkFeed:
    """Keeps *model* (default: a new :func:`walk_model`) up to date with *run*, whose modules were
    started (:meth:`~hostlib.run.tracking_run.TrackingRun.start`): :meth:`start` it, then
    :meth:`close` it when the walk ended (module docstring). *clock* stamps the steps' arrivals
    (seconds of the epoch, as a browser's clock counts)."""

    #: Seconds between two updates at least (steps that come faster share one).
    min_interval_s = 0.02
    #: Seconds between two updates at most, news or not (the links' counters move between steps).
    refresh_s = 0.5

    def __init__(self, run: TrackingRun, model: LiveModel | None = None, *, title: str = "",
                 clock: Callable[[], float] = time.time):
        if not run.modules:
            raise ValueError("start the run first: the feed follows its modules")
        self.run = run
        self.model = model or walk_model()
        self.title = title
        self.clock = clock
        self.updates = 0  #: updates made
        self.failed_updates = 0  #: updates that raised (the first is logged)
        self._news = threading.Event()
        self._stop = threading.Event()
        self._lock = threading.Lock()  # the notes below
        self._update_lock = threading.Lock()
        self._arrivals: deque[float] = deque(maxlen=NOTED)
        self._events: deque[AidEvent] = deque(maxlen=NOTED)
        self._callbacks: list[tuple[Any, Callable[..., object]]] = []
        self._thread: threading.Thread | None = None
        self._ended = False
        self._walked = (-1, 0.0)  # the track's last point drawn: its row and the distance to it [m]

    # -- hearing of news ----------------------------------------------------------------

    def _stepped(self, _event: object) -> None:
        with self._lock:
            self._arrivals.append(self.clock())
        self._news.set()

    def _changed(self, _event: object) -> None:
        self._news.set()

    def _aid(self, event: AidEvent) -> None:
        # taken within a step's summing: the step's own callback, right after, brings the news (so
        # the step's arrival is noted before the update that draws it)
        if event.aid == "gps" or event.outcome in ("aligned", "used", "rejected"):
            with self._lock:
                self._events.append(event)

    # -- running ------------------------------------------------------------------------

    def start(self) -> WalkFeed:
        """Listen to the run's devices and aids; update the model now and from a thread of its own."""
        for m in self.run.modules:
            for register, fn in ((m.dev.on_step, self._stepped), (m.dev.on_link, self._changed),
                                 (m.dev.on_gap, self._changed)):
                register(fn)
                self._callbacks.append((m.dev, fn))
        if isinstance(self.run.tracker, AidedFilter):
            self.run.tracker.observe_aids(self._aid)
        self.model.update(values={"title": self.title, "started": self.clock(), "state": "walking",
                                  "mode": "two feet" if self.two_feet else "one module"})
        self.update()
        self._thread = threading.Thread(target=self._run, name="live-page-feed", daemon=True)
        self._thread.start()
        return self

    @property
    def two_feet(self) -> bool:
        return isinstance(self.run.tracker, TwoFeetTracker)

    def _run(self) -> None:
        while not self._stop.is_set():
            self._news.wait(self.refresh_s)
            if self._stop.is_set():
                return
            self._news.clear()
            began = time.perf_counter()
            try:
                self.update()
            except Exception:  # noqa: BLE001 - the page must not end the walk; the next update tries again
                self.failed_updates += 1
                if self.failed_updates == 1:
                    log.exception("the live page's update failed (the walk goes on)")
            self._stop.wait(max(self.min_interval_s, 4.0 * (time.perf_counter() - began)))

    def close(self) -> None:
        """The walk ended: one last update, the state ``"ended"``; the callbacks are removed (the
        aid observer stays, and hears nothing more of a tracker that sums no more steps). Idempotent."""
        if self._ended:
            return
        self._ended = True
        self._stop.set()
        self._news.set()
        if self._thread is not None:
            self._thread.join(5.0)
        for dev, fn in self._callbacks:
            try:
                dev.remove_callback(fn)
            except ValueError:
                pass
        self._callbacks.clear()
        self.update(ended=True)

    def __enter__(self) -> WalkFeed:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- one update -----------------------------------------------------------------------

    def update(self, ended: bool = False) -> None:
        """Read the run now and tell the model what changed."""
        with self._update_lock:
            snap = self._take()
            append: dict[str, list] = {}
            replace: dict[str, list] = {}
            self._track(snap, append, replace)
            for side in snap.feet:
                self._foot(snap, side, append, replace)
            self._aid_points(snap, append, replace)
            values: dict[str, Any] = {"links": snap.links, "aids": snap.aids, "body": self._body(snap)}
            if ended:
                values["state"] = "ended"
            transient = {"arrivals": snap.arrivals} if snap.arrivals else None
            self.model.update(append=append, replace=replace, values=values, transient=transient)
            self.updates += 1

    def _take(self) -> _Snapshot:
        run, tracker = self.run, self.run.tracker
        with ExitStack() as held:
            for m in run.modules:  # in the modules' order, as every other holder of both takes them
                held.enter_context(m.dev.session_lock)
            with self._lock:
                arrivals, events = list(self._arrivals), list(self._events)
                self._arrivals.clear()
                self._events.clear()
            feet: dict[str, np.ndarray] = {}
            stepped: dict[str, np.ndarray] = {}
            # the rows as they are now, not copied (a later step or turn does not change them)
            if isinstance(tracker, TwoFeetTracker):
                history = tracker.history
                poses, covs, rows = history.views()
                at = {side: tracker.filter.slice(side).start - history.poses.start for side in FOOT_SIDES}
                feet = {side: rows[:, at[side]:at[side] + 4] for side in FOOT_SIDES}
                stepped = {side: history.rows_of(i) for i, side in enumerate(FOOT_SIDES)}
            else:
                poses, covs = tracker.track.views()
            links = [self._link(m) for m in run.modules]
            aids = self._aids()
        n = min([len(poses)] + [len(rows) for rows in feet.values()])
        return _Snapshot(poses[:n], covs[:n], {s: rows[:n] for s, rows in feet.items()},
                         {s: ks[ks < n] for s, ks in stepped.items()}, links, aids, arrivals, events)

    def _link(self, m) -> dict[str, Any]:
        dev = m.dev
        track = dev.tracker.track
        stats = dev.session.stats
        return {"name": dev.name, "side": m.side, "up": dev.link_up, "failed": None if m.failure is None
                else str(m.failure), "packets": stats.packets, "step_packets": len(track),
                "steps": track.motion_steps, "gaps": len(track.gaps), "missing": track.missing,
                "garbage": stats.garbage_bytes, "bad_frames": stats.bad_frames, "distance": track.distance,
                "link_drops": dev.link_drops}

    def _aids(self) -> dict[str, Any] | None:
        run = self.run
        if run.aids is None or not isinstance(run.tracker, AidedFilter):
            return None
        f = run.tracker.fusion
        aids: dict[str, Any] = {
            "compass": run.tracker.aid_settings.compass, "gps": run.tracker.aid_settings.gps,
            "compass_updates": f.compass_updates, "compass_rejected": f.compass_rejected,
            "compass_field_rejected": f.compass_field_rejected,
            "compass_skipped": f.compass_skipped, "compass_refused": f.compass_refused,
            "gps_updates": f.gps_updates, "gps_skipped": f.gps_skipped,
            "gps_before_alignment": f.gps_before_alignment, "aligned_by": f.heading_aligned_by,
            "declination_deg": math.degrees(run.tracker.declination)}
        receiver = run.receiver
        if receiver is not None:
            st = receiver.fixes.stats
            aids["receiver"] = {"url": receiver.url, "fixes": st.fixes, "without_fix": st.missing_fix,
                                "garbled": st.garbled, "lost": receiver.lost}
        return aids

    @staticmethod
    def _body(snap: _Snapshot) -> dict[str, Any]:
        x, y, z, chi = snap.poses[-1]
        a, _b, _angle = ellipse(snap.covs[-1][:2, :2])
        return {"north": x, "east": y, "height": -z, "heading": math.degrees(chi) % 360.0, "sigma": a,
                "steps": len(snap.poses) - 1}

    # -- the series -----------------------------------------------------------------------

    def _track(self, snap: _Snapshot, append: dict[str, list], replace: dict[str, list]) -> None:
        poses, covs = snap.poses, snap.covs
        kept = self.model.points("track")
        start = int(kept[-1][0]) + 1 if _same(kept, poses) and self._walked[0] == int(kept[-1][0]) else 0
        dist = self._distances(poses, start)

        def point(k: int) -> list[float]:
            x, y, z, chi = poses[k].tolist()
            a, b, angle = ellipse(covs[k][:2, :2])
            return [k, x, y, -z, math.degrees(chi) % 360.0, a, b, angle, float(dist[k - start])]

        points = [point(k) for k in range(start, len(poses))]
        if start:
            append["track"] = points
        else:
            replace["track"] = points
        if len(dist):
            self._walked = (len(poses) - 1, float(dist[-1]))

    def _distances(self, poses: np.ndarray, start: int) -> np.ndarray:
        """The distance walked to each row of *poses* from *start* on [m]: summed on from the last
        point drawn (:attr:`_walked`), not from the start again — an update reads only the rows it
        adds, the same sums in the same order."""
        steps = np.hypot(*np.diff(poses[max(start - 1, 0):, :2], axis=0).T)
        return np.cumsum(np.concatenate(([self._walked[1] if start else 0.0], steps)))[1 if start else 0:]

    def _foot(self, snap: _Snapshot, side: str, append: dict[str, list], replace: dict[str, list]) -> None:
        rows = snap.feet[side]
        ks = np.concatenate(([0], snap.stepped[side]))
        kept = self.model.points(side)
        if _same(kept, rows):
            ks = ks[ks > int(kept[-1][0])]
            append[side] = [[k, *rows[k, :2].tolist()] for k in ks.tolist()]
        else:
            replace[side] = [[k, *rows[k, :2].tolist()] for k in ks.tolist()]

    def _aid_points(self, snap: _Snapshot, append: dict[str, list], replace: dict[str, list]) -> None:
        fixes = [[e.reading[0], e.reading[1], FIX_OUTCOMES[e.outcome], e.time_s] for e in snap.events
                 if e.aid == "gps" and e.reading is not None]
        if fixes:
            append["fixes"] = fixes
        compass = [[*self._where(snap, e.pose, e.step), math.degrees(e.reading + e.declination) % 360.0,
                    int(e.accepted), int(e.pose == "right"), e.step] for e in snap.events
                   if e.aid == "compass" and e.reading is not None and math.isfinite(e.reading)]
        if "track" in replace or any(side in replace for side in snap.feet):
            # the walk's past moved: each reading goes where its foot now was
            kept = self.model.points("compass")
            replace["compass"] = [[*self._where(snap, ("right" if p[4] else "left") if snap.feet else "pose",
                                                int(p[5])), *p[2:]] for p in kept] + compass
        elif compass:
            append["compass"] = compass

    @staticmethod
    def _where(snap: _Snapshot, pose: str, k: int) -> tuple[float, float]:
        rows = snap.feet.get(pose, snap.poses)
        row = rows[min(k, len(rows) - 1)]
        return float(row[0]), float(row[1])


def _same(kept: list, rows: np.ndarray) -> bool:
    """Whether the points *kept* (each ``[k, north, east, …]``) are still where *rows* have those steps
    (and there are any)."""
    if not kept:
        return False
    ks = np.array([int(p[0]) for p in kept])
    if ks[-1] >= len(rows):
        return False
    stored = np.array([[p[1], p[2]] for p in kept], dtype=float)
    return bool(np.all(np.abs(rows[ks, :2] - stored) <= SAME_M))
