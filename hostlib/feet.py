"""Two feet on the host: a module on each foot, both step streams fused in one filter.

The module paper recommends a module on each foot (shared/spec/aids.md §6). Each module sends
its own steps (:mod:`hostlib.tracking`); the host keeps, per foot, a :class:`FootTracker` — a
:class:`~hostlib.tracking.StepTracker` with that module's counter, resends and gaps, whose track
is the foot's single-module track — and feeds every step it sums to one :class:`TwoFeetTracker`:

* **the joint state** ``s = [x_L, y_L, z_L, χ_L, x_R, y_R, z_R, χ_R]`` with its 8×8 covariance.
  A step of one foot moves that foot's block by the summation map of
  :func:`~hostlib.tracking.propagate`; the other block stays, and the cross-covariance goes through
  the stepping foot's Jacobian (``P_LR ← F P_LR``). Without the constraint each block is that
  foot's single-module track, bit for bit;
* **the inter-foot constraint** (Prateek, Girisha, Hari and Händel 2013; aids.md §6): the feet are
  never farther apart than a step, ``‖p_L − p_R‖ ≤ γ``. After each step, if the estimate violates
  it, the estimate is projected onto ``‖p_L − p_R‖ = γ`` with the covariance as the metric
  (Simon and Chia 2002: ``s ← s − P Dᵀ (D P Dᵀ)⁻¹ (‖p_L − p_R‖ − γ)``, ``D = [uᵀ 0 −uᵀ 0]``,
  ``u`` the unit vector from right to left, relinearised until it holds; then
  ``P ← P − P Dᵀ (D P Dᵀ)⁻¹ D P``). Through the correlation of each foot's position with its
  heading, the projection also turns the headings towards each other: the drift between the
  feet stays bounded;
* **the body** is the midpoint of the feet, heading the mean of the two, covariance ``M P Mᵀ``
  (:attr:`TwoFeetTracker.body`); :attr:`TwoFeetTracker.average` is the same midpoint of the two
  single-module tracks — the baseline (Bachmann et al. average the two feet).

The positions each step packet gives are where the foot was at the end of its last stance, so
the constraint compares the feet's last rests: with the step-through gait people walk, half a
stride apart (about 0.75 m at 5.4 km/h). γ is therefore the longest *walking* step, 1 m
(:attr:`FeetSettings.max_separation_m`); a runner's steps are longer (set 1.5 m).

**One foot's link lost.** While one foot's stream is silent the other keeps stepping; the silent
foot's estimate is stale. The constraint is applied only when the other foot has stepped since
this foot's previous step (walking, the feet alternate; standing, each module resets every second,
in turn), so a silent foot never pulls the walking one back; once the walking foot has summed
:data:`STALE_AFTER_STEPS` steps since the other's last one, the body is the walking foot alone
(the two single-module tracks' average likewise). A lossless module keeps the steps it could not
send and resends them when the link returns: they arrive in a burst, the foot catches up and the
fusion goes on with both. When the silent foot's
steps come again after a gap in its counter (steps lost), the displacement it missed is unknown:
the tracker restarts that foot at the other foot, with the other foot's heading, its position
uncertain by γ and its heading by :attr:`FeetSettings.restart_heading_sigma_rad`, and the
constraint pulls it in. The gap stays reported on that foot's tracker (``tracker.left.gaps``).
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from protocol.board import FOOT_SIDES

from .events import StepOutcome
from .module_clock import ModuleClock
from .tracking import StepTracker, Track, propagate, rotation_z, step_jacobian

__all__ = ["FOOT_SIDES", "STALE_AFTER_STEPS", "FeetSettings", "FootStep", "FootTracker", "TwoFeetTracker"]

#: A foot is stale — the body follows the other foot alone — once the other foot has summed this
#: many steps since its last one (one more than a transition from standing to walking can make).
STALE_AFTER_STEPS = 3


@dataclass(frozen=True)
class FeetSettings:
    """How the :class:`TwoFeetTracker` fuses the two feet."""

    #: apply the inter-foot constraint (off: the joint filter is the two single tracks)
    constraint: bool = True
    #: γ [m]: the feet's last rests are never farther apart (module docstring)
    max_separation_m: float = 1.0
    #: lateral distance between the feet at the start [m]: the left foot starts half of it to the
    #: left of the body, the right foot to the right (the host's frame starts at the body)
    step_width_m: float = 0.12
    #: heading uncertainty of a foot restarted at the other foot after a gap [rad]
    restart_heading_sigma_rad: float = math.radians(5.0)

    def __post_init__(self) -> None:
        if not self.max_separation_m > 0:
            raise ValueError(f"the feet's maximum separation must be > 0 m, got {self.max_separation_m}")
        if not self.step_width_m >= 0:
            raise ValueError(f"the step width must be ≥ 0 m, got {self.step_width_m}")


@dataclass(frozen=True)
class FootStep:
    """A step one foot's tracker summed, as the joint filter takes it."""

    side: str
    dx: np.ndarray  #: (4,) [dx, dy, dz, dψ]
    dp: np.ndarray  #: (4, 4)
    time_s: float  #: module time of the step [s] (NaN: the packet had no T_INT_K)
    after_gap: bool  #: steps of this foot were lost just before it


