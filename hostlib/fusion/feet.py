"""Two feet on the host: a module on each foot, both step streams fused in one filter.

The module paper recommends a module on each foot (shared/spec/aids.md §6). Each module sends
its own steps (:mod:`hostlib.track.steps`); the host keeps, per foot, a :class:`FootTracker` — a
:class:`~hostlib.track.steps.StepTracker` with that module's counter, resends and gaps, whose track
is the foot's single-module track — and feeds every step it sums to one :class:`TwoFeetTracker`:

* **the joint state** ``s = [x_L, y_L, z_L, χ_L, x_R, y_R, z_R, χ_R]`` with its 8×8 covariance.
  A step of one foot moves that foot's block by the summation map of
  :func:`~hostlib.track.steps.propagate`; the other block stays, and the cross-covariance goes through
  the stepping foot's Jacobian (``P_LR ← F P_LR``). Without the constraint each block is that
  foot's single-module track, bit for bit;
* **the inter-foot constraint** (Prateek, Girisha, Hari and Händel 2013; aids.md §6): the feet are
  never farther apart than a step, ``‖p_L − p_R‖ ≤ γ``. After each step, if the estimate violates
  it, the estimate is projected onto ``‖p_L − p_R‖ = γ`` with the covariance as the metric
  (Simon and Chia 2002), the nearest point of that sphere exactly
  (:func:`hostlib.fusion.constraint.project_separation`). (Linearising the sphere
  at ``u = d/‖d‖`` and iterating, as the first versions did, did not always converge: twenty
  minutes without an aid, C's error ellipse is hundreds of square metres long across u, the step
  along ``P Dᵀ u`` swings the feet's difference round the sphere, and the iteration ended up to
  6 cm outside the bound.) Through the
  correlation of each foot's position with its heading, the projection also turns the headings
  towards each other: the drift between the feet stays bounded.

  The projection does not know which way the walker faces, and it can turn both headings
  together. The covariance is not projected, so it still holds each foot's steps as they were
  summed, in that foot's own direction, not as the projections moved them. Once the feet's
  headings differ, ``P Dᵀ`` therefore turns both feet the same way at every violation.
  Example: a 22-minute walk whose modules' gyros warm up apart (60° free), with no aid. The walker
  turned 43° by the end and the body ended 54 m off, against 14 m for the average of the two
  tracks; with each module's errors held, on two more walkers, 65° and 52° (78 and 30 m against
  21 and 24 m): twenty minutes without an aid leave the common heading tens of degrees of σ,
  and the cross-covariance that turns it at a violation is far outside its linear range.
  **Without a heading aid the projection therefore keeps to the feet's differences**
  (:func:`~hostlib.fusion.constraint.project_separation`'s *differential*: each pair of pose and
  module-error blocks gets half its correction's difference, with opposite signs; any other
  state stays). The bound is invariant to moving or turning both feet together, and nothing
  else observes that: the body keeps its midpoint and mean heading, and ends within 0.3 m of the
  average on those three walkers (13.2, 21.5, 24.5 m against 14.4, 21.3, 24.3 m, errors held).
  With the compass or GPS the common part is needed: taken out, the aided two-feet outage ended
  13 m off instead of 4 m, so there the whole projection stays.

  The covariance is **not** projected. The bound is an inequality the truth keeps well inside (a
  walker's last rests lie about 0.75 m apart, never at γ), so a violation says where the
  estimate must not be, not where the feet are. Projecting P as well (``P ← P − P Dᵀ (D P Dᵀ)⁻¹
  D P``) treats the bound as an exact measurement of the separation, every time it binds: the
  separation's variance along ``u`` collapses to zero, and the next violation is explained by
  whatever the last step correlated with it — at a corner, the feet's common heading and the
  declination. With the heading aids that turned both headings and D by up to 3° for a 5 cm
  violation (the two-feet NavShoe experiment, docs/two-feet.md); the estimate projection alone
  keeps the covariance the two feet's steps give, which the aids can trust;
* **the body** is the midpoint of the feet, heading the mean of the two, covariance ``M P Mᵀ``
  (:attr:`TwoFeetTracker.body`); :attr:`TwoFeetTracker.average` is the same midpoint of the two
  single-module tracks — the baseline (Bachmann et al. average the two feet).

The positions each step packet gives are where the foot was at the end of its last stance, so
the constraint compares the feet's last rests: with the step-through gait people walk, half a
stride apart (about 0.75 m at 5.4 km/h). γ is therefore the longest *walking* step, 1 m
(:attr:`FeetSettings.max_separation_m`); a runner's steps are longer (set 1.5 m).

**A step longer than 2γ** is fused without the constraint (counted in
:attr:`TwoFeetTracker.long_steps`). While one foot swings the other stands: from a rest within γ
of it to a rest within γ of it, a foot moves at most 2γ. A longer step says the other foot moved
in the meantime without a step of its own reported, so its last rest is no longer where it is.
That is what a running module sends: the firmware spaces its resets at least 0.75 s apart, longer
than a running stride (0.70 s; docs/accuracy.md), so each packet spans two strides (5.3 m on the
`run` scenario), the feet's reported rests lie alternately 1.3 and 3.9 m apart, and the
constraint would pull the body 3.3 m back over 100 m and turn it by 2.5°.

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

**With the other aids** (shared/spec/aids.md §1–4; ``TwoFeetTracker(aids=…, drift=…)``):

* the heading aids of :mod:`hostlib.fusion.tracker` act on the joint state, which gains the declination D
  as a ninth state (:class:`~hostlib.fusion.tracker.AidedFilter`): each foot's per-step compass measures
  *that foot's* heading minus D, with its own module's magnetometer calibration; a GPS fix
  measures the body. The first reading (or the GPS course) turns both feet about the body's
  start; the other foot's heading keeps its uncertainty relative to the aligned one;
* with the local compass deviation held (:attr:`~hostlib.fusion.tracker.FusionSettings.compass_deviation`,
  :mod:`hostlib.fusion.deviation`) the joint state holds **one** d for both feet, just before D
  (``[…L, …R, d, D]``): the feet walk through one field, and their rests, half a stride apart,
  read nearly the same deviation, so each foot's compass measures its heading minus D minus the
  same d. d walks with the body: each step moves the feet's midpoint by half the stepping foot's
  displacement, so d's Gauss–Markov step is half that foot's horizontal step (each foot's own
  step would walk it twice as far as the body goes: the readings, one from each foot in turn,
  lie half a stride apart along the walk, not a stride);
* with the receiver's bias held (:attr:`~hostlib.fusion.tracker.FusionSettings.gps_bias`,
  :mod:`hostlib.fusion.gps_bias`) the joint state holds **one** b = [b_n, b_e] for the body's receiver,
  before d (``[…L, …R, b_n, b_e, [d,] D]``): a fix measures the body plus b. The first fix moves
  both feet by the same unknown translation (the start's error, b₀ plus the fix's white part), so
  each foot's position is correlated with b as the body's is;
* with the module's errors held (:attr:`~hostlib.fusion.tracker.FusionSettings.module_errors`,
  :mod:`hostlib.fusion.module_errors`) each foot's module has **its own** step-length scale, climb, turn
  scale (and, with a drift prior, heading drift rate), after both feet's poses and before the aid
  states: ``[…L, …R, s_L, c_L, k_L, [r_L,] s_R, c_R, k_R, [r_R,] [b_n, b_e,] [d,] D]``. They are
  two modules' errors: independent priors, uncorrelated until an aid correlates them (the
  constraint, which moves the estimate only, does not). A step of one foot takes its pose and its
  module's errors through the step as one foot's :class:`~hostlib.fusion.tracker.FusionTracker` does
  (:func:`hostlib.fusion.module_errors.through_step`), the drift over the time since that foot's step
  before (0 for the step that restarts a foot after a gap: its heading is the other foot's);
  without an aid the feet's estimates stay and each foot's covariance grows as its single-module
  track's. A GPS fix of the body then teaches the scales' sum, the constraint (which holds the feet
  together) their difference (in the estimate: it leaves the covariance, so their σ stays what
  the aids left), each foot's compass that module's turns and drift;
* each module's drift calibration (:mod:`hostlib.calibration.drift`) moves that foot's every step by
  ``R(χ₀) Δv · T_swing`` before the constraint sees it, χ₀ the walk's start heading (turned with
  the alignment). A step without a swing time is fused uncorrected and counted;
* each foot's own tracker is a :class:`~hostlib.fusion.tracker.FusionTracker` with the same aids (and its
  module's calibrations), so the baseline is the average of two aided single-module tracks.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace

import numpy as np

from protocol.board import FOOT_SIDES

from ..aids.compass import StanceReading
from ..calibration.drift import DriftCalibration
from ..calibration.magcal import MagCalibration
from ..events import StepOutcome
from ..track.steps import Track, closure_sigma, is_motion_step, rotation_z
from .aid_states import add_aid_states
from .aided import AidedFilter
from .constraint import project_separation
from .core import StateFilter
from .feet_settings import FeetSettings
from .joint_history import JointHistory, body_pose_rows
from .settings import FusionSettings
from .tracker import FusionTracker

__all__ = ["DISAGREEMENT_SIGMAS", "FOOT_SIDES", "STALE_AFTER_STEPS", "FeetSettings", "FootStep",
           "FootTracker", "TwoFeetTracker"]

#: The fused body and the average of the two tracks part by more than their covariances allow
#: beyond this many σ (:meth:`TwoFeetTracker.disagreement`): 3σ of a 2-D Gaussian is exceeded by
#: 1.1 % of honest estimates.
DISAGREEMENT_SIGMAS = 3.0

#: A foot is stale — the body follows the other foot alone — once the other foot has summed this
#: many steps since its last one (one more than a transition from standing to walking can make).
STALE_AFTER_STEPS = 3


@dataclass(frozen=True)
class FootStep:
    """A step one foot's tracker summed, as the joint filter takes it."""

    side: str
    dx: np.ndarray  #: (4,) [dx, dy, dz, dψ]
    dp: np.ndarray  #: (4, 4)
    time_s: float  #: module time of the step [s] (NaN: the packet had no T_INT_K)
    after_gap: bool  #: steps of this foot were lost just before it
    swing_time: float = math.nan  #: the step's swing time [s] (NaN: none in the packet)
    compass: float | None = None  #: heading from magnetic north at its end of stance [rad], if read
    #: the calibrated field [µT] and the board → navigation rotation it was read with, if read
    field: tuple[np.ndarray, np.ndarray] | None = None


