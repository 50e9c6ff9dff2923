"""Step-wise dead reckoning on the host: summing the module's steps into a track.

The module resets its INS at the end of every stance and sends the displacement
since the previous reset, a *step*: ``dx = [dx, dy, dz, dψ]`` in the navigation
frame of the previous reset (x north, y east, z down; dψ the heading change),
the 4×4 covariance ``dP`` of ``dx`` and the 16-bit step counter (firmware.md §4,
protocol.md §3 "Mode commands"). The host chains the steps
(firmware.md §5; Nilsson, Gupta and Händel, "Foot-mounted inertial navigation
made easy", IPIN 2014, §IV). With the pose ``s = [x, y, z, χ]``::

    [x, y, z]_ℓ = [x, y, z]_{ℓ−1} + R(χ_{ℓ−1}) · dp_ℓ
    χ_ℓ         = χ_{ℓ−1} + dψ_ℓ

where ``R(χ)`` is the rotation about the (down-pointing) z axis. The 4×4 pose
covariance is propagated with the Jacobians of that map::

    P_ℓ = F P_{ℓ−1} Fᵀ + G dP_ℓ Gᵀ
    F = ∂s_ℓ/∂s_{ℓ−1} = [[I₃, R'(χ) dp], [0, 1]],  G = ∂s_ℓ/∂dx_ℓ = diag(R(χ), 1)

Everything on the host is float64. Step packets are resent until acknowledged,
so the same step can arrive more than once: a step whose counter was already
summed is ignored (and counted). A jump in the counter (it is a uint16 and wraps)
means steps were lost; the gap is recorded as a :class:`GapEvent` and the pose
continues from the last summed step (the lost displacement is unknown).

Each step may come with its swing time [s] (state 0x34 SWING_TIME, when the host
asked for it: :data:`protocol.extensions.FUSION_SETUP`); the track keeps it beside
the step (NaN when the step had none) for the aids that need it
(:mod:`hostlib.calibration.drift`). It changes nothing in the summation.

This module is pure computation: no I/O, no protocol decoding. It accepts any
object with ``dx`` (4,), ``dp`` (4×4) and ``counter`` attributes, such as
:class:`protocol.codec.Step`. Its gap records and step outcomes are the types
declared in :mod:`hostlib.events` (numpy and the standard library only).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Protocol

import numpy as np

from ..events import GapEvent, StepOutcome
from .rows import Rows
from .step_checks import step_problem

__all__ = [
    "COUNTER_MODULUS",
    "MOTION_MIN_HEADING_RAD",
    "MOTION_MIN_LENGTH_M",
    "StepLike",
    "StepTracker",
    "Track",
    "closure_sigma",
    "counter_delta",
    "heading_deg",
    "is_motion_step",
    "propagate",
    "rotation_z",
    "step_jacobian",
    "step_problem",
]

#: The step counter is a uint16 on the module (state 0x32).
COUNTER_MODULUS = 1 << 16
_HALF = COUNTER_MODULUS // 2


class StepLike(Protocol):
    """What the tracker needs from a step (e.g. :class:`protocol.codec.Step`)."""

    @property
    def dx(self) -> np.ndarray: ...  # (4,): dx, dy, dz [m], dψ [rad]

    @property
    def dp(self) -> np.ndarray: ...  # (4, 4) covariance of dx

    @property
    def counter(self) -> int: ...  # uint16 step counter


def rotation_z(chi: float) -> np.ndarray:
    """The 3×3 rotation about the z axis by heading *chi* [rad] (x north, y east, z down)."""
    c, s = math.cos(chi), math.sin(chi)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def heading_deg(chi: float) -> float:
    """A heading χ [rad] as a host shows it: degrees in [0, 360), rounded to 0.1° first so that
    −0.0 and 359.96° both read 0.0, never 360.0. (χ itself is kept unwrapped: the track's
    headings turn on through whole circles.)"""
    return (round(math.degrees(chi), 1) % 360.0) + 0.0


_EYE4 = np.eye(4)
_EYE4.flags.writeable = False


def step_jacobian(chi: float, dx: np.ndarray) -> np.ndarray:
    """F = ∂pose_ℓ/∂pose_{ℓ−1} (4×4) of one step *dx* taken at heading *chi*: the identity plus
    the derivative of R(χ)·dp with respect to χ."""
    c, s = math.cos(chi), math.sin(chi)
    f = _EYE4.copy()
    f[0, 3] = -s * dx[0] - c * dx[1]
    f[1, 3] = c * dx[0] - s * dx[1]
    return f


def propagate(
    pose: np.ndarray, cov: np.ndarray, dx: np.ndarray, dp: np.ndarray, f: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """One step of the summation map: the new pose [x, y, z, χ] and its 4×4 covariance.

    *pose* (4,) and *cov* (4×4) describe the pose after the previous step; *dx*
    (4,) is the step's displacement and heading change in the previous step's
    frame and *dp* (4×4) its covariance. The pose and the step are independent.
    *f*: the step's :func:`step_jacobian`, when the caller has it already.
    """
    pose = np.asarray(pose, dtype=np.float64)
    cov = np.asarray(cov, dtype=np.float64)
    dx = np.asarray(dx, dtype=np.float64)
    dp = np.asarray(dp, dtype=np.float64)
    chi = float(pose[3])
    r = rotation_z(chi)
    new = np.empty(4)
    new[:3] = pose[:3] + r @ dx[:3]
    new[3] = chi + dx[3]
    if f is None:
        f = step_jacobian(chi, dx)
    # G = ∂new/∂dx = diag(R(χ), 1).
    g = _EYE4.copy()
    g[:3, :3] = r
    new_cov = f @ cov @ f.T + g @ dp @ g.T
    new_cov = 0.5 * (new_cov + new_cov.T)  # keep it exactly symmetric
    return new, new_cov


#: A step moved the foot if it carried it at least this far [m]. The module also resets
#: while the wearer stands still (every ~0.75–1 s); such a step moves a few millimetres at
#: most (ZUPT residuals), while the shortest real step — a stair tread, a side step — is
#: 0.25–0.3 m. 0.1 m lies far from both.
MOTION_MIN_LENGTH_M = 0.10
#: … or turned it at least this much [rad] (a turn on the spot: 30–45° a step; at rest the
#: heading is held by the detector's ZARU, hundredths of a degree).
MOTION_MIN_HEADING_RAD = math.radians(10.0)


def is_motion_step(dx: Iterable[float]) -> bool:
    """Whether a step ``[dx, dy, dz, dψ]`` moved the foot (see :data:`MOTION_MIN_LENGTH_M`),
    rather than being one of the module's resets while the wearer stands still."""
    d = np.asarray(dx if isinstance(dx, np.ndarray) else list(dx), dtype=np.float64)
    return bool(np.linalg.norm(d[:3]) >= MOTION_MIN_LENGTH_M or abs(d[3]) >= MOTION_MIN_HEADING_RAD)


