"""The host-side fusion filter: the step track with a per-step compass, declination and GPS fixes.

The module keeps its ZUPT INS and hands the host one step at a time (:mod:`hostlib.track.steps`).
:class:`FusionTracker` sums the steps exactly as :class:`~hostlib.track.steps.StepTracker` does — it
*is* one — and holds one more state, the magnetic declination D, so that its state is
``[x, y, z, χ, D]`` with a 5×5 covariance. On top of the summation it applies, each switched on
by :class:`FusionSettings` (shared/spec/aids.md §1–2, NavShoe):

* **the per-step compass** — at each step's end of stance the packet's magnetometers and attitude
  give a heading from magnetic north, ψ_c (:mod:`hostlib.aids.compass`), which measures ``χ − D`` with
  variance σ_c² (the local deviation, not the sensor noise: tens of degrees indoors). One reading
  per step that moved the foot; the module's resets while the wearer stands still carry no
  update (their readings are the same reading again, and the module's ZARU holds the heading).
  The first reading aligns the heading: χ ← ψ_c + D, with variance σ_c² + var D. While the
  shoe's iron is being calibrated in situ (:mod:`hostlib.calibration.wiggle`) the compass waits
  (:meth:`FusionTracker.hold_compass`); the calibration then applies, and the first reading after
  it aligns the heading with the calibration's σ (NavShoe: 10°,
  :meth:`FusionTracker.release_compass`);
* **GPS fixes** — north and east of a fix, about the first fix, measure ``[x, y]`` with an
  inflated variance σ_gps² (a receiver's errors are correlated over minutes, so fixes a second
  apart are not independent measurements). A fix is applied at the first step at or after its
  time (at most a step late: a metre against σ_gps of many). The first fix places the origin: the
  start is uncertain by the receiver's own σ. Without a compass the first heading comes from the
  GPS course: once the receiver has moved :attr:`FusionSettings.gps_align_distance_m` from the
  first fix, the track turns onto it, with σ = √2 σ_rx / distance;
* **declination** — a state with a prior (the World Magnetic Model at the first fix, chosen by
  the caller: :func:`hostlib.aids.declination.declination_deg`) and σ_D (NavShoe: 15°) while GPS is
  used; the compass then measures χ − D and GPS χ alone, so D becomes observable. Without GPS it
  is a constant.

With every aid off the track is :class:`~hostlib.track.steps.StepTracker`'s, bit for bit: the
summation is the same code, and D is uncorrelated with the pose until an aid correlates it.

**The module's errors** (:attr:`FusionSettings.module_errors`, :mod:`hostlib.fusion.module_errors`): a
step-length scale s, a climb c per metre and a turn scale k, held as three more states before D
(``[x, y, z, χ, s, c, k, D]``), and with a heading drift prior the drift rate r [rad/s] as a
fourth (``[x, y, z, χ, s, c, k, r, D]``: each step's heading turns by r Δt, Δt its duration from
the steps' module times; a step without a time, or the first, drifts by nothing). Without an aid
they leave the track as it is and widen its covariance along the displacement, in height, with
the angle turned and with the time walked, as a module's systematic errors do; the aids make them
observable, and the steps after are corrected by what they taught.

**The local deviation** (:attr:`FusionSettings.compass_deviation`, :mod:`hostlib.fusion.deviation`):
a compass reading's error is mostly the deviation d of the field where the foot stands, which is
the same for readings a step apart. Held, d is one more state just before D
(``[x, y, z, χ, d, D]``, or ``[x, y, z, χ, s, c, k, d, D]`` with the module's errors), a
Gauss–Markov process in the distance walked: each step of horizontal length Δs takes
d ← φ d and adds (1 − φ²) σ_d² to its variance, φ = exp(−Δs / ℓ); it starts at 0 with variance
σ_d². The compass then measures ``χ − D − d``, and σ_c is only the reading's own, white error
(the chips' noise and the attitude: about 1.5°, :data:`hostlib.fusion.deviation.WHITE_SIGMA_RAD`). The
first reading aligns χ ← ψ_c + D + d, correlated with D and d. Not held, the filter is the one
without it, bit for bit.

**The receiver's bias** (:attr:`FusionSettings.gps_bias`, :mod:`hostlib.fusion.gps_bias`): a receiver's
error is mostly an offset b = [b_north, b_east] that wanders over minutes. Held, b is two more
states before d (``[x, y, z, χ, b_n, b_e, D]``; with every state held
``[x, y, z, χ, s, c, k, b_n, b_e, d, D]``), a Gauss–Markov process in the module's time: over Δt,
b ← φ b and (1 − φ²) σ_b² is added to each axis's variance, φ = exp(−Δt / τ). A fix then
measures ``[x, y] + b`` with only its white σ_w, and every fix is used (the inflation is not
needed: fixes a second apart share their b, and the filter knows it). The first fix still places
the origin, but the start lies at −(b₀ + w₀) from it: every pose moves by that unknown
translation, so each position's variance grows by var b₀ + σ_w² and its covariance with b is
−var b₀ (the next fixes, sharing most of b₀, then know the positions relative to the first far
better than either absolutely). b is north and east: when an aid turns the frame about the start,
its covariance with the poses (the origin's translation) does not turn. The GPS course aligns the
heading as without it. Not held, the filter is the one without it, bit for bit.

The aids themselves are :class:`AidedFilter`, which does not care how many poses the state
holds: :class:`hostlib.fusion.feet.TwoFeetTracker` applies the same aids to both feet's poses and D. A
fix's north and east are applied one after the other, the second with the state the first left.

Time: a step packet of the fusion set-up carries T_INT_K (the module's 64 MHz cycle counter when
the step's last measurement was taken); the tracker unwraps it into seconds since the module's
power-on (:class:`~hostlib.link.module_clock.ModuleClock`). Fix times are seconds since the receiver started
talking (:func:`hostlib.aids.gps.seconds_since`); the two clocks are taken to start together, as the
emulator's receiver and module do (:attr:`FusionSettings.gps_offset_s` shifts the fixes).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, replace

import numpy as np

from ..aids.compass import StanceReading, compass_heading, stance_reading, wrap_angle
from ..calibration.magcal import MagCalibration
from ..events import StepOutcome
from ..link.module_clock import ModuleClock
from ..track.steps import StepTracker, is_motion_step, rotation_z, step_jacobian
from .deviation import CompassDeviation
from .gauss_markov import decay
from .gps_bias import GpsBias
from .module_errors import ModuleErrors, through_step

__all__ = ["AidIndices", "AidedFilter", "FusionSettings", "FusionStats", "FusionTracker"]

@dataclass(frozen=True)
class FusionSettings:
    """Which aids the :class:`FusionTracker` applies, and how much it trusts them."""

    #: per-step compass updates on
    compass: bool = False
    #: 1σ of one compass reading [rad]: the local deviation. Our default is indoor: the emulator's
    #: building deviation (5 µT RMS per axis against a 15.5 µT horizontal field) is ≈ 18°. With
    #: :attr:`compass_deviation` held, only the reading's own white error beyond the deviation (the
    #: chips' noise, the attitude): about 1.5° (:data:`hostlib.fusion.deviation.WHITE_SIGMA_RAD`)
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
    #: independent). 3 m · √(2τ / 10 s) ≈ 15 m (NavShoe: 20 m for a 6 m receiver). Not used with
    #: :attr:`gps_bias` held: a fix's σ is then its white part
    gps_sigma_m: float = 15.0
    #: seconds between GPS updates (fixes in between are skipped, counted); None: 10 s, what the
    #: inflated σ assumes, or with :attr:`gps_bias` held every fix (:attr:`gps_update_interval_s`)
    gps_interval_s: float | None = None
    #: added to every fix time [s] to put it on the module's clock
    gps_offset_s: float = 0.0
    #: without a compass, the GPS course aligns the heading after this distance [m] from the first fix
    gps_align_distance_m: float = 50.0
    #: the declination prior D₀ [rad] (east positive) and its 1σ while GPS is used
    declination_rad: float = 0.0
    declination_sigma_rad: float = math.radians(15.0)
    #: the module's step-length scale, climb and turn scale (and, with its prior, heading drift rate)
    #: as states (:mod:`hostlib.fusion.module_errors`; None: not held, and the covariance is the steps' own)
    module_errors: ModuleErrors | None = None
    #: the local compass deviation d as a state, correlated over the distance walked
    #: (:mod:`hostlib.fusion.deviation`: :data:`~hostlib.fusion.deviation.OUTDOORS`,
    #: :data:`~hostlib.fusion.deviation.INDOORS`;
    #: None: not held, each reading's deviation is in σ_c as white noise)
    compass_deviation: CompassDeviation | None = None
    #: the receiver's correlated error b as states, a Gauss–Markov process in time
    #: (:mod:`hostlib.fusion.gps_bias`; None: not held, a fix's error is white, of σ :attr:`gps_sigma_m`)
    gps_bias: GpsBias | None = None

    @property
    def gps_update_interval_s(self) -> float:
        """The seconds between GPS updates: :attr:`gps_interval_s` if given; else 10 s with the
        white model (the interval its inflated σ is worked out for) and 0 with :attr:`gps_bias`
        held: every fix, since the filter knows what fixes a second apart share, and each still
        brings its white part and the bias's news (two scalar updates a fix)."""
        if self.gps_interval_s is not None:
            return self.gps_interval_s
        return 10.0 if self.gps_bias is None else 0.0

    def __post_init__(self) -> None:
        if self.compass_mode not in ("step", "every-reset"):
            raise ValueError(f"compass_mode must be 'step' or 'every-reset', not {self.compass_mode!r}")
        for name in ("compass_sigma_rad", "gps_sigma_m", "gps_receiver_sigma_m", "gps_align_distance_m"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be positive")
        if self.gps_interval_s is not None and not self.gps_interval_s >= 0:
            raise ValueError(f"gps_interval_s must be ≥ 0 s (or None), not {self.gps_interval_s}")


@dataclass
class FusionStats:
    """What the aids did."""

    compass_updates: int = 0
    compass_skipped: int = 0  #: readings not used (standing resets; no reading in the packet)
    gps_updates: int = 0
    gps_skipped: int = 0  #: fixes between updates (:attr:`FusionSettings.gps_update_interval_s`)
    gps_before_alignment: int = 0  #: fixes that arrived before the heading was aligned
    heading_aligned_by: str = ""  #: "compass", "gps" or "" (not aligned: the module's frame)
    #: (step index, innovation [rad]) of every compass update, for consistency checks
    compass_innovations: list[tuple[int, float]] = field(default_factory=list)


@dataclass(frozen=True)
class AidIndices:
    """Where the aid states sit in a filter's state, counted from its end: they come last, after
    the poses (and the modules' errors, if held), as ``[b_n, b_e,] [d,] D``."""

    #: the declination D: always held, always last
    declination: int = -1
    #: the local compass deviation d, just before D (None: not held)
    deviation: int | None = None
    #: the receiver's bias [b_north, b_east], before d (None: not held)
    gps_bias: tuple[int, int] | None = None

    @classmethod
    def of(cls, settings: FusionSettings) -> AidIndices:
        """The aid states *settings* hold."""
        deviation = -2 if settings.compass_deviation is not None else None
        east = -2 if deviation is None else -3  # b_e: just before d, or before D
        gps_bias = (east - 1, east) if settings.gps_bias is not None else None
        return cls(-1, deviation, gps_bias)

    @property
    def count(self) -> int:
        """How many aid states there are."""
        return 1 + (self.deviation is not None) + 2 * (self.gps_bias is not None)


class AidedFilter:
    """The aids of :class:`FusionSettings` on a filter whose state is poses and, last, the declination D.

    The aids do not care how many poses the state holds: :class:`FusionTracker` holds one foot's
    ``[x, y, z, χ, D]``, :class:`hostlib.fusion.feet.TwoFeetTracker` both feet's and D. With
    :attr:`FusionSettings.compass_deviation` the local deviation d sits just before D, one for
    all the poses (they walk through one field); with :attr:`FusionSettings.gps_bias` the
    receiver's bias [b_n, b_e] before that, one for the walker's receiver. :attr:`_aid_indices`
    says where they are. A subclass keeps the state and gives the aids these views of it:

    * :meth:`_aid_state` / :meth:`_aid_set_state`: the state vector (b and d, if held, then D
      last) and its covariance;
    * :attr:`_heading_indices`: where the headings χ are in it (one per foot), and
      :meth:`_heading_carried` the states whose covariance with the headings an alignment keeps
      relative to the aligned one (below);
    * :meth:`_gps_rows`: the (2, n) rows of the point a fix measures (north, east), and
      :meth:`_origin_rows` those of a shift of the whole frame (every pose's x, y);
    * :meth:`_rotate_frame`: turn every pose (and the history kept of them) about the start;
    * :meth:`_travelled`: the horizontal displacement of the measured point since the start;
    * :attr:`aid_settings`: the :class:`FusionSettings`; ``len(self)``: the steps fused.

    It calls :meth:`_init_aids` in its ``__init__``, then for each step (with d held)
    :meth:`_walk_deviation` with the distance walked, :meth:`_compass_step` with the step's
    compass heading, and :meth:`_gps_until` with the step's module time (which also carries b, if
    held, on to it).

    **Aligning two headings.** The first compass reading (or the GPS course) gives one heading
    χ_k; every pose turns with it about the start. Another heading χ_j was known relative to χ_k
    only: it becomes χ_k + (χ_j − χ_k), with the variance of the reading plus that of the
    difference. With one heading this is the single-foot rule: χ takes the reading's variance.
    The headings' covariances with the other states are dropped, but for D and d (which the
    reading measures against) and those of :meth:`_heading_carried` (two feet's module errors:
    χ_j's covariance with them is that of χ_j − χ_k, which the reading leaves).
    """

    _heading_indices: tuple[int, ...] = (3,)
    #: 1σ [rad] of the heading the first compass reading aligns (None: the compass's own σ_c)
    _align_sigma_rad: float | None = None

    def _init_aids(self) -> None:
        s = self.aid_settings
        self.fusion = FusionStats()
        self._aligned = not (s.compass or s.gps)
        self._fix_times: list[float] = []
        self._fixes: list[np.ndarray] = []
        self._next_fix = 0
        self._origin_set = False
        self._first_fix = np.zeros(2)
        self._last_gps_update = -math.inf
        self._bias_time: float | None = None  # the module time b was carried to (None: not yet)

    # -- what a subclass gives --------------------------------------------------------

    @property
    def aid_settings(self) -> FusionSettings:
        """The aids this filter applies."""
        raise NotImplementedError

    def _aid_state(self) -> tuple[np.ndarray, np.ndarray]:
        """The state (b and d, if held, then D last) and its covariance, as copies."""
        raise NotImplementedError

    def _aid_set_state(self, x: np.ndarray, p: np.ndarray) -> None:
        raise NotImplementedError

    def _gps_rows(self) -> np.ndarray:
        raise NotImplementedError

    def _origin_rows(self) -> np.ndarray:
        raise NotImplementedError

    def _rotate_frame(self, turn: float) -> None:
        raise NotImplementedError

    def _travelled(self) -> np.ndarray:
        raise NotImplementedError

    def _heading_carried(self) -> list[int]:
        """The states whose covariance with each heading χ_j an alignment keeps as that of
        χ_j − χ_k, χ_k the aligned heading (none: one heading, or none held)."""
        return []

    # -- state ------------------------------------------------------------------------

    @property
    def _aid_indices(self) -> AidIndices:
        """Where D, d and b are in the state (:class:`AidIndices`)."""
        return AidIndices.of(self.aid_settings)

    @property
    def declination(self) -> float:
        """The declination estimate D [rad], east positive."""
        return float(self._aid_state()[0][self._aid_indices.declination])

    @property
    def declination_sigma(self) -> float:
        i = self._aid_indices.declination
        return math.sqrt(max(float(self._aid_state()[1][i, i]), 0.0))

    @property
    def deviation(self) -> float | None:
        """The estimate of the local compass deviation d [rad] where the last step ended, east
        positive as D (None: not held, :attr:`FusionSettings.compass_deviation`)."""
        i = self._aid_indices.deviation
        return None if i is None else float(self._aid_state()[0][i])

    @property
    def deviation_sigma(self) -> float | None:
        """The 1σ of :attr:`deviation` [rad] (None: not held)."""
        i = self._aid_indices.deviation
        return None if i is None else math.sqrt(max(float(self._aid_state()[1][i, i]), 0.0))

    @property
    def gps_bias(self) -> np.ndarray | None:
        """The estimate of the receiver's bias [north, east] [m] at the last step's time (None: not
        held, :attr:`FusionSettings.gps_bias`): a fix is the position plus it."""
        i = self._aid_indices.gps_bias
        return None if i is None else self._aid_state()[0][list(i)]

    @property
    def gps_bias_sigma(self) -> np.ndarray | None:
        """The 1σ [m] of :attr:`gps_bias`, north and east (None: not held)."""
        i = self._aid_indices.gps_bias
        if i is None:
            return None
        p = self._aid_state()[1]
        return np.sqrt(np.clip([p[i[0], i[0]], p[i[1], i[1]]], 0.0, None))

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
        if self._fix_times and t < self._fix_times[-1]:
            raise ValueError(f"fix at {time_s} s is older than the one before ({self._fix_times[-1]} s)")
        pos = np.asarray(list(north_east), dtype=np.float64)[:2]
        if pos.shape != (2,) or not np.isfinite(pos).all():
            raise ValueError(f"a fix needs finite north and east, got {pos}")
        self._fix_times.append(t)
        self._fixes.append(pos)

    def pending_fixes(self) -> int:
        """Fixes queued whose time no step has reached yet."""
        return len(self._fix_times) - self._next_fix

    # -- the aids ---------------------------------------------------------------------

    def _walk_deviation(self, distance_m: float) -> None:
        """The local deviation d (held: just before D) after a walk of *distance_m* [m]: d ← φ d,
        its variance φ² var d + (1 − φ²) σ_d², its covariances with the rest φ times theirs."""
        phi, q = self.aid_settings.compass_deviation.transition(distance_m)
        x, p = self._aid_state()
        decay(x, p, (self._aid_indices.deviation,), phi, q)
        self._aid_set_state(x, p)

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
        phi, q = self.aid_settings.gps_bias.transition(dt)
        x, p = self._aid_state()
        decay(x, p, self._aid_indices.gps_bias, phi, q)
        self._aid_set_state(x, p)

    def _compass_step(self, psi: float | None, heading_index: int, moved: bool) -> None:
        """A step's compass heading *psi* [rad] from magnetic north (None: no reading) measures the
        heading at *heading_index* minus D (minus d, held); *moved*: the step moved the foot."""
        s = self.aid_settings
        if psi is None:
            self.fusion.compass_skipped += 1
            return
        if self._aligned and s.compass_mode == "step" and not moved:
            self.fusion.compass_skipped += 1
            return
        x, p = self._aid_state()
        dec, dev = self._aid_indices.declination, self._aid_indices.deviation
        if not self._aligned:
            var_d = float(p[dec, dec])
            sigma = s.compass_sigma_rad if self._align_sigma_rad is None else self._align_sigma_rad
            if dev is not None:
                # χ ← ψ + D + d: the reading's white error, and D's and d's uncertainty and covariance
                var_dev, cov = float(p[dev, dev]), float(p[dev, dec])
                self._align(heading_index, psi + float(x[dec]) + float(x[dev]),
                            sigma ** 2 + var_d + var_dev + 2.0 * cov, cov_with_d=var_d + cov,
                            cov_with_deviation=var_dev + cov)
            else:
                self._align(heading_index, psi + float(x[dec]), sigma ** 2 + var_d, cov_with_d=var_d)
            self.fusion.heading_aligned_by = "compass"
            return
        h = np.zeros(len(x))
        h[heading_index], h[dec] = 1.0, -1.0
        if dev is not None:
            h[dev] = -1.0
            innovation = wrap_angle(psi - (x[heading_index] - x[dec] - x[dev]))
        else:
            innovation = wrap_angle(psi - (x[heading_index] - x[dec]))
        self._update(h, innovation, s.compass_sigma_rad ** 2)
        self.fusion.compass_updates += 1
        self.fusion.compass_innovations.append((len(self), innovation))

    def _gps_until(self, now: float) -> None:
        """Apply the queued fixes whose time module time *now* [s] has reached (the receiver's
        bias, held, carried to each fix's time, then to *now*)."""
        s = self.aid_settings
        bias = s.gps_bias
        while self._next_fix < len(self._fix_times) and self._fix_times[self._next_fix] <= now:
            t, pos = self._fix_times[self._next_fix], self._fixes[self._next_fix]
            self._next_fix += 1
            if bias is not None:
                self._drift_gps_bias(t)
            if not self._origin_set:
                self._origin_set = True
                self._place_origin()
                self._first_fix = pos
                continue
            if not self._aligned:
                if not self._align_by_course(pos):
                    self.fusion.gps_before_alignment += 1
                    continue
            if t - self._last_gps_update < s.gps_update_interval_s:
                self.fusion.gps_skipped += 1
                continue
            self._last_gps_update = t
            rows = self._gps_rows()
            if bias is None:
                for axis, h in enumerate(rows):
                    x, _ = self._aid_state()
                    self._update(h, float(pos[axis] - h @ x), s.gps_sigma_m ** 2)
            else:
                # the fix is the point plus the bias, with only its white error
                rows = rows + self._gps_bias_rows(rows.shape[1])
                for axis, h in enumerate(rows):
                    x, _ = self._aid_state()
                    self._update(h, float(pos[axis] - h @ x), bias.white_sigma_m ** 2)
            self.fusion.gps_updates += 1
        if bias is not None:
            self._drift_gps_bias(now)

    def _gps_bias_rows(self, n: int) -> np.ndarray:
        """The (2, *n*) rows of the receiver's bias [b_n, b_e] in a state of *n* (held)."""
        rows = np.zeros((2, n))
        for axis, i in enumerate(self._aid_indices.gps_bias):
            rows[axis, i] = 1.0
        return rows

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
        x, p = self._aid_state()
        if s.gps_bias is None:
            for row in self._origin_rows():
                p += s.gps_receiver_sigma_m ** 2 * np.outer(row, row)
        else:
            o = self._origin_rows()
            t = np.eye(len(x)) - o.T @ self._gps_bias_rows(len(x))
            x = t @ x
            p = t @ p @ t.T + s.gps_bias.white_sigma_m ** 2 * (o.T @ o)
            p = 0.5 * (p + p.T)
        self._aid_set_state(x, p)

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
        k = self._heading_indices[0]
        self._align(k, float(self._aid_state()[0][k]) + turn, sigma ** 2, cov_with_d=0.0,
                    cov_with_deviation=None if s.compass_deviation is None else 0.0)
        self.fusion.heading_aligned_by = "gps"
        return True

    def _align(self, k: int, chi: float, var_chi: float, *, cov_with_d: float,
               cov_with_deviation: float | None = None) -> None:
        """Turn every pose about the start so that heading *k* is *chi*, with variance *var_chi* and
        covariance *cov_with_d* with D and *cov_with_deviation* with the local deviation d (None:
        not held) (class docstring: the other headings follow it). The receiver's bias, held, is
        north and east and its covariance with the poses is the origin's translation, which
        turning the frame about the start does not turn: it stays as it was."""
        x, before = self._aid_state()
        self._rotate_frame(wrap_angle(chi - float(x[k])))
        x, p = self._aid_state()
        idx = self._aid_indices
        if idx.gps_bias is not None:
            bias = list(idx.gps_bias)
            p[bias, :] = before[bias, :]
            p[:, bias] = before[:, bias]
        dec, dev = idx.declination, idx.deviation
        hs = list(self._heading_indices)
        ones = np.ones(len(hs))
        b = np.eye(len(hs))
        b[:, hs.index(k)] -= 1.0  # χ_j' = χ_k' + (χ_j − χ_k)
        hh = b @ p[np.ix_(hs, hs)] @ b.T + var_chi * np.outer(ones, ones)
        hd = b @ p[hs, dec] + ones * cov_with_d
        if cov_with_deviation is not None:
            hdev = b @ p[hs, dev] + ones * cov_with_deviation
        carried = self._heading_carried()
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
        self._aid_set_state(x, p)
        self._aligned = True

    def _update(self, h: np.ndarray, innovation: float, r: float) -> None:
        """A scalar Kalman update of the state (Joseph form: P stays symmetric and positive)."""
        x, p = self._aid_state()
        ph = p @ h
        k = ph / (float(h @ ph) + r)
        x = x + k * innovation
        i_kh = np.eye(len(x)) - np.outer(k, h)
        p = i_kh @ p @ i_kh.T + r * np.outer(k, k)
        self._aid_set_state(x, 0.5 * (p + p.T))

    def __len__(self) -> int:
        raise NotImplementedError


class FusionTracker(AidedFilter, StepTracker):
    """A :class:`StepTracker` with a declination state and the aids of :class:`FusionSettings`.

    Use it wherever a step tracker goes (a :class:`~hostlib.link.session.HostSession`'s tracker): the
    session hands it each step packet's decoded states, which carry the stance reading and the
    step's time. :attr:`declination` and :attr:`covariance5` give the full state,
    :attr:`state_covariance` all of it (with the module's errors, the receiver's bias and the local
    deviation, if held).
    """

    def __init__(self, settings: FusionSettings | None = None, **tracker_args):
        StepTracker.__init__(self, **tracker_args)
        self.settings = settings or FusionSettings()
        s = self.settings
        # the states beside the pose: the module's errors [s, c, k] (r and w, with their priors) if held,
        # then the aid states (AidIndices): the receiver's bias [b_n, b_e] if held, the deviation d
        # if held, then D
        errors = s.module_errors
        idx = AidIndices.of(s)
        self._errors = errors.states if errors is not None else 0  # how many: 0, or 3 to 5
        self._a = np.zeros(self._errors + idx.count)
        self._a[idx.declination] = float(s.declination_rad)
        self._pa = np.zeros((4, len(self._a)))  # cov(pose, [s, c, k, [r,] [w,]] [b_n, b_e,] [d,] D)
        self._aa = np.zeros((len(self._a), len(self._a)))
        if errors is not None:
            self._aa[:self._errors, :self._errors] = errors.prior
        if s.gps_bias is not None:
            for i in idx.gps_bias:
                self._aa[i, i] = s.gps_bias.variance
        if s.compass_deviation is not None:
            self._aa[idx.deviation, idx.deviation] = s.compass_deviation.variance
        self._aa[idx.declination, idx.declination] = (s.declination_sigma_rad ** 2 if (s.gps and s.compass)
                                                      else 0.0)
        self._init_aids()
        self._compass_held = False
        self._clock = ModuleClock()
        # the steps' times as the module's heading drift sees them (with its errors held)
        self._drift_clock = errors.clock() if errors is not None else None
        self._time = 0.0  # module time of the last step [s]
        #: per summed step: module time [s] (NaN: the packet had no T_INT_K)
        self.step_times: list[float] = []

    # -- state -------------------------------------------------------------------------

    @property
    def covariance5(self) -> np.ndarray:
        """The 5×5 covariance of [x, y, z, χ, D] (whatever else is held)."""
        keep = [0, 1, 2, 3, self._aid_indices.declination]
        return self.state_covariance[np.ix_(keep, keep)]

    @property
    def state_covariance(self) -> np.ndarray:
        """The covariance of the whole state: [x, y, z, χ, D], with what is held between χ and D
        in this order: the module's errors s, c, k and, with its prior, the heading drift rate r
        (:attr:`FusionSettings.module_errors`), the
        receiver's bias b_n, b_e [m] (:attr:`FusionSettings.gps_bias`), the local compass
        deviation d (:attr:`FusionSettings.compass_deviation`). So [x, y, z, χ, s, c, k, D] with
        the module's errors; [x, y, z, χ, d, D] with the deviation; [x, y, z, χ, b_n, b_e, D]
        with the bias; with all three [x, y, z, χ, s, c, k, b_n, b_e, d, D]
        (:class:`AidIndices` counts the aid states from the end)."""
        n = 4 + len(self._a)
        p = np.zeros((n, n))
        p[:4, :4] = self.track._covs[-1]
        p[:4, 4:] = self._pa
        p[4:, :4] = self._pa.T
        p[4:, 4:] = self._aa
        return p

    @property
    def module_errors(self) -> tuple[float, ...] | None:
        """The estimated step-length scale s, climb c [m/m] and turn scale k, with a heading drift
        prior the drift rate r [rad/s], with a warm-up prior the warm-up w [rad/s] (None: not held)."""
        if self.settings.module_errors is None:
            return None
        return tuple(float(v) for v in self._a[:self._errors])

    def compass_heading(self, reading: StanceReading | None) -> float | None:
        """The heading from magnetic north [rad] of a stance *reading*, the shoe's iron removed
        (:attr:`FusionSettings.mag_calibration`); None without a reading."""
        if reading is None:
            return None
        field_b = reading.field_board
        if self.settings.mag_calibration is not None:
            field_b = self.settings.mag_calibration.apply(field_b)
        return compass_heading(field_b, reading.rotation)

    def hold_compass(self) -> None:
        """No compass update until :meth:`release_compass`: the shoe's iron is being calibrated
        (:class:`hostlib.calibration.wiggle.WiggleCalibration`). The readings meanwhile count as skipped."""
        self._compass_held = True

    def release_compass(self, calibration: MagCalibration | None,
                        align_sigma_rad: float | None = None) -> None:
        """Compass updates again, *calibration* removing the shoe's iron from now on (None: none,
        the readings uncalibrated); if the heading is not aligned yet, the next reading aligns it
        with σ *align_sigma_rad* (None: the compass's own σ_c; with the local deviation held, in
        place of σ_c, d's and D's uncertainty added as at any first reading)."""
        self.settings = replace(self.settings, mag_calibration=calibration)
        self._align_sigma_rad = align_sigma_rad
        self._compass_held = False

    # -- input -------------------------------------------------------------------------

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
        outcome = StepTracker.add_step(self, dx, dp, counter, swing_time)
        if outcome is StepOutcome.DUPLICATE:
            return outcome
        dxa = np.asarray(dx, dtype=np.float64)
        f = step_jacobian(float(prev[3]), dxa)
        errors = self.settings.module_errors
        if errors is None:
            # cov(pose, [b,] [d,] D) through the step: the pose's Jacobian; they do not move it
            self._pa = f @ self._pa
        else:
            # the drift's Δt and the warm-up's W since the step before (0 standing still, or no time)
            span = self._drift_clock.span(dxa, time_s)
            self._module_errors_through(f, errors.jacobian(float(prev[3]), dxa, span))
        if self.settings.compass_deviation is not None:
            self._walk_deviation(math.hypot(dxa[0], dxa[1]))  # where this step's reading is taken
        if math.isfinite(time_s):
            self._time = time_s
        self.step_times.append(time_s)
        if self.settings.compass and self._compass_held:
            self.fusion.compass_skipped += 1
        elif self.settings.compass:
            self._compass_step(self.compass_heading(reading), 3, is_motion_step(dxa))
        if self.settings.gps:
            self._gps_until(self._time)
        return outcome

    def _module_errors_through(self, f: np.ndarray, j: np.ndarray) -> None:
        """The step just summed, with the module's errors held: its pose moves by the learned
        errors (nothing while they are 0), and the covariance goes through the step's Jacobians
        (F for the pose, J for [s, c, k] or [s, c, k, r]; b, d and D do not move it; the steps' own
        dP is already in; :func:`hostlib.fusion.module_errors.through_step`, the rest [s, c, k, [r,]] then
        the aid states)."""
        pose, cov, self._pa = through_step(self.track._poses[-1], self.track._covs[-1], self._pa, f, j,
                                           self._a, self._aa, slice(0, self._errors))
        self.track._poses[-1], self.track._covs[-1] = pose, cov

    # -- the aids' view of the state ---------------------------------------------------

    @property
    def aid_settings(self) -> FusionSettings:
        return self.settings

    def _aid_state(self) -> tuple[np.ndarray, np.ndarray]:
        x = np.concatenate([self.track._poses[-1], self._a])
        return x, self.state_covariance

    def _aid_set_state(self, x: np.ndarray, p: np.ndarray) -> None:
        self.track._poses[-1] = x[:4].copy()
        self.track._covs[-1] = p[:4, :4].copy()
        self._pa = p[:4, 4:].copy()
        self._aa = p[4:, 4:].copy()
        self._a = x[4:].copy()

    def _gps_rows(self) -> np.ndarray:
        return np.eye(4 + len(self._a))[:2]

    def _origin_rows(self) -> np.ndarray:
        return np.eye(4 + len(self._a))[:2]

    def _travelled(self) -> np.ndarray:
        return self.track._poses[-1][:2] - self.track._poses[0][:2]

    def _rotate_frame(self, turn: float) -> None:
        track = self.track
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
        self._pa[:3] = r @ self._pa[:3]

    def __len__(self) -> int:
        return StepTracker.__len__(self)

    def __repr__(self) -> str:
        return (f"FusionTracker({self.track!r}, D={math.degrees(self.declination):.2f}°, "
                f"compass {self.fusion.compass_updates}, gps {self.fusion.gps_updates})")
