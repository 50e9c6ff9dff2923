"""The host-side fusion filter: the step track with a per-step compass, declination and GPS fixes.

The module keeps its ZUPT INS and hands the host one step at a time (:mod:`hostlib.tracking`).
:class:`FusionTracker` sums the steps exactly as :class:`~hostlib.tracking.StepTracker` does — it
*is* one — and holds one more state, the magnetic declination D, so that its state is
``[x, y, z, χ, D]`` with a 5×5 covariance. On top of the summation it applies, each switched on
by :class:`FusionSettings` (shared/spec/aids.md §1–2, NavShoe):

* **the per-step compass** — at each step's end of stance the packet's magnetometers and attitude
  give a heading from magnetic north, ψ_c (:mod:`hostlib.compass`), which measures ``χ − D`` with
  variance σ_c² (the local deviation, not the sensor noise: tens of degrees indoors). One reading
  per step that moved the foot; the module's resets while the wearer stands still carry no
  update (their readings are the same reading again, and the module's ZARU holds the heading).
  The first reading aligns the heading: χ ← ψ_c + D, with variance σ_c² + var D;
* **GPS fixes** — north and east of a fix, about the first fix, measure ``[x, y]`` with an
  inflated variance σ_gps² (a receiver's errors are correlated over minutes, so fixes a second
  apart are not independent measurements). A fix is applied at the first step at or after its
  time (at most a step late: a metre against σ_gps of many). The first fix places the origin: the
  start is uncertain by the receiver's own σ. Without a compass the first heading comes from the
  GPS course: once the receiver has moved :attr:`FusionSettings.gps_align_distance_m` from the
  first fix, the track turns onto it, with σ = √2 σ_rx / distance;
* **declination** — a state with a prior (the World Magnetic Model at the first fix, chosen by
  the caller: :func:`hostlib.declination.declination_deg`) and σ_D (NavShoe: 15°) while GPS is
  used; the compass then measures χ − D and GPS χ alone, so D becomes observable. Without GPS it
  is a constant.

With every aid off the track is :class:`~hostlib.tracking.StepTracker`'s, bit for bit: the
summation is the same code, and D is uncorrelated with the pose until an aid correlates it.

Time: a step packet of the fusion set-up carries T_INT_K (the module's 64 MHz cycle counter when
the step's last measurement was taken); the tracker unwraps it into seconds since the module's
power-on (:class:`~hostlib.module_clock.ModuleClock`). Fix times are seconds since the receiver started
talking (:func:`hostlib.gps.seconds_since`); the two clocks are taken to start together, as the
emulator's receiver and module do (:attr:`FusionSettings.gps_offset_s` shifts the fixes).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

import numpy as np

from .compass import StanceReading, compass_heading, stance_reading, wrap_angle
from .events import StepOutcome
from .magcal import MagCalibration
from .module_clock import ModuleClock
from .tracking import StepTracker, is_motion_step, rotation_z, step_jacobian

__all__ = ["FusionSettings", "FusionStats", "FusionTracker"]

@dataclass(frozen=True)
class FusionSettings:
    """Which aids the :class:`FusionTracker` applies, and how much it trusts them."""

    #: per-step compass updates on
    compass: bool = False
    #: 1σ of one compass reading [rad]: the local deviation. Our default is indoor: the emulator's
    #: building deviation (5 µT RMS per axis against a 15.5 µT horizontal field) is ≈ 18°.
    compass_sigma_rad: float = math.radians(20.0)
    #: "step": one update per step that moved the foot (NavShoe); "every-reset": at every reset,
    #: standing ones too (the continuous compass NavShoe warns against, kept for comparison)
    compass_mode: str = "step"
    #: the shoe's hard and soft iron, removed before the heading is taken
    mag_calibration: MagCalibration | None = None
    #: GPS updates on (fixes given with :meth:`FusionTracker.add_fixes` / :meth:`add_fix`)
    gps: bool = False
    #: 1σ [m] of the receiver's horizontal error as specified (the emulator's: 3 m RMS)
    gps_receiver_sigma_m: float = 3.0
    #: 1σ [m] of a horizontal fix as a filter measurement: the receiver's σ inflated for the
    #: correlation of its errors (τ = 120 s: fixes an update interval apart are far from
    #: independent). 3 m · √(2τ / 10 s) ≈ 15 m (NavShoe: 20 m for a 6 m receiver).
    gps_sigma_m: float = 15.0
    #: seconds between GPS updates (fixes in between are skipped, counted)
    gps_interval_s: float = 10.0
    #: added to every fix time [s] to put it on the module's clock
    gps_offset_s: float = 0.0
    #: without a compass, the GPS course aligns the heading after this distance [m] from the first fix
    gps_align_distance_m: float = 50.0
    #: the declination prior D₀ [rad] (east positive) and its 1σ while GPS is used
    declination_rad: float = 0.0
    declination_sigma_rad: float = math.radians(15.0)

    def __post_init__(self) -> None:
        if self.compass_mode not in ("step", "every-reset"):
            raise ValueError(f"compass_mode must be 'step' or 'every-reset', not {self.compass_mode!r}")
        for name in ("compass_sigma_rad", "gps_sigma_m", "gps_receiver_sigma_m", "gps_align_distance_m"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be positive")


@dataclass
class FusionStats:
    """What the aids did."""

    compass_updates: int = 0
    compass_skipped: int = 0  #: readings not used (standing resets; no reading in the packet)
    gps_updates: int = 0
    gps_skipped: int = 0  #: fixes between updates (:attr:`FusionSettings.gps_interval_s`)
    gps_before_alignment: int = 0  #: fixes that arrived before the heading was aligned
    heading_aligned_by: str = ""  #: "compass", "gps" or "" (not aligned: the module's frame)
    #: (step index, innovation [rad]) of every compass update, for consistency checks
    compass_innovations: list[tuple[int, float]] = field(default_factory=list)


class FusionTracker(StepTracker):
    """A :class:`StepTracker` with a declination state and the aids of :class:`FusionSettings`.

    Use it wherever a step tracker goes (a :class:`~hostlib.session.HostSession`'s tracker): the
    session hands it each step packet's decoded states, which carry the stance reading and the
    step's time. :attr:`declination` and :attr:`covariance5` give the full state.
    """

    def __init__(self, settings: FusionSettings | None = None, **tracker_args):
        super().__init__(**tracker_args)
        self.settings = settings or FusionSettings()
        s = self.settings
        self.fusion = FusionStats()
        self._d = float(s.declination_rad)
        self._pd = np.zeros(4)  # cov(pose, D)
        self._dd = s.declination_sigma_rad ** 2 if (s.gps and s.compass) else 0.0
        self._aligned = not (s.compass or s.gps)
        self._clock = ModuleClock()
        self._time = 0.0  # module time of the last step [s]
        self._fix_times: list[float] = []
        self._fixes: list[np.ndarray] = []
        self._next_fix = 0
        self._origin_set = False
        self._last_gps_update = -math.inf
        #: per summed step: module time [s] (NaN: the packet had no T_INT_K)
        self.step_times: list[float] = []

    # -- state -------------------------------------------------------------------------

    @property
    def declination(self) -> float:
        """The declination estimate D [rad], east positive."""
        return self._d

    @property
    def declination_sigma(self) -> float:
        return math.sqrt(max(self._dd, 0.0))

    @property
    def covariance5(self) -> np.ndarray:
        """The 5×5 covariance of [x, y, z, χ, D]."""
        p = np.zeros((5, 5))
        p[:4, :4] = self.track._covs[-1]
        p[:4, 4] = p[4, :4] = self._pd
        p[4, 4] = self._dd
        return p

    @property
    def heading_aligned(self) -> bool:
        """Whether χ is a true heading (an aid aligned it) rather than the module's initial frame."""
        return self._aligned

    # -- input -------------------------------------------------------------------------

    def add_fixes(self, times_s: Iterable[float], north_east: Iterable[Iterable[float]]) -> None:
        """Queue GPS fixes: times [s] on the receiver's clock and positions (n, ≥2) [m] north, east
        of the first fix. Each is applied when the first step at or after its time arrives."""
        for t, p in zip(times_s, north_east, strict=True):
            self.add_fix(float(t), p)

    def add_fix(self, time_s: float, north_east: Iterable[float]) -> None:
        """Queue one fix (see :meth:`add_fixes`); fixes must come in time order."""
        t = float(time_s) + self.settings.gps_offset_s
        if self._fix_times and t < self._fix_times[-1]:
            raise ValueError(f"fix at {time_s} s is older than the one before ({self._fix_times[-1]} s)")
        pos = np.asarray(list(north_east), dtype=np.float64)[:2]
        if pos.shape != (2,) or not np.isfinite(pos).all():
            raise ValueError(f"a fix needs finite north and east, got {pos}")
        self._fix_times.append(t)
        self._fixes.append(pos)

    def add(self, step, swing_time: float = math.nan, states: Mapping[int, np.ndarray] | None = None
            ) -> StepOutcome:
        """Sum one step, then apply the aids its packet's *states* and the queued fixes allow."""
        reading = stance_reading(states) if states is not None else None
        time_s = self._clock.seconds(states)
        return self.add_step(step.dx, step.dp, step.counter, swing_time, reading=reading, time_s=time_s)

    def add_step(self, dx, dp, counter, swing_time: float = math.nan, *,
                 reading: StanceReading | None = None, time_s: float = math.nan) -> StepOutcome:
        """Sum a step given as arrays (:meth:`StepTracker.add_step`), with its stance *reading*
        and module time *time_s* [s], and apply the aids."""
        prev = self.track._poses[-1]
        outcome = super().add_step(dx, dp, counter, swing_time)
        if outcome is StepOutcome.DUPLICATE:
            return outcome
        # cov(pose, D) through the step: the pose's Jacobian; D does not move
        self._pd = step_jacobian(float(prev[3]), np.asarray(dx, dtype=np.float64)) @ self._pd
        if math.isfinite(time_s):
            self._time = time_s
        self.step_times.append(time_s)
        if self.settings.compass:
            self._compass(reading, np.asarray(dx, dtype=np.float64))
        if self.settings.gps:
            self._gps_until(self._time)
        return outcome

    # -- time --------------------------------------------------------------------------

    # -- the aids ----------------------------------------------------------------------

    def _compass(self, reading: StanceReading | None, dx: np.ndarray) -> None:
        s = self.settings
        if reading is None:
            self.fusion.compass_skipped += 1
            return
        moved = is_motion_step(dx)
        if self._aligned and s.compass_mode == "step" and not moved:
            self.fusion.compass_skipped += 1
            return
        field_b = reading.field_board
        if s.mag_calibration is not None:
            field_b = s.mag_calibration.apply(field_b)
        psi = compass_heading(field_b, reading.rotation)
        if not self._aligned:
            chi = psi + self._d
            self._align(chi, s.compass_sigma_rad ** 2 + self._dd, cov_with_d=self._dd)
            self.fusion.heading_aligned_by = "compass"
            return
        h = np.array([0.0, 0.0, 0.0, 1.0, -1.0])
        pose = self.track._poses[-1]
        innovation = wrap_angle(psi - (pose[3] - self._d))
        self._update(h, innovation, s.compass_sigma_rad ** 2)
        self.fusion.compass_updates += 1
        self.fusion.compass_innovations.append((len(self.track), innovation))

    def _gps_until(self, now: float) -> None:
        s = self.settings
        while self._next_fix < len(self._fix_times) and self._fix_times[self._next_fix] <= now:
            t, pos = self._fix_times[self._next_fix], self._fixes[self._next_fix]
            self._next_fix += 1
            if not self._origin_set:
                # the first fix is the origin: the start lies there, within the receiver's σ
                self._origin_set = True
                cov = self.track._covs[-1]
                cov[0, 0] += s.gps_receiver_sigma_m ** 2
                cov[1, 1] += s.gps_receiver_sigma_m ** 2
                self._first_fix = pos
                continue
            if not self._aligned:
                if not self._align_by_course(pos):
                    self.fusion.gps_before_alignment += 1
                    continue
            if t - self._last_gps_update < s.gps_interval_s:
                self.fusion.gps_skipped += 1
                continue
            self._last_gps_update = t
            pose = self.track._poses[-1]
            for axis in (0, 1):
                h = np.zeros(5)
                h[axis] = 1.0
                self._update(h, float(pos[axis] - pose[axis]), s.gps_sigma_m ** 2)
            self.fusion.gps_updates += 1

    def _align_by_course(self, fix: np.ndarray) -> bool:
        """Turn the track onto the GPS course once the receiver moved far enough (no compass)."""
        s = self.settings
        gps = fix - self._first_fix
        dr = self.track._poses[-1][:2] - self.track._poses[0][:2]
        distance = float(np.hypot(*gps))
        if distance < s.gps_align_distance_m or float(np.hypot(*dr)) < 0.5 * s.gps_align_distance_m:
            return False
        turn = math.atan2(gps[1], gps[0]) - math.atan2(dr[1], dr[0])
        sigma = math.sqrt(2.0) * s.gps_receiver_sigma_m / distance
        self._align(float(self.track._poses[-1][3]) + turn, sigma ** 2, cov_with_d=0.0)
        self.fusion.heading_aligned_by = "gps"
        return True

    def _align(self, chi: float, var_chi: float, *, cov_with_d: float) -> None:
        """Rotate the whole track about its start so that the current heading is *chi*; the
        heading's variance becomes *var_chi* and its covariance with D *cov_with_d*."""
        track = self.track
        turn = wrap_angle(chi - float(track._poses[-1][3]))
        r = rotation_z(turn)
        start = track._poses[0][:3].copy()
        for k in range(len(track._poses)):
            p = track._poses[k].copy()
            p[:3] = start + r @ (p[:3] - start)
            p[3] += turn
            track._poses[k] = p
            c = track._covs[k].copy()
            c[:3, :3] = r @ c[:3, :3] @ r.T
            c[:3, 3] = r @ c[:3, 3]
            c[3, :3] = c[:3, 3]
            track._covs[k] = c
        cov = track._covs[-1]
        cov[3, :] = cov[:, 3] = 0.0
        cov[3, 3] = var_chi
        self._pd = np.zeros(4)
        self._pd[3] = cov_with_d
        self._aligned = True

    def _update(self, h: np.ndarray, innovation: float, r: float) -> None:
        """A scalar Kalman update of [x, y, z, χ, D]; the track's last row takes the result."""
        p = self.covariance5
        ph = p @ h
        s = float(h @ ph) + r
        k = ph / s
        state = np.empty(5)
        state[:4] = self.track._poses[-1]
        state[4] = self._d
        state = state + k * innovation
        # Joseph form keeps P symmetric and positive
        i_kh = np.eye(5) - np.outer(k, h)
        p = i_kh @ p @ i_kh.T + r * np.outer(k, k)
        p = 0.5 * (p + p.T)
        self.track._poses[-1] = state[:4]
        self.track._covs[-1] = p[:4, :4]
        self._pd = p[:4, 4].copy()
        self._dd = float(p[4, 4])
        self._d = float(state[4])

    def pending_fixes(self) -> int:
        """Fixes queued whose time no step has reached yet."""
        return len(self._fix_times) - self._next_fix

    def __repr__(self) -> str:
        return (f"FusionTracker({self.track!r}, D={math.degrees(self._d):.2f}°, "
                f"compass {self.fusion.compass_updates}, gps {self.fusion.gps_updates})")