class FootTracker(StepTracker):
    """One foot's stream in a two-foot fusion: a :class:`~hostlib.tracking.StepTracker` (its own
    counter, resends and gaps; its track is the foot's single-module track) that hands every step
    it sums to *on_step*. Use it as that foot's :class:`~hostlib.session.HostSession` tracker."""

    def __init__(self, side: str, on_step: Callable[[FootStep], None] | None = None, **tracker_args):
        if side not in FOOT_SIDES:
            raise ValueError(f"a foot is {' or '.join(FOOT_SIDES)}, not {side!r}")
        super().__init__(**tracker_args)
        self.side = side
        self.on_step = on_step
        self._clock = ModuleClock()
        #: per summed step: module time [s] (NaN: the packet had no T_INT_K)
        self.step_times: list[float] = []

    def add(self, step, swing_time: float = math.nan, states: Mapping[int, np.ndarray] | None = None
            ) -> StepOutcome:
        time_s = self._clock.seconds(states)
        outcome = self.add_step(step.dx, step.dp, step.counter, swing_time)
        if outcome is StepOutcome.DUPLICATE:
            return outcome
        self.step_times.append(time_s)
        if self.on_step is not None:
            self.on_step(FootStep(self.side, self.track._steps[-1], np.asarray(step.dp, dtype=np.float64),
                                  time_s, outcome is StepOutcome.SUMMED_AFTER_GAP))
        return outcome

    def __repr__(self) -> str:
        return f"FootTracker({self.side}, {self.track!r}, duplicates={self.duplicates})"