class FootTracker(FusionTracker):
    """One foot's stream in a two-foot fusion: a :class:`~hostlib.fusion.tracker.FusionTracker` (its own
    counter, resends and gaps, and the aids of *settings* on this foot alone; its track is the
    foot's single-module track) that hands every step it sums to *on_step*. Use it as that foot's
    :class:`~hostlib.link.session.HostSession` tracker. With every aid off it is a
    :class:`~hostlib.track.steps.StepTracker`, bit for bit."""

    def __init__(self, side: str, on_step: Callable[[FootStep], None] | None = None,
                 settings: FusionSettings | None = None, **tracker_args):
        if side not in FOOT_SIDES:
            raise ValueError(f"a foot is {' or '.join(FOOT_SIDES)}, not {side!r}")
        super().__init__(settings, **tracker_args)
        self.side = side
        self.on_step = on_step

    def _reads_stance(self) -> bool:
        return True  # the joint filter's compass reads it from each foot's step (FootStep)

    def add_step(self, dx, dp, counter, swing_time: float = math.nan, *,
                 reading: StanceReading | None = None, time_s: float = math.nan) -> StepOutcome:
        outcome = super().add_step(dx, dp, counter, swing_time, reading=reading, time_s=time_s)
        if outcome.summed and self.on_step is not None:
            self.on_step(FootStep(self.side, self.track.last_step, np.asarray(dp, dtype=np.float64), time_s,
                                  outcome is StepOutcome.SUMMED_AFTER_GAP, float(swing_time),
                                  self.compass_heading(reading), self.calibrated_reading(reading)))
        return outcome

    def __repr__(self) -> str:
        return f"FootTracker({self.side}, {self.track!r}, duplicates={self.duplicates})"