def closure_sigma(cov0: np.ndarray, cov: np.ndarray) -> float:
    """1σ [m] along its worst direction of the horizontal position a walk added: from the start's
    pose covariance *cov0* to the end's *cov* (4×4 each, or at least their x–y block)."""
    c = cov[:2, :2] - cov0[:2, :2]
    return float(math.sqrt(max(0.0, float(np.linalg.eigvalsh(c).max()))))


def counter_delta(previous: int, counter: int) -> int:
    """Signed distance from *previous* to *counter* on the uint16 circle, in −32768..32767.

    1 is the next step, 0 a resend of the same step, > 1 a gap, < 0 an older step.
    """
    return ((int(counter) - int(previous) + _HALF) % COUNTER_MODULUS) - _HALF


class Track:
    """A walked track: the pose after every summed step, with covariances.

    Row 0 of :attr:`poses` / :attr:`covariances` is the initial pose; row *k* is
    the pose after the *k*-th summed step. Poses are ``[x, y, z, χ]`` in metres
    and radians, navigation frame x north, y east, z down.

    Kept per step, for the whole walk (the CSV and the plot at the end write every pose, a live
    page opened late draws them all): the pose (4 float64), its 4×4 covariance, the step's dx
    (4 float64), its counter and its swing time, in growing arrays (:class:`~hostlib.track.rows.Rows`):
    about 200 bytes a step, nothing else grows with the walk.
    """

    def __init__(self, pose0: np.ndarray, cov0: np.ndarray, start_counter: int | None = 0):
        #: counter of the step before the first one (0 after 0x34; None when attached mid-walk)
        self.start_counter = start_counter
        self._poses = Rows((4,))
        self._covs = Rows((4, 4))
        self._poses.append(np.asarray(pose0, dtype=np.float64))
        self._covs.append(np.asarray(cov0, dtype=np.float64))
        self._steps = Rows((4,))
        self._counters = Rows((), np.uint16)
        self._swing_times = Rows(())
        self._moving = 0  # summed steps that moved the foot (is_motion_step)
        self.distance: float = 0.0  #: sum of the horizontal step lengths [m]
        self.gaps: list[GapEvent] = []  #: every gap in the step counter, in order

    def append(self, pose: np.ndarray, cov: np.ndarray, dx: np.ndarray, counter: int,
               swing_time: float = math.nan) -> None:
        """Add the pose *pose* (4,) and covariance *cov* (4×4) after a step *dx* (4,) numbered
        *counter*, with its swing time [s] (NaN: none); the numbers are copied into the track."""
        self._poses.append(pose)
        self._covs.append(cov)
        self._steps.append(dx)
        self._counters.append(counter)
        self._swing_times.append(float(swing_time))
        self._moving += is_motion_step(dx)
        self.distance += math.hypot(float(dx[0]), float(dx[1]))

    def replace_last(self, pose: np.ndarray, cov: np.ndarray) -> None:
        """The last pose and covariance as a filter corrected them (copied into the track)."""
        self._poses.set_last(pose)
        self._covs.set_last(cov)

    def rotate_about_start(self, turn: float) -> None:
        """Turn every pose about the start by *turn* [rad]: positions about the first one, every
        heading by *turn*, and each covariance with them (an aid aligned the frame). The turned rows
        are new arrays: what :meth:`views` handed out before stays as it was."""
        r = rotation_z(turn)
        poses, covs = self._poses.copy(), self._covs.copy()
        start = poses[0, :3].copy()
        for k in range(len(poses)):
            p = poses[k].copy()
            p[:3] = start + r @ (p[:3] - start)
            p[3] += turn
            poses[k] = p
            c = covs[k].copy()
            c[:3, :3] = r @ c[:3, :3] @ r.T
            c[:3, 3] = r @ c[:3, 3]
            c[3, :3] = c[:3, 3]
            covs[k] = c
        self._poses, self._covs = Rows.of(poses), Rows.of(covs)

    @classmethod
    def from_arrays(
        cls,
        poses: np.ndarray,
        covariances: np.ndarray,
        steps: np.ndarray | None = None,
        counters: Iterable[int] | None = None,
        start_counter: int | None = 0,
        swing_times: Iterable[float] | None = None,
    ) -> Track:
        """A track from stored arrays (e.g. read back from CSV): poses (n+1, 4), covariances (n+1, 4, 4).

        *steps* (n, 4) default to the pose differences in each previous frame;
        *counters* (n,) default to 1..n; *start_counter* is the counter before the
        first step (None: unknown); *swing_times* (n,) [s] default to NaN (none).
        Distance and gaps are recomputed.
        """
        poses = np.asarray(poses, dtype=np.float64)
        covs = np.asarray(covariances, dtype=np.float64)
        n = len(poses) - 1
        if n < 0 or poses.shape != (n + 1, 4) or covs.shape != (n + 1, 4, 4):
            raise ValueError(
                f"need poses (n+1, 4) and covariances (n+1, 4, 4), got {poses.shape}, {covs.shape}"
            )
        if steps is None:
            steps = np.empty((n, 4))
            for k in range(n):
                steps[k, :3] = rotation_z(poses[k, 3]).T @ (poses[k + 1, :3] - poses[k, :3])
                steps[k, 3] = poses[k + 1, 3] - poses[k, 3]
        steps = np.asarray(steps, dtype=np.float64).reshape(n, 4)
        cnt = list(range(1, n + 1)) if counters is None else [int(c) for c in counters]
        if len(cnt) != n:
            raise ValueError(f"{n} steps but {len(cnt)} counters")
        swings = [math.nan] * n if swing_times is None else [float(t) for t in swing_times]
        if len(swings) != n:
            raise ValueError(f"{n} steps but {len(swings)} swing times")
        track = cls(poses[0], covs[0], start_counter)
        prev: int | None = start_counter
        for k in range(n):
            if prev is not None and counter_delta(prev, cnt[k]) > 1:
                track.gaps.append(GapEvent(prev, cnt[k], counter_delta(prev, cnt[k]) - 1, k + 1))
            track.append(poses[k + 1], covs[k + 1], steps[k], cnt[k], swings[k])
            prev = cnt[k]
        return track

    def copy(self) -> Track:
        """An independent copy (take it under the owner's lock while steps are being added)."""
        t = Track(self._poses[0], self._covs[0], self.start_counter)
        t._poses, t._covs = Rows.of(self._poses.view()), Rows.of(self._covs.view())
        t._steps, t._counters = Rows.of(self._steps.view()), Rows.of(self._counters.view())
        t._swing_times = Rows.of(self._swing_times.view())
        t._moving = self._moving
        t.distance = self.distance
        t.gaps = list(self.gaps)
        return t

    def views(self) -> tuple[np.ndarray, np.ndarray]:
        """:attr:`poses` and :attr:`covariances` read-only and not copied: for a reader that takes them
        under the lock steps are summed under and reads them after it (later steps, and a turn of
        the track, do not show in them)."""
        return self._poses.view(), self._covs.view()

    def __len__(self) -> int:
        """Number of summed steps."""
        return len(self._steps)

    @property
    def poses(self) -> np.ndarray:
        """(n+1, 4) float64: initial pose, then the pose after each step."""
        return self._poses.copy()

    @property
    def covariances(self) -> np.ndarray:
        """(n+1, 4, 4) float64: covariance of each row of :attr:`poses`."""
        return self._covs.copy()

    @property
    def positions(self) -> np.ndarray:
        """(n+1, 3) float64 positions [m]."""
        return self.poses[:, :3]

    @property
    def headings(self) -> np.ndarray:
        """(n+1,) float64 headings χ [rad] (not wrapped)."""
        return self.poses[:, 3]

    @property
    def steps(self) -> np.ndarray:
        """(n, 4) float64: the summed steps' dx as received."""
        return self._steps.copy()

    @property
    def last_step(self) -> np.ndarray | None:
        """The last summed step's dx (4,) as received (None: no step yet)."""
        return self._steps[-1].copy() if len(self._steps) else None

    @property
    def counters(self) -> np.ndarray:
        """(n,) uint16: the summed steps' counters."""
        return self._counters.view().astype(np.uint16)

    @property
    def swing_times(self) -> np.ndarray:
        """(n,) float64: each summed step's swing time [s] (state 0x34), NaN where it had none."""
        return self._swing_times.copy()

    @property
    def motion_steps(self) -> int:
        """How many summed steps moved the foot (:func:`is_motion_step`); the rest are the
        module's resets while the wearer stood still."""
        return self._moving

    @property
    def sigmas(self) -> np.ndarray:
        """(n+1, 4) float64: 1σ of x, y, z [m] and χ [rad] for every pose."""
        return np.sqrt(np.clip(np.diagonal(self.covariances, axis1=1, axis2=2), 0.0, None))

    @property
    def missing(self) -> int:
        """Total number of steps lost in gaps."""
        return sum(g.missing for g in self.gaps)

    @property
    def initial_pose(self) -> np.ndarray:
        """The pose before the first step [x, y, z, χ] (a copy)."""
        return self._poses[0].copy()

    @property
    def final_pose(self) -> np.ndarray:
        return self._poses[-1].copy()

    @property
    def final_covariance(self) -> np.ndarray:
        return self._covs[-1].copy()

    def closure_error(self, horizontal: bool = True) -> float:
        """Distance [m] between the final and the initial position (a closed loop's error).

        Horizontal (x, y) by default; ``horizontal=False`` includes z.
        """
        return self.error_to(self._poses[0][:3], horizontal=horizontal)

    def relative_closure_error(self, horizontal: bool = True) -> float:
        """Closure error as a fraction of the distance walked (NaN before any distance)."""
        if self.distance == 0.0:
            return math.nan
        return self.closure_error(horizontal) / self.distance

    def error_to(self, point: Iterable[float], horizontal: bool = True) -> float:
        """Distance [m] from the final position to a known *point* (x, y[, z])."""
        p = np.asarray(list(point), dtype=np.float64)
        d = self._poses[-1][: len(p)] - p
        if horizontal:
            d = d[:2]
        return float(np.linalg.norm(d))

    def closure_sigma(self) -> float:
        """1σ [m] of the final horizontal position along its worst direction.

        The square root of the largest eigenvalue of the final x–y covariance
        minus the initial one (the uncertainty the walk added).
        """
        return closure_sigma(self._covs[0], self._covs[-1])

    def __repr__(self) -> str:
        x, y, z, chi = self._poses[-1]
        return (
            f"Track({len(self)} steps, {self.distance:.2f} m, end=({x:.2f}, {y:.2f}, {z:.2f}) m "
            f"χ={heading_deg(chi):.1f}°, gaps={len(self.gaps)}, missing={self.missing})"
        )