class TwoFeetTracker:
    """Both feet in one filter (module docstring). ``tracker.left`` and ``tracker.right`` are the
    feet's :class:`FootTracker`s — give each to its module's session. Steps may come from two
    threads (one device each): the joint filter takes them one at a time, in arrival order.

    With *defer* the feet's steps are only collected; :meth:`fuse_in_time_order` then runs them
    through the filter in module-time order (replaying two captures, which arrive one after the
    other). *heading* [rad] is the way the walker faces at the start (from north towards east);
    the feet start half of :attr:`FeetSettings.step_width_m` to either side of the origin."""

    def __init__(self, settings: FeetSettings | None = None, *, last_counter: int | None = 0,
                 defer: bool = False, heading: float = 0.0):
        self.settings = settings or FeetSettings()
        take = self._collect if defer else self.take
        half = 0.5 * self.settings.step_width_m
        self.left, self.right = (
            FootTracker(side, take, last_counter=last_counter, heading=heading,
                        position=rotation_z(heading) @ np.array([0.0, sign * half, 0.0]))
            for side, sign in zip(FOOT_SIDES, (-1.0, 1.0), strict=True))
        self._lock = threading.Lock()
        self._deferred: list[FootStep] = []
        self._s = np.concatenate([self.left.track._poses[0], self.right.track._poses[0]])
        self._p = np.zeros((8, 8))
        self._since = {side: 0 for side in FOOT_SIDES}  # the other foot's steps since this one's last
        self._fused = {side: 0 for side in FOOT_SIDES}  # steps of each foot through the filter
        self._body: list[tuple[np.ndarray, np.ndarray]] = []
        self._average: list[tuple[np.ndarray, np.ndarray]] = []
        self._feet: list[np.ndarray] = []  # the joint state after each step
        self._variances: list[np.ndarray] = []  # the diagonal of its covariance
        self._sides: list[str] = []
        self._record()
        #: how often the constraint was violated and projected; steps fused without it because the
        #: other foot had not stepped since this foot's previous step
        self.projections = 0
        self.stale_steps = 0
        #: feet restarted at the other foot after a gap in their stream
        self.restarts: list[tuple[str, int]] = []  # (side, index of the joint step)

    # -- input ----------------------------------------------------------------------------

    def foot(self, side: str) -> FootTracker:
        if side not in FOOT_SIDES:
            raise ValueError(f"a foot is {' or '.join(FOOT_SIDES)}, not {side!r}")
        return self.left if side == "left" else self.right

    def _collect(self, step: FootStep) -> None:
        self._deferred.append(step)

    def fuse_in_time_order(self) -> None:
        """Run the collected steps through the filter in module-time order (without T_INT_K in
        every packet, alternately: :func:`_time_order`)."""
        order = _time_order(self._deferred)
        self._deferred = []
        for step in order:
            self.take(step)

    def take(self, step: FootStep) -> None:
        """Fuse one summed step of one foot."""
        with self._lock:
            self._take(step)

    def _take(self, step: FootStep) -> None:
        i = FOOT_SIDES.index(step.side)
        block = slice(4 * i, 4 * i + 4)
        other = 1 - i
        if step.after_gap and len(self._sides) > 0:
            self._restart_at_other(i)
        # the stepping foot's block through the summation map, the cross terms through its Jacobian
        f = step_jacobian(float(self._s[block][3]), step.dx)
        pose, cov = propagate(self._s[block], self._p[block, block], step.dx, step.dp)
        cross = slice(4 * other, 4 * other + 4)
        self._p[block, cross] = f @ self._p[block, cross]
        self._p[cross, block] = self._p[block, cross].T
        self._s[block] = pose
        self._p[block, block] = cov
        self._since[step.side] = 0
        self._since[FOOT_SIDES[other]] += 1
        if self._since[FOOT_SIDES[other]] > 1:
            self.stale_steps += 1  # the other foot has not stepped since this one's last step
        elif self.settings.constraint:
            self._constrain()
        self._sides.append(step.side)
        self._fused[step.side] += 1
        self._record()

    def _stale(self, i: int) -> bool:
        return self._since[FOOT_SIDES[i]] >= STALE_AFTER_STEPS

    def _restart_at_other(self, i: int) -> None:
        """Foot *i* lost steps: put it where the other foot is, as uncertain as that foot plus γ
        in position and the restart σ in heading, correlated with it as a copy is."""
        a, b = slice(4 * i, 4 * i + 4), slice(4 * (1 - i), 4 * (1 - i) + 4)
        self._s[a] = self._s[b]
        self._p[a, :] = self._p[b, :]
        self._p[:, a] = self._p[:, b]
        self._p[a, a] = self._p[b, b] + np.diag([self.settings.max_separation_m ** 2] * 3
                                                + [self.settings.restart_heading_sigma_rad ** 2])
        self.restarts.append((FOOT_SIDES[i], len(self._sides) + 1))

    def _constrain(self) -> None:
        gamma = self.settings.max_separation_m
        d = self._s[0:3] - self._s[4:7]
        dist = float(np.linalg.norm(d))
        if dist <= gamma:
            return
        s, p = self._s.copy(), self._p
        for _ in range(20):  # relinearise: the norm is curved across u (converges in a few)
            d = s[0:3] - s[4:7]
            dist = float(np.linalg.norm(d))
            u = d / dist
            h = np.zeros(8)
            h[0:3], h[4:7] = u, -u
            ph = p @ h
            var = float(h @ ph)
            if var <= 1e-18:
                return  # both feet known exactly: nothing to move
            s = s - ph * ((dist - gamma) / var)
            if abs(float(np.linalg.norm(s[0:3] - s[4:7])) - gamma) < 1e-9:
                break
        self._s = s
        self._p = p - np.outer(ph, ph) / var
        self._p = 0.5 * (self._p + self._p.T)
        self.projections += 1

    def _record(self) -> None:
        s, p = self._s, self._p
        stale = [self._stale(i) for i in (0, 1)]
        self._feet.append(s.copy())
        self._variances.append(np.diagonal(p).copy())
        self._body.append(_midpoint(s, p, stale))
        # the single-module tracks as far as the fused steps go (deferred, they are complete already)
        ls, rs = self.left.track, self.right.track
        nl, nr = self._fused["left"], self._fused["right"]
        single = np.concatenate([ls._poses[nl], rs._poses[nr]])
        cov = np.zeros((8, 8))
        cov[:4, :4], cov[4:, 4:] = ls._covs[nl], rs._covs[nr]
        self._average.append(_midpoint(single, cov, stale))

    # -- results --------------------------------------------------------------------------

    @property
    def state(self) -> np.ndarray:
        """The joint state [x_L, y_L, z_L, χ_L, x_R, y_R, z_R, χ_R] (a copy)."""
        return self._s.copy()

    @property
    def covariance(self) -> np.ndarray:
        """Its 8×8 covariance (a copy)."""
        return self._p.copy()

    @property
    def sides(self) -> list[str]:
        """Which foot made each fused step."""
        return list(self._sides)

    @property
    def body(self) -> Track:
        """The fused body track: the feet's midpoint after each fused step (row 0: the start);
        while one foot is stale, the other foot."""
        with self._lock:
            return _track(self._body)

    @property
    def average(self) -> Track:
        """The baseline: the midpoint of the two single-module tracks after each fused step."""
        with self._lock:
            return _track(self._average)

    def fused_foot(self, side: str) -> np.ndarray:
        """(n + 1, 4) the fused poses of *side* after each fused step (row 0: the start)."""
        i = FOOT_SIDES.index(side)
        with self._lock:
            return np.array([s[4 * i: 4 * i + 4] for s in self._feet])

    def fused_foot_sigmas(self, side: str) -> np.ndarray:
        """(n + 1, 4) the 1σ of :meth:`fused_foot`'s rows: x, y, z [m] and χ [rad]."""
        i = FOOT_SIDES.index(side)
        with self._lock:
            var = np.array([v[4 * i: 4 * i + 4] for v in self._variances])
        return np.sqrt(np.clip(var, 0.0, None))

    def separation(self) -> np.ndarray:
        """(n + 1,) the fused feet's distance apart after each fused step [m]."""
        with self._lock:
            feet = np.array(self._feet)
        return np.linalg.norm(feet[:, 0:3] - feet[:, 4:7], axis=1)

    def __len__(self) -> int:
        return len(self._sides)

    def __repr__(self) -> str:
        return (f"TwoFeetTracker({len(self)} steps: left {len(self.left)}, right {len(self.right)}; "
                f"{self.projections} projections, {self.stale_steps} steps with a stale foot, "
                f"{len(self.restarts)} restarts)")


