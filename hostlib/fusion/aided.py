"""The heading aids on a tracker's filter: the per-step compass, GPS fixes, the declination, and the
aid states' process noise.

:class:`AidedFilter` applies the aids of :class:`~hostlib.fusion.settings.FusionSettings` to a
:class:`~hostlib.fusion.core.StateFilter` whose blocks are one or more feet's poses (``pose``, or
``left`` and ``right``), each module's errors (``errors``, or ``errors.left`` and ``errors.right``)
and the aid states of :mod:`hostlib.fusion.aid_states` (``gps_bias``, ``deviation``,
``declination``). It addresses them by name only: :attr:`AidedFilter.pose_blocks` says which blocks
are poses, and a tracker gives what only it knows — the point a GPS fix measures
(``_gps_rows()``), how to turn its kept history with the frame
(``_rotate_frame()``) and how far the measured point has travelled
(``_travelled()``).

For each step a tracker calls, with the local deviation held, ``_walk_deviation()``
with the distance walked, then ``_compass_step()`` with the step's compass heading,
and ``_gps_until()`` with the step's module time (which also carries the receiver's
bias, if held, on to it).

**Aligning two headings.** The first compass reading (or the GPS course) gives one heading χ_k;
every pose turns with it about the start. Another heading χ_j was known relative to χ_k only: it
becomes χ_k + (χ_j − χ_k), with the variance of the reading plus that of the difference. With one
heading this is the single-foot rule: χ takes the reading's variance. The headings' covariances
with the other states are dropped, but for D and d (which the reading measures against) and the
modules' errors (χ_j's covariance with them is that of χ_j − χ_k, which the reading leaves; with
one heading that difference is 0).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections import deque
from collections.abc import Iterable

import numpy as np

from ..aids.compass import wrap_angle
from ..aids.field_check import level_field
from ..calibration.magcal import MagCalibration
from .aid_events import AidEvent, AidObserver
from .compass_dip import DipAid
from .compass_swing import swing_basis
from .compass_trust import disturbance_ut, field_check, weighs_uncalibrated
from .core import StateFilter
from .gauss_markov import transition
from .hard_iron import iron_heading, iron_heading_sigma
from .settings import FusionSettings, FusionStats

__all__ = ["AidedFilter"]


class AidedFilter(DipAid, ABC):
    """The aids (module docstring) on the filter :attr:`filter` of a tracker whose poses are the
    blocks :attr:`pose_blocks` and whose modules' errors are :attr:`error_blocks`."""

    filter: StateFilter
    aid_settings: FusionSettings
    pose_blocks: tuple[str, ...]
    error_blocks: tuple[str, ...] = ()
    #: 1σ [rad] of the heading the first compass reading aligns (None: the compass's own σ_c)
    _align_sigma_rad: float | None = None

    def _init_aids(self) -> None:
        s = self.aid_settings
        self.fusion = FusionStats()
        self._aligned = not (s.compass or s.gps)
        # the fixes queued and not applied yet, (time [s], north-east [m]) in time order: an applied
        # fix is let go (a receiver's fix a second over a long walk would otherwise pile up)
        self._queued_fixes: deque[tuple[float, np.ndarray]] = deque()
        self._last_fix_time = -math.inf  # the latest fix queued [s]
        self._origin_set = False
        self._first_fix = np.zeros(2)
        self._last_gps_update = -math.inf
        self._bias_time: float | None = None  # the module time b was carried to (None: not yet)
        self._aid_observers: list[AidObserver] = []
        #: 1σ [rad] an uncalibrated compass is weighed for its unknown hard iron (0: it is not),
        #: and the horizontal field [µT] it was worked out with (NaN: not yet)
        self.iron_weight_rad = 0.0
        self.iron_weight_horizontal_ut = math.nan
        #: weighed, but no horizontal field to work the weight out with until the first reading
        self.iron_weight_pending = False
        self._weigh_uncalibrated(None)
        self._swing_start = math.nan  # module time of the compass's first calibrated reading [s]

    # -- what a tracker gives -----------------------------------------------------------

    @abstractmethod
    def _gps_rows(self) -> np.ndarray:
        """The (2, n) rows of the point a fix measures (north, east)."""

    @abstractmethod
    def _rotate_frame(self, turn: float) -> None:
        """Turn every pose, and the history kept of them, about the start by *turn* [rad]."""

    @abstractmethod
    def _travelled(self) -> np.ndarray:
        """The horizontal displacement of the measured point since the start."""

    @abstractmethod
    def __len__(self) -> int:
        """The steps fused."""

    def _compass_calibration(self, pose: str) -> MagCalibration | None:
        """The magnetometer calibration the compass of block *pose* reads with."""
        return self.aid_settings.mag_calibration

    def _module_seconds(self) -> float:
        """The module time [s] of the step being fused (NaN: the tracker does not keep one)."""
        return math.nan

    # -- where the aids look ------------------------------------------------------------

    def _heading_indices(self) -> list[int]:
        return [self.filter.index(pose, 3) for pose in self.pose_blocks]

    def _origin_rows(self) -> np.ndarray:
        """The rows of a shift of the whole frame: every pose's north and east."""
        return np.stack([self.filter.row({(pose, axis): 1.0 for pose in self.pose_blocks})
                         for axis in (0, 1)])

    def _gps_bias_rows(self) -> np.ndarray:
        """The (2, n) rows of the receiver's bias [b_n, b_e] (held)."""
        return np.stack([self.filter.row({("gps_bias", axis): 1.0}) for axis in (0, 1)])

    # -- state ------------------------------------------------------------------------

    @property
    def declination(self) -> float:
        """The declination estimate D [rad], east positive."""
        return float(self.filter.x[self.filter.index("declination")])

    @property
    def declination_sigma(self) -> float:
        return self.filter.sigma("declination")

    @property
    def deviation(self) -> float | None:
        """The estimate of the local compass deviation d [rad] where the last step ended, east
        positive as D (None: not held, :attr:`FusionSettings.compass_deviation`)."""
        return float(self.filter.mean("deviation")[0]) if "deviation" in self.filter else None

    @property
    def deviation_sigma(self) -> float | None:
        """The 1σ of :attr:`deviation` [rad] (None: not held)."""
        return self.filter.sigma("deviation") if "deviation" in self.filter else None

    @property
    def gps_bias(self) -> np.ndarray | None:
        """The estimate of the receiver's bias [north, east] [m] at the last step's time (None: not
        held, :attr:`FusionSettings.gps_bias`): a fix is the position plus it."""
        return self.filter.mean("gps_bias") if "gps_bias" in self.filter else None

    @property
    def gps_bias_sigma(self) -> np.ndarray | None:
        """The 1σ [m] of :attr:`gps_bias`, north and east (None: not held)."""
        if "gps_bias" not in self.filter:
            return None
        return self.filter.sigmas("gps_bias")

    @property
    def heading_aligned(self) -> bool:
        """Whether χ is a true heading (an aid aligned it) rather than the module's initial frame."""
        return self._aligned

    # -- input ------------------------------------------------------------------------

    def add_fixes(self, times_s: Iterable[float], north_east: Iterable[Iterable[float]]) -> None:
        """Queue GPS fixes: times [s] on the receiver's clock and positions (n, ≥2) [m] north, east
        of the first fix. Each is applied when the first step at or after its time arrives."""
        for t, p in zip(times_s, north_east, strict=True):
            self.add_fix(float(t), p)

    def add_fix(self, time_s: float, north_east: Iterable[float]) -> None:
        """Queue one fix (see :meth:`add_fixes`); fixes must come in time order."""
        t = float(time_s) + self.aid_settings.gps_offset_s
        if t < self._last_fix_time:
            raise ValueError(f"fix at {time_s} s is older than the one before ({self._last_fix_time} s)")
        pos = np.asarray(list(north_east), dtype=np.float64)[:2]
        if pos.shape != (2,) or not np.isfinite(pos).all():
            raise ValueError(f"a fix needs finite north and east, got {pos}")
        self._queued_fixes.append((t, pos))
        self._last_fix_time = t

    def observe_aids(self, fn: AidObserver) -> AidObserver:
        """Call *fn(event)* for every compass reading and GPS fix the filter takes, with what became
        of it (:class:`~hostlib.fusion.aid_events.AidEvent`; called under the tracker's lock, in the
        thread that sums the step); returns *fn*."""
        if not callable(fn):
            raise TypeError(f"an aid observer must be callable, got {fn!r}")
        self._aid_observers.append(fn)
        return fn

    def _tell(self, aid: str, outcome: str, pose: str, reading=None, innovation: float = math.nan,
              time_s: float = math.nan, at: np.ndarray | None = None) -> None:
        """An :class:`~hostlib.fusion.aid_events.AidEvent` to the observers (none: nothing to do); *at*
        defaults to where block *pose* is."""
        if not self._aid_observers:
            return
        if at is None:
            k = self.filter.index(pose, 0)
            at = self.filter.x[k:k + 2]
        event = AidEvent(aid, outcome, len(self), pose, (float(at[0]), float(at[1])), reading,
                         float(innovation), self.declination, time_s)
        for fn in list(self._aid_observers):
            fn(event)

    def _tell_fix(self, outcome: str, fix: tuple[float, float], t: float) -> None:
        """A GPS fix to the observers, with where the filter has the point it measures (its
        innovation: how far apart the two are)."""
        if self._aid_observers:
            at = self._gps_rows() @ self.filter.x
            self._tell("gps", outcome, self.pose_blocks[0], fix, math.hypot(fix[0] - at[0], fix[1] - at[1]),
                       t, at)

    def pending_fixes(self) -> int:
        """Fixes queued whose time no step has reached yet."""
        return len(self._queued_fixes)

    # -- the aid states' process noise --------------------------------------------------

    def _walk_deviation(self, distance_m: float) -> None:
        """The local deviation d (held) after a walk of *distance_m* [m]: d ← φ d, its variance
        φ² var d + (1 − φ²) σ_d², its covariances with the rest φ times theirs (σ_d² with an
        uncalibrated compass's weight added, :meth:`_weigh_uncalibrated`)."""
        phi, q = transition(distance_m, self.aid_settings.compass_deviation.length_m,
                            self._deviation_variance())
        self.filter.decay("deviation", phi, q)
        self._walk_dip(distance_m)

    def _deviation_variance(self) -> float:
        """The local deviation's stationary variance: σ_d², plus the unknown iron's heading
        variance while an uncalibrated compass is weighed for it."""
        return self.aid_settings.compass_deviation.variance + self.iron_weight_rad ** 2

    def _weigh_uncalibrated(self, horizontal_ut: float | None) -> None:
        """Weigh the compass for an unknown hard iron (:mod:`hostlib.fusion.compass_trust`) when a
        module's compass is uncalibrated and its iron not learned: its heading error's σ
        atan(σ_b / H), H the WMM's horizontal intensity or else *horizontal_ut* (the first reading's;
        None and no WMM: wait for that reading). Held, the local deviation starts with that variance
        added (before any reading, it is correlated with nothing)."""
        s = self.aid_settings
        self.iron_weight_pending = False
        if not (s.compass and any(weighs_uncalibrated(s, self._compass_calibration(pose))
                                  for pose in self.pose_blocks)):
            self.iron_weight_rad = 0.0
            return
        if s.magnetic_field is not None:
            horizontal_ut = s.magnetic_field.horizontal_nt / 1000.0
        if horizontal_ut is None:
            self.iron_weight_pending = True
            return
        self.iron_weight_rad = iron_heading_sigma(s.uncalibrated_iron, horizontal_ut)
        self.iron_weight_horizontal_ut = float(horizontal_ut)
        if "deviation" in self.filter:
            self.filter.decay("deviation", 0.0, self._deviation_variance())

    def _compass_calibrated(self) -> None:
        """A calibration came for the compass (:meth:`FusionTracker.release_compass
        <hostlib.fusion.tracker.FusionTracker.release_compass>`): no more weight for an unknown
        iron; before any reading was used, the local deviation starts again from σ_d²."""
        weighed = self.iron_weight_rad > 0.0
        self._weigh_uncalibrated(self.iron_weight_horizontal_ut if weighed else None)
        if weighed and "deviation" in self.filter and self.fusion.compass_updates == 0:
            self.filter.decay("deviation", 0.0, self._deviation_variance())

    def _field_problem(self, pose: str, reading: tuple[np.ndarray, np.ndarray]) -> str | None:
        """Why the field of *reading* (calibrated board-frame field [µT], board → navigation
        rotation) of block *pose*'s compass is not the Earth's, or None (:func:`field_check
        <hostlib.fusion.compass_trust.field_check>`; nothing to check it against: None)."""
        s = self.aid_settings
        calibration = self._compass_calibration(pose)
        check = field_check(s, calibration)
        if check is None:
            return None
        field_b, rotation = reading
        if "hard_iron" in self.filter:
            field_b = np.asarray(field_b, dtype=np.float64) - self.filter.mean("hard_iron")
        horizontal = (s.magnetic_field.horizontal_nt / 1000.0 if s.magnetic_field is not None
                      else level_field(field_b, rotation)[2])
        return check.problem(field_b, rotation, disturbance_ut(s, calibration, horizontal))

    def _drift_gps_bias(self, now: float) -> None:
        """The receiver's bias b (held) carried on to module time *now* [s]: over Δt, b ← φ b, each
        axis's variance φ² var + (1 − φ²) σ_b², its covariances with the rest φ times theirs.
        The first call only starts b's clock: b is still its stationary prior."""
        if self._bias_time is None:
            self._bias_time = now
            return
        dt = now - self._bias_time
        if not dt > 0.0:
            return  # a fix that came late: b is already past its time, within a step
        self._bias_time = now
        self.filter.decay("gps_bias", *self.aid_settings.gps_bias.transition(dt))

    # -- the compass --------------------------------------------------------------------

    def _compass_step(self, psi: float | None, pose: str, moved: bool,
                      reading: tuple[np.ndarray, np.ndarray] | None = None) -> None:
        """A step's compass heading *psi* [rad] from magnetic north (None: no reading) measures the
        heading of block *pose* minus D (minus d, held); *moved*: the step moved the foot. *reading*
        (the calibrated board-frame field [µT] and the board → navigation rotation; None: not
        given) must pass the field check first (:meth:`_field_problem`). With the shoe's hard iron
        held, it gives the heading less the iron's estimate, and the reading measures the iron too
        (:func:`hostlib.fusion.hard_iron.iron_heading`)."""
        s = self.aid_settings
        g = None
        if psi is not None and reading is not None and "hard_iron" in self.filter:
            psi, g = iron_heading(*reading, self.filter.mean("hard_iron"))
        if psi is None:
            self.fusion.compass_skipped += 1
            self._tell("compass", "skipped", pose)
            return
        if not math.isfinite(psi):
            self.fusion.compass_refused += 1
            self._tell("compass", "refused", pose, psi)
            return
        if self._aligned and s.compass_mode == "step" and not moved:
            self.fusion.compass_skipped += 1
            self._tell("compass", "skipped", pose, psi)
            return
        problem = None if reading is None else self._field_problem(pose, reading)
        if problem is not None:
            self.fusion.compass_field_rejected += 1
            self.fusion.compass_field_first = self.fusion.compass_field_first or problem
            self._tell("compass", "rejected", pose, psi)
            return
        if self.iron_weight_pending and reading is not None:
            self._weigh_uncalibrated(level_field(*reading)[2])
        if not self._aligned:
            self._tell("compass", "aligned", pose, psi)
            self._align_by_compass(psi, pose, g)
            return
        f = self.filter
        x = f.x
        k, dec = f.index(pose, 3), f.index("declination")
        weights = {(pose, 3): 1.0, "declination": -1.0}
        if g is not None:  # ψ̂ − g b̂ = χ − D − d − g b: the iron's columns are −g
            weights.update({("hard_iron", axis): -float(g[axis]) for axis in range(3)})
        if "deviation" in f:
            weights["deviation"] = -1.0
            innovation = wrap_angle(psi - (x[k] - x[dec] - x[f.index("deviation")]))
        else:
            innovation = wrap_angle(psi - (x[k] - x[dec]))
        magnetic_heading = float(x[k] - x[dec])
        swing = self._swing_basis(pose, magnetic_heading)
        if swing is not None:  # the reading is less the swing B sin ψ_m + C cos ψ_m, too
            weights.update({("swing", i): -float(swing[i]) for i in range(2)})
            innovation = wrap_angle(innovation + float(swing @ f.mean("swing")))
        h, r = f.row(weights), self._reading_variance()
        gate = s.compass_gate_sigmas
        if gate is not None and innovation ** 2 > gate ** 2 * (float(h @ f.P @ h) + r):
            self.fusion.compass_rejected += 1
            self._tell("compass", "rejected", pose, psi, innovation)
            return
        self._tell("compass", "used", pose, psi, innovation)
        f.update(h, innovation, r)
        if swing is not None and s.compass_swing.dip and reading is not None:
            self._dip_step(reading, magnetic_heading)
        self.fusion.compass_updates += 1
        self.fusion.compass_innovations.append((len(self), innovation))

    def _swing_basis(self, pose: str, magnetic_heading: float) -> np.ndarray | None:
        """[sin ψ_m, cos ψ_m] at *magnetic_heading*, times what the swing has grown to since the
        compass's first calibrated reading (:meth:`~hostlib.fusion.compass_swing.CompassSwing.warming`),
        when block *pose*'s compass reads with a calibration and its swing is held
        (:mod:`hostlib.fusion.compass_swing`); else None."""
        if "swing" not in self.filter or self._compass_calibration(pose) is None:
            return None
        basis = swing_basis(magnetic_heading)
        t = self._module_seconds()
        if not math.isfinite(t):  # no time: the swing at its full size
            return basis
        if math.isnan(self._swing_start):
            self._swing_start = t
        return basis * self.aid_settings.compass_swing.warming(t - self._swing_start)

    @property
    def compass_swing(self) -> np.ndarray | None:
        """The estimate of a calibrated compass's swing [B, C] [rad] (None: not held)."""
        return self.filter.mean("swing") if "swing" in self.filter else None

    @property
    def compass_swing_sigma(self) -> np.ndarray | None:
        """The 1σ of :attr:`compass_swing` [rad] (None: not held)."""
        if "swing" not in self.filter:
            return None
        return self.filter.sigmas("swing")

    def _reading_variance(self) -> float:
        """A compass reading's own variance σ_c², plus an uncalibrated compass's weight when the
        local deviation, which holds it otherwise, is not held."""
        return self.aid_settings.compass_sigma_rad ** 2 + (
            0.0 if "deviation" in self.filter else self.iron_weight_rad ** 2)

    def _align_by_compass(self, psi: float, pose: str, g: np.ndarray | None = None) -> None:
        """The first reading aligns heading *pose*: χ ← ψ + D (+ d, held), with the reading's
        variance and D's (and d's) uncertainty and covariance; with the hard iron held (*g*: the
        reading's ∂ψ/∂b), χ ← ψ̂ + D + d + g (b − b̂), its uncertainty and covariances from all of
        them."""
        if g is not None:
            self._align_by_iron_compass(psi, pose, g)
            return
        f = self.filter
        x, p = f.x, f.P
        dec = f.index("declination")
        var_d = float(p[dec, dec])
        sigma = self._align_sigma_rad
        if sigma is None:
            sigma = math.sqrt(self._reading_variance())
        k = f.index(pose, 3)
        swing = self._swing_basis(pose, psi)
        if swing is not None:  # its estimate is 0 until a reading used it: its variance only
            sigma = math.sqrt(sigma ** 2 + float(swing @ f.covariance("swing") @ swing))
        if "deviation" in f:
            dev = f.index("deviation")
            var_dev, cov = float(p[dev, dev]), float(p[dev, dec])
            self._align(k, psi + float(x[dec]) + float(x[dev]), sigma ** 2 + var_d + var_dev + 2.0 * cov,
                        cov_with_d=var_d + cov, cov_with_deviation=var_dev + cov)
        else:
            self._align(k, psi + float(x[dec]), sigma ** 2 + var_d, cov_with_d=var_d)
        self.fusion.heading_aligned_by = "compass"

    def _align_by_iron_compass(self, psi: float, pose: str, g: np.ndarray) -> None:
        """:meth:`_align_by_compass` with the hard iron held: χ ← ψ̂ + c·s, c the coefficients of
        D, d (held) and b (g) over those states s (their estimate's part is in ψ̂ already)."""
        f = self.filter
        c = f.row({"declination": 1.0, **({"deviation": 1.0} if "deviation" in f else {}),
                   **{("hard_iron", axis): float(g[axis]) for axis in range(3)}})
        sigma = self._align_sigma_rad
        if sigma is None:
            sigma = self.aid_settings.compass_sigma_rad
        pc = f.P @ c
        x = f.x
        dev = f.index("deviation") if "deviation" in f else None
        chi = psi + float(x[f.index("declination")]) + (0.0 if dev is None else float(x[dev]))
        iron = f.indices("hard_iron")
        self._align(f.index(pose, 3), chi, sigma ** 2 + float(c @ pc),
                    cov_with_d=float(pc[f.index("declination")]),
                    cov_with_deviation=None if dev is None else float(pc[dev]), cov_with_iron=pc[iron])
        self.fusion.heading_aligned_by = "compass"

    # -- GPS ----------------------------------------------------------------------------

    def _gps_until(self, now: float) -> None:
        """Apply the queued fixes whose time module time *now* [s] has reached (the receiver's
        bias, held, carried to each fix's time, then to *now*)."""
        bias = self.aid_settings.gps_bias
        while self._queued_fixes and self._queued_fixes[0][0] <= now:
            t, pos = self._queued_fixes.popleft()
            if bias is not None:
                self._drift_gps_bias(t)
            self._gps_fix(t, pos)
        if bias is not None:
            self._drift_gps_bias(now)

    def _gps_fix(self, t: float, pos: np.ndarray) -> None:
        """One fix at module time *t*: the origin, the course's alignment, or an update of the
        measured point (plus the bias, held)."""
        s = self.aid_settings
        fix = (float(pos[0]), float(pos[1]))
        if not self._origin_set:
            self._tell_fix("origin", fix, t)
            self._origin_set = True
            self._place_origin()
            self._first_fix = pos
            return
        if not self._aligned and not self._align_by_course(pos):
            self.fusion.gps_before_alignment += 1
            self._tell_fix("before alignment", fix, t)
            return
        if t - self._last_gps_update < s.gps_update_interval_s:
            self.fusion.gps_skipped += 1
            self._tell_fix("skipped", fix, t)
            return
        self._last_gps_update = t
        rows = self._gps_rows()
        self._tell_fix("used", fix, t)
        if s.gps_bias is None:
            sigma = s.gps_sigma_m
        else:
            rows, sigma = rows + self._gps_bias_rows(), s.gps_bias.white_sigma_m
        for axis, h in enumerate(rows):
            self.filter.update(h, float(pos[axis] - h @ self.filter.x), sigma ** 2)
        self.fusion.gps_updates += 1

    def _place_origin(self) -> None:
        """The first fix is the origin, and the start lies at it less the fix's error (the track's
        estimate stays: it starts at 0). Without the bias held, that error is white of the
        receiver's σ: every position's variance grows by σ². With it held the error is b₀ + w₀,
        b₀ the bias now: every pose moves by the translation −(b₀ + w₀), x ← x − Oᵀ (b + w) (O the
        rows of :meth:`_origin_rows`; b's estimate is still 0, so the track's stays), and
        P ← T P Tᵀ + σ_w² Oᵀ O with T = I − Oᵀ B (B: b's rows): each position's variance grows
        by var b₀ + σ_w² and its covariance with b is −var b₀. A later fix, whose b is still
        mostly b₀, then measures the walk since the first fix far better than either fix
        measures a position."""
        s = self.aid_settings
        f = self.filter
        if s.gps_bias is None:
            p = f.P.copy()
            for row in self._origin_rows():
                p += s.gps_receiver_sigma_m ** 2 * np.outer(row, row)
            f.P = p
        else:
            o = self._origin_rows()
            t = np.eye(len(f)) - o.T @ self._gps_bias_rows()
            x = t @ f.x
            p = t @ f.P @ t.T + s.gps_bias.white_sigma_m ** 2 * (o.T @ o)
            f.x, f.P = x, 0.5 * (p + p.T)

    def _align_by_course(self, fix: np.ndarray) -> bool:
        """Turn the track onto the GPS course once the receiver moved far enough (no compass)."""
        s = self.aid_settings
        gps = fix - self._first_fix
        dr = self._travelled()
        distance = float(np.hypot(*gps))
        if distance < s.gps_align_distance_m or float(np.hypot(*dr)) < 0.5 * s.gps_align_distance_m:
            return False
        turn = math.atan2(gps[1], gps[0]) - math.atan2(dr[1], dr[0])
        sigma = math.sqrt(2.0) * s.gps_receiver_sigma_m / distance
        k = self._heading_indices()[0]
        self._align(k, float(self.filter.x[k]) + turn, sigma ** 2, cov_with_d=0.0,
                    cov_with_deviation=None if s.compass_deviation is None else 0.0)
        self.fusion.heading_aligned_by = "gps"
        return True

    # -- alignment ----------------------------------------------------------------------

    def _align(self, k: int, chi: float, var_chi: float, *, cov_with_d: float,
               cov_with_deviation: float | None = None, cov_with_iron: np.ndarray | None = None) -> None:
        """Turn every pose about the start so that heading index *k* is *chi*, with variance
        *var_chi* and covariance *cov_with_d* with D and *cov_with_deviation* with the local
        deviation d (None: not held) (module docstring: the other headings follow it). The
        receiver's bias, held, is north and east and its covariance with the poses is the origin's
        translation, which turning the frame about the start does not turn: it stays as it was."""
        f = self.filter
        before = f.P.copy()
        self._rotate_frame(wrap_angle(chi - float(f.x[k])))
        p = f.P.copy()
        if "gps_bias" in f:
            bias = f.indices("gps_bias")
            p[bias, :] = before[bias, :]
            p[:, bias] = before[:, bias]
        dec = f.index("declination")
        hs = self._heading_indices()
        ones = np.ones(len(hs))
        b = np.eye(len(hs))
        b[:, hs.index(k)] -= 1.0  # χ_j' = χ_k' + (χ_j − χ_k)
        hh = b @ p[np.ix_(hs, hs)] @ b.T + var_chi * np.outer(ones, ones)
        hd = b @ p[hs, dec] + ones * cov_with_d
        if cov_with_deviation is not None:
            dev = f.index("deviation")
            hdev = b @ p[hs, dev] + ones * cov_with_deviation
        if "hard_iron" in f:  # the course's alignment knows nothing of the iron: 0
            iron = f.indices("hard_iron")
            hiron = b @ p[np.ix_(hs, iron)] + np.outer(ones, np.zeros(3) if cov_with_iron is None
                                                       else cov_with_iron)
        carried = f.indices(*self.error_blocks) if len(hs) > 1 else []
        hc = b @ p[np.ix_(hs, carried)]
        p[hs, :] = 0.0
        p[:, hs] = 0.0
        p[np.ix_(hs, hs)] = hh
        p[np.ix_(hs, carried)] = hc
        p[np.ix_(carried, hs)] = hc.T
        p[hs, dec] = hd
        p[dec, hs] = hd
        if cov_with_deviation is not None:
            p[hs, dev] = hdev
            p[dev, hs] = hdev
        if "hard_iron" in f:
            p[np.ix_(hs, iron)] = hiron
            p[np.ix_(iron, hs)] = hiron.T
        f.P = p
        self._aligned = True