class TwoFeetTracker(AidedFilter):
    """Both feet in one filter (module docstring). ``tracker.left`` and ``tracker.right`` are the
    feet's trackers (:class:`FootTracker`) — give each to its module's session. Steps may come from two
    threads (one device each): the joint filter takes them one at a time, in arrival order.

    With *defer* the feet's steps are only collected; :meth:`fuse_in_time_order` then runs them
    through the filter in module-time order (replaying two captures, which arrive one after the
    other). *heading* [rad] is the way the walker faces at the start (from north towards east);
    the feet start half of :attr:`FeetSettings.step_width_m` to either side of the origin.

    *aids* (:class:`~hostlib.fusion.tracker.FusionSettings`) are the heading aids on the joint filter —
    each foot's compass measures its heading minus the declination D (a ninth state; minus the
    local deviation d too, one shared state before D, if the aids hold it), a GPS fix the body
    (plus the receiver's bias b, two states before d and D, if held); with the module's errors
    held each foot's module has its own, after the poses (module docstring) —
    and on each foot's own tracker (the baseline). *mag_calibrations* are each foot's
    module's magnetometer calibration, *drift* each module's drift calibration
    (:mod:`hostlib.calibration.drift`): its Δv moves that foot's every step by ``R(χ₀) Δv · T_swing``."""

    def __init__(self, settings: FeetSettings | None = None, *, last_counter: int | None = 0,
                 defer: bool = False, heading: float = 0.0, aids: FusionSettings | None = None,
                 mag_calibrations: Mapping[str, MagCalibration] | None = None,
                 drift: Mapping[str, DriftCalibration] | None = None):
        self.settings = settings or FeetSettings()
        self.aids = aids or FusionSettings()
        if self.aids.mag_calibration is not None:
            raise ValueError("a magnetometer calibration belongs to one module: give each foot's in "
                             "mag_calibrations, not one in the aids")
        mag_calibrations, self.drift = dict(mag_calibrations or {}), dict(drift or {})
        for side in (*mag_calibrations, *self.drift):
            if side not in FOOT_SIDES:
                raise ValueError(f"a foot is {' or '.join(FOOT_SIDES)}, not {side!r}")
        take = self._collect if defer else self.take
        half = 0.5 * self.settings.step_width_m
        self.left, self.right = (
            FootTracker(side, take, replace(self.aids, mag_calibration=mag_calibrations.get(side)),
                        last_counter=last_counter, heading=heading,
                        position=rotation_z(heading) @ np.array([0.0, sign * half, 0.0]))
            for side, sign in zip(FOOT_SIDES, (-1.0, 1.0), strict=True))
        self._lock = threading.Lock()
        self._deferred: list[FootStep] = []
        # both feet's poses, then each module's errors if held (the left's, then the right's), then
        # the aid states: [b_n, b_e,] [d,] D
        errors = self.aids.module_errors
        self.aid_settings = self.aids
        self.filter = StateFilter()
        for side in FOOT_SIDES:
            self.filter.add_block(side, self.foot(side).track.initial_pose)
        if errors is not None:
            for side in FOOT_SIDES:
                self.filter.add_block(f"errors.{side}", np.zeros(errors.states), errors.prior)
            self.error_blocks = tuple(f"errors.{side}" for side in FOOT_SIDES)
        # the shoe's hard iron belongs to each foot's module: each foot's own tracker learns its own,
        # and the heading it hands the joint filter has its estimate removed
        add_aid_states(self.filter, replace(self.aids, hard_iron=None))
        self._frame_heading = float(heading)  # the walk's start frame, turned with the aids' alignment
        self._time = 0.0  # the latest module time of a fused step [s]
        self._since = {side: 0 for side in FOOT_SIDES}  # the other foot's steps since this one's last
        # each foot's steps' times as its module's heading drift sees them (with the errors held)
        self._drift_clocks = {side: errors.clock() for side in FOOT_SIDES} if errors is not None else {}
        self._fused = {side: 0 for side in FOOT_SIDES}  # steps of each foot through the filter
        # the two feet's poses, side by side and first in the state: the history keeps their
        # covariance (all the body and each foot's σ need), not the error and aid blocks'
        self._poses = slice(self.filter.slice("left").start, self.filter.slice("right").stop)
        #: a row per fused step for the whole walk, a few hundred bytes each (its module docstring)
        self.history = JointHistory(len(self.filter), self._poses, self._body_rows())
        # without a heading aid nothing observes the walker's common heading and position, and the
        # bound (invariant to both) leaves them: the projection keeps to the feet's differences
        self._differential = () if self.aids.compass or self.aids.gps else (
            ("left", "right"), *((self.error_blocks,) if errors is not None else ()))
        self._init_aids()
        self._record(None)
        #: how often the constraint was violated and projected; steps fused without it because the
        #: other foot had not stepped since this foot's previous step, or because the step was
        #: longer than twice the bound (the other foot moved meanwhile: module docstring)
        self.projections = 0
        self.stale_steps = 0  #: steps fused without the constraint: the other foot had not stepped
        self.long_steps = 0  #: steps fused without the constraint: longer than twice the bound
        #: feet restarted at the other foot after a gap in their stream
        self.restarts: list[tuple[str, int]] = []  # (side, index of the joint step)
        #: steps the drift correction could not move: their packet had no swing time
        self.drift_uncorrected = 0

    # -- input ----------------------------------------------------------------------------

    def foot(self, side: str) -> FootTracker:
        if side not in FOOT_SIDES:
            raise ValueError(f"a foot is {' or '.join(FOOT_SIDES)}, not {side!r}")
        return self.left if side == "left" else self.right

    def _compass_calibration(self, pose: str) -> MagCalibration | None:
        """The calibration foot *pose*'s compass reads with (its own tracker's)."""
        return self.foot(pose).settings.mag_calibration

    def add_fix(self, time_s: float, north_east) -> None:
        """Queue one GPS fix of the body, for the joint filter and each foot's own tracker."""
        self.add_body_fix(time_s, north_east)
        self.left.add_fix(time_s, north_east)
        self.right.add_fix(time_s, north_east)

    def add_body_fix(self, time_s: float, north_east) -> None:
        """Queue one GPS fix of the body for the joint filter alone, at *time_s* on the clock it
        times its steps by (the latest module time of the steps it fused). A receiver read live
        (:mod:`hostlib.run.gps_stream`) gives each foot's own tracker the fix on that foot's module
        clock (``foot(side).add_fix``): the two modules' clocks need not be one."""
        super().add_fix(time_s, north_east)

    def _collect(self, step: FootStep) -> None:
        self._deferred.append(step)

    def fuse_in_time_order(self) -> None:
        """Run the collected steps through the filter in module-time order (without T_INT_K in
        every packet, alternately: ``_time_order()``)."""
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
        if step.after_gap and len(self) > 0:
            self._restart_at_other(i)
        # the stepping foot's block through the summation map, its cross terms through its Jacobian
        # (and through its module's errors, held)
        errors = self.aids.module_errors
        if errors is None:
            self.filter.step_pose(step.side, step.dx, step.dp)
        else:
            chi = float(self.filter.x[self.filter.index(step.side, 3)])
            span = self._drift_clocks[step.side].span(step.dx, step.time_s)
            self.filter.step_pose(step.side, step.dx, step.dp, f"errors.{step.side}",
                                  errors.jacobian(chi, step.dx, span))
        self._correct_drift(step)
        self._since[step.side] = 0
        self._since[FOOT_SIDES[1 - i]] += 1
        self._fused[step.side] += 1
        if math.isfinite(step.time_s):
            self._time = max(self._time, step.time_s)
        if self.aids.compass_deviation is not None:
            # d walks with the body: the feet's midpoint moves half the stepping foot's step
            self._walk_deviation(0.5 * math.hypot(step.dx[0], step.dx[1]))
        if self.aids.compass:
            self._compass_step(step.compass, step.side, is_motion_step(step.dx), step.field)
        if self.aids.gps:
            self._gps_until(self._time)
        if self._since[FOOT_SIDES[1 - i]] > 1:
            self.stale_steps += 1  # the other foot has not stepped since this one's last step
        elif float(np.linalg.norm(step.dx[:3])) > 2.0 * self.settings.max_separation_m:
            self.long_steps += 1  # the other foot moved meanwhile: its last rest is not where it is
        elif self.settings.constraint:
            self.projections += project_separation(self.filter, "left", "right",
                                                   self.settings.max_separation_m, self._differential)
        self._record(step.side)

    def _correct_drift(self, step: FootStep) -> None:
        calibration = self.drift.get(step.side)
        if calibration is None:
            return
        if not math.isfinite(step.swing_time):
            self.drift_uncorrected += 1
            return
        position = slice(self.filter.index(step.side), self.filter.index(step.side) + 3)
        self.filter.x[position] += calibration.velocity(self._frame_heading) * step.swing_time

    def _stale_foot(self) -> int:
        """0: both feet fresh; 1 + i: foot i is stale (the other stepped on without it)."""
        stale = [self._since[side] >= STALE_AFTER_STEPS for side in FOOT_SIDES]
        return 1 + stale.index(True) if stale[0] != stale[1] else 0

    def _restart_at_other(self, i: int) -> None:
        """Foot *i* lost steps: put it where the other foot is, as uncertain as that foot plus γ
        in position and the restart σ in heading, correlated with it as a copy is (its module's
        errors stay; its next step drifts over no time: the heading is the other foot's)."""
        a, b = self.filter.slice(FOOT_SIDES[i]), self.filter.slice(FOOT_SIDES[1 - i])
        x, p = self.filter.x, self.filter.P
        x[a] = x[b]
        p[a, :] = p[b, :]
        p[:, a] = p[:, b]
        p[a, a] = p[b, b] + np.diag([self.settings.max_separation_m ** 2] * 3
                                    + [self.settings.restart_heading_sigma_rad ** 2])
        if self._drift_clocks:
            self._drift_clocks[FOOT_SIDES[i]].lose_previous()
        self.restarts.append((FOOT_SIDES[i], len(self) + 1))

    def _record(self, side: str | None) -> None:
        """The history's row of the step *side* made (None: the start); the frame is settled once
        the heading is aligned (the alignment is the one turn of it)."""
        self.history.record(self.filter.x, self.filter.P[self._poses, self._poses], self._stale_foot(),
                            (self._fused["left"], self._fused["right"]), side, self._aligned)

    # -- what the aids need of the joint state ----------------------------------------------

    pose_blocks = FOOT_SIDES

    def _gps_rows(self) -> np.ndarray:
        """A fix measures the body: the feet's midpoint, or the fresh foot while the other is stale."""
        return self._body_rows()[self._stale_foot()][:2]

    def _travelled(self) -> np.ndarray:
        return self._gps_rows() @ (self.filter.x - self.history.start)

    def _rotate_frame(self, turn: float) -> None:
        """Turn both feet, now and in every recorded row, about the origin (the body's start)."""
        t = np.eye(len(self.filter))
        shift = np.zeros(len(self.filter))
        for side in FOOT_SIDES:
            position = self.filter.index(side)
            t[position: position + 3, position: position + 3] = rotation_z(turn)
            shift[self.filter.index(side, 3)] = turn
        self.history.turn(t, shift)  # t turns only the pose blocks
        self.filter.transform(t, shift)
        self._frame_heading += turn

    # -- results --------------------------------------------------------------------------

    @property
    def state(self) -> np.ndarray:
        """The joint state [x_L, y_L, z_L, χ_L, x_R, y_R, z_R, χ_R] (a copy)."""
        return self.filter.x[self.filter.indices(*FOOT_SIDES)]

    @property
    def covariance(self) -> np.ndarray:
        """Its 8×8 covariance (a copy)."""
        feet = self.filter.indices(*FOOT_SIDES)
        return self.filter.P[np.ix_(feet, feet)]

    def module_errors(self, side: str) -> tuple[float, ...] | None:
        """The estimated errors of *side*'s module: its step-length scale s, climb c [m/m] and turn
        scale k and, with a heading drift prior, drift rate r [rad/s] (None: not held)."""
        if self.aids.module_errors is None:
            return None
        with self._lock:
            return tuple(float(v) for v in self.filter.mean(f"errors.{side}"))

    def module_error_sigmas(self, side: str) -> np.ndarray | None:
        """The 1σ of :meth:`module_errors` (None: not held)."""
        if self.aids.module_errors is None:
            return None
        with self._lock:
            return self.filter.sigmas(f"errors.{side}")

    @property
    def sides(self) -> list[str]:
        """Which foot made each fused step."""
        with self._lock:
            return self.history.sides()

    def rows_of(self, side: str) -> np.ndarray:
        """The rows of :meth:`fused_foot` (and :attr:`body`) that steps of *side* made, in order."""
        with self._lock:
            return self.history.rows_of(FOOT_SIDES.index(side))

    @property
    def body(self) -> Track:
        """The fused body track: the feet's midpoint after each fused step (row 0: the start);
        while one foot is stale, the other foot."""
        return Track.from_arrays(*self.body_poses())

    def body_poses(self) -> tuple[np.ndarray, np.ndarray]:
        """:attr:`body`'s (n + 1, 4) poses and (n + 1, 4, 4) covariances, without the track (each
        row is made once: :class:`~hostlib.fusion.joint_history.JointHistory`)."""
        with self._lock:
            return self.history.body()

    def body_end(self) -> tuple[np.ndarray, float]:
        """The body's last pose and its closure σ (:meth:`~hostlib.track.steps.Track.closure_sigma`)
        without the rest of :attr:`body` (a status line's, after every step)."""
        with self._lock:
            (pose, cov), (_, cov0) = self.history.body_row(-1), self.history.body_row(0)
        return pose, closure_sigma(cov0, cov)

    @property
    def average(self) -> Track:
        """The baseline: the midpoint of the two single-module tracks after each fused step (each
        with its own aids and drift correction)."""
        with self._lock:
            counts, stale = self.history.counts(), self.history.stale()
        single = [self._single_poses(side)[counts[:, i]] for i, side in enumerate(FOOT_SIDES)]
        covs = [self.foot(side).track.covariances[counts[:, i]] for i, side in enumerate(FOOT_SIDES)]
        n = len(self.filter)
        states, joint = np.zeros((len(stale), n)), np.zeros((len(stale), n, n))
        for side, poses, cov in zip(FOOT_SIDES, single, covs, strict=True):
            b = self.filter.slice(side)
            states[:, b], joint[:, b, b] = poses, cov
        return Track.from_arrays(*body_pose_rows(states, joint, self._body_rows()[stale]))

    def _body_rows(self) -> np.ndarray:
        """(3, 4, n): the body pose from the joint state — the midpoint; the right foot while the
        left is stale; the left foot while the right is stale."""
        def pose_rows(weights: dict[str, float]) -> np.ndarray:
            return np.stack([self.filter.row({(side, k): w for side, w in weights.items()})
                             for k in range(4)])
        return np.stack([pose_rows({"left": 0.5, "right": 0.5}), pose_rows({"right": 1.0}),
                         pose_rows({"left": 1.0})])

    def disagreement(self) -> tuple[float, float]:
        """How far the fused body's end lies from the average's: [m] horizontally, and in σ of the
        two ends' covariances summed (as if independent: they share each foot's steps, so this
        overstates the σ and understates the count). Beyond :data:`DISAGREEMENT_SIGMAS` the
        constraint moved the walker further than either estimate allows: the feet's modules err in
        ways the filter does not hold (their heading drifts: hold each module's errors)."""
        fused, average = self.body, self.average
        d = fused.final_pose[:2] - average.final_pose[:2]
        c = fused.final_covariance[:2, :2] + average.final_covariance[:2, :2]
        sigmas = float(np.sqrt(max(float(d @ np.linalg.pinv(c) @ d), 0.0)))
        return float(np.hypot(*d)), sigmas

    def _single_poses(self, side: str) -> np.ndarray:
        """One foot's single-module track, drift-corrected with its calibration (steps without a
        swing time uncorrected)."""
        track = self.foot(side).track
        poses = track.poses
        calibration = self.drift.get(side)
        if calibration is not None:
            swing = np.nan_to_num(track.swing_times, nan=0.0)
            dv = calibration.velocity(poses[0, 3])
            poses[:, :3] += np.concatenate(([0.0], np.cumsum(swing)))[:, None] * dv[None, :]
        return poses

    def fused_foot(self, side: str) -> np.ndarray:
        """(n + 1, 4) the fused poses of *side* after each fused step (row 0: the start)."""
        b = self.filter.slice(side)
        with self._lock:
            return self.history.feet()[:, b.start - self._poses.start:b.stop - self._poses.start].copy()

    def fused_foot_sigmas(self, side: str) -> np.ndarray:
        """(n + 1, 4) the 1σ of :meth:`fused_foot`'s rows: x, y, z [m] and χ [rad]."""
        b = self.filter.slice(side)
        b = slice(b.start - self._poses.start, b.stop - self._poses.start)
        with self._lock:
            var = self.history.variances()[:, b]
        return np.sqrt(np.clip(var, 0.0, None))

    def separation(self) -> np.ndarray:
        """(n + 1,) the fused feet's distance apart after each fused step [m]."""
        with self._lock:
            feet = self.history.feet()
        left, right = (self.filter.index(side) - self._poses.start for side in ("left", "right"))
        return np.linalg.norm(feet[:, left:left + 3] - feet[:, right:right + 3], axis=1)

    def __len__(self) -> int:
        return len(self.history) - 1

    def __repr__(self) -> str:
        return (f"TwoFeetTracker({len(self)} steps: left {len(self.left)}, right {len(self.right)}; "
                f"{self.projections} projections, {self.stale_steps} steps with a stale foot, "
                f"{self.long_steps} steps longer than twice the bound, "
                f"{len(self.restarts)} restarts)")


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