class StepTracker:
    """Sums steps into a :class:`Track`, ignoring resends and recording gaps.

    *position* (3,) [m], *heading* χ [rad] and *covariance* (4×4 over
    [x, y, z, χ], default zero) set the initial pose. *last_counter* is the
    counter of the step before the first expected one: 0 after STEPWISE_DEAD_RECKONING
    (0x34) resets the module's counter, so the first step is 1 and a first step
    numbered 3 reports two missing; ``None`` when attaching to a module that is
    already counting (the first step is taken as it comes, no gap).
    """

    def __init__(
        self,
        position: Iterable[float] = (0.0, 0.0, 0.0),
        heading: float = 0.0,
        covariance: np.ndarray | None = None,
        *,
        last_counter: int | None = 0,
    ):
        pose0 = np.zeros(4)
        pos = np.asarray(list(position), dtype=np.float64)
        if pos.shape != (3,):
            raise ValueError(f"position must have 3 elements, got shape {pos.shape}")
        pose0[:3] = pos
        pose0[3] = float(heading)
        cov0 = np.zeros((4, 4)) if covariance is None else np.array(covariance, dtype=np.float64)
        if cov0.shape != (4, 4):
            raise ValueError(f"covariance must be 4×4, got shape {cov0.shape}")
        if not np.allclose(cov0, cov0.T):
            raise ValueError("covariance must be symmetric")
        if last_counter is not None and not 0 <= int(last_counter) < COUNTER_MODULUS:
            raise ValueError(f"last_counter {last_counter} is not a uint16")
        #: the summed track: every step's pose and covariance
        self.track = Track(pose0, cov0, None if last_counter is None else int(last_counter))
        self._last: int | None = None if last_counter is None else int(last_counter)
        self.duplicates = 0  #: steps ignored because their counter was already summed
        #: steps left out because their numbers are impossible (:func:`step_problem`): (counter, why)
        self.rejections: list[tuple[int, str]] = []

    # -- state ---------------------------------------------------------------

    @property
    def pose(self) -> np.ndarray:
        """Current pose [x, y, z, χ] (a copy)."""
        return self.track.final_pose

    @property
    def position(self) -> np.ndarray:
        return self.track.final_pose[:3]

    @property
    def heading(self) -> float:
        return float(self.track.final_pose[3])

    @property
    def covariance(self) -> np.ndarray:
        """Current 4×4 pose covariance (a copy)."""
        return self.track.final_covariance

    @property
    def distance(self) -> float:
        return self.track.distance

    @property
    def gaps(self) -> list[GapEvent]:
        return self.track.gaps

    @property
    def missing(self) -> int:
        return self.track.missing

    @property
    def last_counter(self) -> int | None:
        """Counter of the last summed step (or the configured start)."""
        return self._last

    def __len__(self) -> int:
        return len(self.track)

    # -- summation -----------------------------------------------------------

    def add(self, step: StepLike, swing_time: float = math.nan,
            states: Mapping[int, np.ndarray] | None = None) -> StepOutcome:
        """Sum one step unless it is a resend; returns what was done with it.

        *swing_time* [s] is kept beside the step (:attr:`Track.swing_times`); NaN: none.
        *states* are the step packet's decoded states, for trackers that use more than the
        step (:class:`hostlib.fusion.tracker.FusionTracker`); the summation ignores them."""
        return self.add_step(step.dx, step.dp, step.counter, swing_time)

    def add_step(self, dx: Iterable[float], dp: np.ndarray, counter: int,
                 swing_time: float = math.nan) -> StepOutcome:
        """Sum one step given as arrays: *dx* (4,), *dp* (4×4), *counter* (uint16), and its
        *swing_time* [s] (NaN: none). A resend is counted and ignored; a step whose numbers are
        impossible (:func:`step_problem`) is counted in :attr:`rejections` and left out, its counter
        taken as seen (its displacement is lost, as a gap's)."""
        counter = int(counter)
        if not 0 <= counter < COUNTER_MODULUS:
            raise ValueError(f"step counter {counter} is not a uint16")
        dxa = np.asarray(dx, dtype=np.float64).reshape(-1)
        dpa = np.asarray(dp, dtype=np.float64)
        if dxa.shape != (4,) or dpa.shape != (4, 4):
            raise ValueError(f"a step needs dx (4,) and dp (4, 4); got {dxa.shape} and {dpa.shape}")
        outcome = self._admit(counter)
        if outcome is StepOutcome.DUPLICATE:
            return outcome
        self._last = counter
        problem = step_problem(dxa, dpa)
        if problem is not None:
            self.rejections.append((counter, problem))
            return StepOutcome.REJECTED
        self._sum(dxa, dpa, counter, swing_time)
        return outcome

    def _admit(self, counter: int) -> StepOutcome:
        """Whether step *counter* is summed: a resend is counted and left out, a jump in the
        counter is recorded as a gap."""
        if self._last is None:
            return StepOutcome.SUMMED
        delta = counter_delta(self._last, counter)
        if delta <= 0:
            self.duplicates += 1
            return StepOutcome.DUPLICATE
        if delta > 1:
            self.track.gaps.append(GapEvent(self._last, counter, delta - 1, len(self.track) + 1))
            return StepOutcome.SUMMED_AFTER_GAP
        return StepOutcome.SUMMED

    def _sum(self, dx: np.ndarray, dp: np.ndarray, counter: int, swing_time: float) -> None:
        """Sum one admitted step into the track (the summation map)."""
        pose, cov = propagate(self.track.final_pose, self.track.final_covariance, dx, dp)
        self.track.append(pose, cov, dx.copy(), counter, swing_time)

    def extend(self, steps: Iterable[StepLike]) -> Track:
        """Sum many steps in order; returns the track."""
        for s in steps:
            self.add(s)
        return self.track

    def restart_counter(self, last_counter: int | None = 0) -> None:
        """Forget the step counter (e.g. after sending 0x34 again): the pose keeps going."""
        self._last = None if last_counter is None else int(last_counter) % COUNTER_MODULUS

    @property
    def rejected(self) -> int:
        """How many steps were left out because their numbers are impossible."""
        return len(self.rejections)

    def __repr__(self) -> str:
        return f"StepTracker({self.track!r}, duplicates={self.duplicates}, rejected={self.rejected})"