_MID = np.hstack([0.5 * np.eye(4), 0.5 * np.eye(4)])


def _midpoint(s: np.ndarray, p: np.ndarray, stale: list[bool]) -> tuple[np.ndarray, np.ndarray]:
    """The body pose and covariance from the joint state: the feet's midpoint, or the fresh foot
    while the other is stale."""
    if stale[0] != stale[1]:
        i = 1 if stale[0] else 0
        return s[4 * i: 4 * i + 4].copy(), p[4 * i: 4 * i + 4, 4 * i: 4 * i + 4].copy()
    return _MID @ s, _MID @ p @ _MID.T


def _track(rows: list[tuple[np.ndarray, np.ndarray]]) -> Track:
    return Track.from_arrays(np.array([r[0] for r in rows]), np.array([r[1] for r in rows]))


def _time_order(steps: list[FootStep]) -> list[FootStep]:
    """*steps* merged by module time when every step has one (the fusion set-up's T_INT_K), else
    alternately, the k-th step of the left foot before the k-th of the right; each foot's own
    order is kept either way."""
    timed = all(math.isfinite(s.time_s) for s in steps)
    count = {side: 0 for side in FOOT_SIDES}
    keyed = []
    for n, step in enumerate(steps):
        count[step.side] += 1
        keyed.append((step.time_s if timed else count[step.side], FOOT_SIDES.index(step.side), n, step))
    return [k[-1] for k in sorted(keyed, key=lambda k: k[:3])]
