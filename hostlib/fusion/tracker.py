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

The state is a :class:`~hostlib.fusion.core.StateFilter` of named blocks (``pose``, ``errors``,
``gps_bias``, ``deviation``, ``declination``), and the aids are :class:`~hostlib.fusion.aided.AidedFilter`,
which does not care how many poses the state holds: :class:`hostlib.fusion.feet.TwoFeetTracker`
applies the same aids to both feet's poses and D. A
fix's north and east are applied one after the other, the second with the state the first left.

Time: a step packet of the fusion set-up carries T_INT_K (the module's 64 MHz cycle counter when
the step's last measurement was taken); the tracker unwraps it into seconds since the module's
power-on (:class:`~hostlib.link.module_clock.ModuleClock`). Fix times are seconds since the receiver started
talking (:func:`hostlib.aids.gps.seconds_since`); the two clocks are taken to start together, as the
emulator's receiver and module do (:attr:`FusionSettings.gps_offset_s` shifts the fixes).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace

import numpy as np

from ..aids.compass import StanceReading, compass_heading, stance_reading
from ..calibration.magcal import MagCalibration
from ..events import StepOutcome
from ..link.module_clock import ModuleClock
from ..track.rows import Rows
from ..track.steps import StepTracker, is_motion_step, rotation_z
from .aid_states import add_aid_states
from .aided import AidedFilter
from .core import StateFilter
from .hard_iron import iron_heading
from .settings import FusionSettings, FusionStats

__all__ = ["AidedFilter", "FusionSettings", "FusionStats", "FusionTracker"]


class FusionTracker(AidedFilter, StepTracker):
    """A :class:`StepTracker` with a declination state and the aids of :class:`FusionSettings`.

    Use it wherever a step tracker goes (a :class:`~hostlib.link.session.HostSession`'s tracker):
    the session hands it each step packet's decoded states, which carry the stance reading and the
    step's time. Its filter (:attr:`filter`) holds the blocks ``pose`` [x, y, z, χ], ``errors``
    (the module's, if held), then the aid states (:mod:`hostlib.fusion.aid_states`);
    :attr:`declination` and :attr:`covariance5` give the pose and D, :attr:`state_covariance` all
    of it. The track (:attr:`track`) keeps every pose; its last row is the filter's pose after each
    step's aids.
    """

    pose_blocks = ("pose",)

    def __init__(self, settings: FusionSettings | None = None, **tracker_args):
        StepTracker.__init__(self, **tracker_args)
        self.settings = settings or FusionSettings()
        self.aid_settings = self.settings
        errors = self.settings.module_errors
        self.filter = StateFilter()
        self.filter.add_block("pose", self.track.final_pose, self.track.final_covariance)
        if errors is not None:
            self.filter.add_block("errors", np.zeros(errors.states), errors.prior)
            self.error_blocks = ("errors",)
        add_aid_states(self.filter, self.settings)
        self._init_aids()
        self._compass_held = False
        self._clock = ModuleClock()
        # the steps' times as the module's heading drift sees them (with its errors held)
        self._drift_clock = errors.clock() if errors is not None else None
        self._time = 0.0  # module time of the last step [s]
        self._step_time = math.nan  # module time of the step being summed [s]
        self._step_times = Rows(())  # per summed step: module time [s]

    # -- state -------------------------------------------------------------------------

    @property
    def step_times(self) -> np.ndarray:
        """(n,) per summed step its module time [s] (NaN: the packet had no T_INT_K); read-only,
        as it is now (later steps do not show in it)."""
        return self._step_times.view()

    @property
    def covariance5(self) -> np.ndarray:
        """The 5×5 covariance of [x, y, z, χ, D] (whatever else is held)."""
        keep = self.filter.indices("pose", "declination")
        return self.filter.P[np.ix_(keep, keep)].copy()

    @property
    def state_covariance(self) -> np.ndarray:
        """The covariance of the whole state, block by block as the filter holds them: [x, y, z, χ],
        the module's errors s, c, k and, with their priors, the heading drift rate r and the
        warm-up w (:attr:`FusionSettings.module_errors`), the receiver's bias b_n, b_e [m]
        (:attr:`FusionSettings.gps_bias`), the local compass deviation d
        (:attr:`FusionSettings.compass_deviation`), and the declination D. So [x, y, z, χ, s, c, k, D]
        with the module's errors; [x, y, z, χ, d, D] with the deviation; [x, y, z, χ, b_n, b_e, D]
        with the bias; with all three [x, y, z, χ, s, c, k, b_n, b_e, d, D]."""
        return self.filter.P.copy()

    @property
    def module_errors(self) -> tuple[float, ...] | None:
        """The estimated step-length scale s, climb c [m/m] and turn scale k, with a heading drift
        prior the drift rate r [rad/s], with a warm-up prior the warm-up w [rad/s] (None: not held)."""
        if "errors" not in self.filter:
            return None
        return tuple(float(v) for v in self.filter.mean("errors"))

    def compass_heading(self, reading: StanceReading | None) -> float | None:
        """The heading from magnetic north [rad] of a stance *reading*, the shoe's iron removed
        (:attr:`FusionSettings.mag_calibration`, and with :attr:`FusionSettings.hard_iron` held
        what the filter has learned of it so far); None without a reading."""
        calibrated = self.calibrated_reading(reading)
        if calibrated is None:
            return None
        if "hard_iron" in self.filter:
            return iron_heading(*calibrated, self.filter.mean("hard_iron"))[0]
        return compass_heading(*calibrated)

    def _module_seconds(self) -> float:
        return self._time

    def calibrated_reading(self, reading: StanceReading | None) -> tuple[np.ndarray, np.ndarray] | None:
        """A stance *reading*'s board-frame field [µT] with the calibration applied
        (:attr:`FusionSettings.mag_calibration`), and its board → navigation rotation."""
        if reading is None:
            return None
        field_b = reading.field_board
        if self.settings.mag_calibration is not None:
            field_b = self.settings.mag_calibration.apply(field_b)
        return field_b, reading.rotation

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
        self.aid_settings = self.settings
        self._align_sigma_rad = align_sigma_rad
        self._compass_held = False
        self._compass_calibrated()

    # -- input -------------------------------------------------------------------------

    def add(self, step, swing_time: float = math.nan, states: Mapping[int, np.ndarray] | None = None
            ) -> StepOutcome:
        """Sum one step, then apply the aids its packet's *states* and the queued fixes allow."""
        reading = stance_reading(states) if states is not None and self._reads_stance() else None
        time_s = self._clock.seconds(states)
        return self.add_step(step.dx, step.dp, step.counter, swing_time, reading=reading, time_s=time_s)

    def _reads_stance(self) -> bool:
        """Whether a step's packet is read for its stance reading: only the compass uses it."""
        return self.settings.compass

    def add_step(self, dx, dp, counter, swing_time: float = math.nan, *,
                 reading: StanceReading | None = None, time_s: float = math.nan) -> StepOutcome:
        """Sum a step given as arrays (:meth:`StepTracker.add_step`), with its stance *reading*
        and module time *time_s* [s], and apply the aids."""
        self._step_time = time_s
        outcome = StepTracker.add_step(self, dx, dp, counter, swing_time)
        if not outcome.summed:
            return outcome
        dxa = self.track.last_step
        if self.settings.compass_deviation is not None:
            self._walk_deviation(math.hypot(dxa[0], dxa[1]))  # where this step's reading is taken
        if math.isfinite(time_s):
            self._time = time_s
        self._step_times.append(time_s)
        if self.settings.compass and self._compass_held:
            self.fusion.compass_skipped += 1
        elif self.settings.compass:
            self._compass_step(self.compass_heading(reading), "pose", is_motion_step(dxa),
                               self.calibrated_reading(reading))
        if self.settings.gps:
            self._gps_until(self._time)
        if self.settings.compass or self.settings.gps:  # else no aid moved the pose _sum appended
            self._write_track()
        return outcome

    def _sum(self, dx: np.ndarray, dp: np.ndarray, counter: int, swing_time: float) -> None:
        """The pose block through the step (and, held, the module's errors over the drift's Δt and
        the warm-up's W since the step before: 0 standing still, or without a time); the track
        gets the new pose."""
        errors = self.settings.module_errors
        if errors is None:
            self.filter.step_pose("pose", dx, dp)
        else:
            chi = float(self.filter.x[self.filter.index("pose", 3)])
            span = self._drift_clock.span(dx, self._step_time)
            self.filter.step_pose("pose", dx, dp, "errors", errors.jacobian(chi, dx, span))
        self.track.append(self.filter.mean("pose"), self.filter.covariance("pose"), dx.copy(), counter,
                          swing_time)

    def _write_track(self) -> None:
        """The track's last row as the filter's pose now (the aids corrected it)."""
        self.track.replace_last(self.filter.mean("pose"), self.filter.covariance("pose"))

    # -- what the aids need of this tracker --------------------------------------------

    def _gps_rows(self) -> np.ndarray:
        return np.stack([self.filter.row({("pose", axis): 1.0}) for axis in (0, 1)])

    def _travelled(self) -> np.ndarray:
        return self.filter.x[self.filter.slice("pose")][:2] - self.track.initial_pose[:2]

    def _rotate_frame(self, turn: float) -> None:
        """Turn the track about its start, and the filter with it: the pose as its last row, the
        position's covariance with every other state by the same rotation."""
        self._write_track()
        self.track.rotate_about_start(turn)
        f = self.filter
        b, rest = f.slice("pose"), f.others("pose")
        f.x[b] = self.track.final_pose
        f.P[b, b] = self.track.final_covariance
        position = np.arange(b.start, b.start + 3)
        cross = rotation_z(turn) @ f.P[np.ix_(position, rest)]
        f.P[np.ix_(position, rest)] = cross
        f.P[np.ix_(rest, position)] = cross.T

    def __len__(self) -> int:
        return StepTracker.__len__(self)

    def __repr__(self) -> str:
        return (f"FusionTracker({self.track!r}, D={math.degrees(self.declination):.2f}°, "
                f"compass {self.fusion.compass_updates}, gps {self.fusion.gps_updates})")
