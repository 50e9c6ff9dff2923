"""The in-situ magnetometer calibration: NavShoe's wiggle, as a state machine without I/O.

After mounting, the wearer wiggles the shoe through many orientations for about 30 s with little
translation, so the true field is nearly constant and the readings lie on an ellipsoid; the
calibration ends by itself at the first step longer than 0.5 m, and navigation then starts with a
10° heading uncertainty, because the horizontal field at the calibration spot may differ from the
local average (shared/spec/aids.md §3).

:class:`WiggleCalibration` is that procedure for one module, driven by whatever moves the bytes
(``openshoe-host track --calibrate-mag``, ``openshoe-host log --calibrate-mag`` recording it,
``openshoe-host replay --calibrate-mag``, the emulator's replayed host ``openshoe-emu replay --host
fusion --calibrate-mag``):

* :data:`WiggleCalibration.START` — the commands that make the module stream its magnetometers and
  attitude (:data:`protocol.extensions.MAG_STREAM_START`), sent after the fusion set-up;
* :meth:`WiggleCalibration.feed` — the host session's events in order: each stream packet gives a
  reading (the board-frame field averaged over the chips, :func:`hostlib.aids.compass.stance_reading`,
  with the attitude), each step its horizontal length; step packets are steps, not readings (the
  first long step's reading is taken a stride away). At the first step whose horizontal length
  exceeds :data:`STOP_STEP_M` it fits the readings (:func:`hostlib.calibration.magcal.fit_quadric`, the
  calibration named after the module's serial number), turns the fit's soft iron by the field's
  rotation the readings' attitudes show (:func:`hostlib.calibration.iron_rotation.fit_iron_rotation`, the part
  of the iron no ellipsoid sees) and returns True: then send
  :data:`WiggleCalibration.STOP` (:data:`protocol.extensions.MAG_STREAM_STOP`), and hand the result
  to the tracker (:meth:`hostlib.fusion.tracker.FusionTracker.release_compass`, σ :data:`HEADING_SIGMA_DEG`
  for the first reading).

It refuses — :attr:`~WiggleCalibration.calibration` stays None and
:attr:`~WiggleCalibration.refusal` says why — when the readings do not determine an ellipsoid:

* too few of them (:data:`hostlib.calibration.magcal.MIN_READINGS`), or no ellipsoid fits them at all;
* too little rotation: the field was not seen from enough sides. Readings confined to one half of
  the sphere of directions (a cap about the board's z axis, when the shoe is tilted less than the
  field is steep) leave the ellipsoid's extent and centre along the cap's axis to its curvature
  alone: a family of ellipsoids fits them nearly equally well, noise picks one, and the fit's own
  scatter (below) no longer tells how far off it is. :func:`coverage_deg` says how far the
  readings reach into the half of the sphere they reach least into (negative: they stop short of
  it); it must be at least :data:`MIN_COVERAGE_DEG`;
* readings that leave the fit so uncertain that a level compass could be off by more than
  :data:`MAX_FIT_HEADING_SIGMA_DEG` (1σ, worst heading) from their scatter alone — too few, a
  field that changed while the shoe turned, or a shoe only turned round (the readings on one
  circle, on which many ellipsoids lie). That figure propagates the nine quadric coefficients'
  covariance to the heading of a level compass at every 30° of heading in the field the calibrated
  readings show (its horizontal and vertical parts from the readings levelled with their
  attitudes); linearised, it is a fair figure only where the coverage is good, hence both tests.

Navigation then goes on uncalibrated.

The rotation is a second step: when the attitudes do not determine it (too few readings held
still, a shoe not tilted while held, an inclination that scatters: the attitude does not go with
the magnetometers) the calibration is the ellipsoid's alone, and
:attr:`~WiggleCalibration.rotation_refusal` says why — the ellipsoid's calibration still halves a
compass's error, so that is no reason to go on uncalibrated. The same 1σ limit on a level
compass's heading holds for it.

Steps lost while the stream runs (it is lossy, and so are the step packets meanwhile) are no
concern: a lost wiggle step is a few centimetres, and if the first long step is lost the next one
ends the calibration.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from protocol.extensions import MAG_STREAM_START, MAG_STREAM_STOP
from protocol.ids import Command, StateId

from ..aids.compass import StanceReading, compass_heading, stance_reading, wrap_angle
from ..events import PacketEvent, StepEvent
from ..track.steps import rotation_z
from .iron_rotation import IronRotation, fit_iron_rotation
from .magcal import MagCalibration, MagCalibrationError, QuadricFit, fit_quadric

__all__ = ["HEADING_SIGMA_DEG", "MAX_FIT_HEADING_SIGMA_DEG", "MIN_COVERAGE_DEG", "STOP_STEP_M",
           "WiggleCalibration", "coverage_deg", "fit_heading_sigma_deg"]

#: The calibration ends at the first step whose horizontal length exceeds this [m] (NavShoe): the
#: wiggle's own steps are a few centimetres, a stride is more than a metre.
STOP_STEP_M = 0.5
#: 1σ of the heading the first compass reading after the calibration gives [deg] (NavShoe): the
#: horizontal field at the calibration spot may deviate from the local average.
HEADING_SIGMA_DEG = 10.0
#: The largest 1σ heading error [deg] the fit's own noise may leave on a level compass: a third of
#: :data:`HEADING_SIGMA_DEG`, so that, independent of it, it widens the start's uncertainty by
#: 5 % at most (√(1 + 1/9) = 1.054).
MAX_FIT_HEADING_SIGMA_DEG = HEADING_SIGMA_DEG / 3.0
#: The least :func:`coverage_deg` [deg] of a calibration: the readings may end at most 30° short of
#: the half of the sphere they reach least into. In simulation (30 s wiggles through the emulated
#: module, twenty modules' iron, outdoors at Stockholm's 72.5° inclination; ``python -m
#: lab.accuracy magcal``, docs/heading-aids.md) the fit's own worst level-heading error is 0.3°
#: where the readings end 12° short, 1.5° at 26°, 3.4° at 35° and 8° at 48°: 30° is where it passes
#: :data:`MAX_FIT_HEADING_SIGMA_DEG`.
MIN_COVERAGE_DEG = -30.0
#: What a refusal asks the wearer to do.
_WIGGLE_HOW = ("wiggle again, in one place away from iron, for longer: toe down and up, the sole to either "
               "side, all round")
#: The level headings at which the fit's heading error is taken [deg].
_LEVEL_HEADINGS_DEG = np.arange(0.0, 360.0, 30.0)
#: The share of readings that must lie at least as far into every half of the sphere as
#: :func:`coverage_deg` says: 1 %, so that a few stray readings do not make a side seen.
_COVERAGE_QUANTILE = 0.99
#: Directions (a Fibonacci lattice) whose halves of the sphere :func:`coverage_deg` looks into:
#: neighbours lie about 5° apart, well under the angles it tells apart.
HALF_SPHERES = 2000


def _fibonacci_sphere(n: int) -> np.ndarray:
    k = np.arange(n) + 0.5
    z = 1.0 - 2.0 * k / n
    phi = k * math.pi * (3.0 - math.sqrt(5.0))
    r = np.sqrt(1.0 - z * z)
    return np.column_stack([r * np.cos(phi), r * np.sin(phi), z])


def coverage_deg(calibration: MagCalibration, readings: Sequence[StanceReading]) -> float:
    """How far [deg] the readings' directions about the calibration's centre (its hard iron) reach
    into the half of the sphere they reach least into: for each half (about each of
    :data:`HALF_SPHERES` directions d), the angle beyond its rim of the readings the 1 % farthest
    into it, asin(q₉₉(u·d)); the worst half. A cap of half-angle θ gives θ − 90°: negative when all
    readings lie in one half. (Taken before the soft iron, so that a fit gone wrong cannot spread
    the directions it judges.)"""
    u = np.array([r.field_board for r in readings]) - calibration.hard_iron
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    reach = np.quantile(u @ _fibonacci_sphere(HALF_SPHERES).T, _COVERAGE_QUANTILE, axis=0)
    return math.degrees(math.asin(float(np.clip(reach.min(), -1.0, 1.0))))


def fit_heading_sigma_deg(fit: QuadricFit, calibration: MagCalibration,
                          readings: Sequence[StanceReading]) -> float:
    """The 1σ heading error [deg] that the quadric's coefficient covariance leaves on a level
    compass calibrated with *calibration* (the fit's own), worst over headings every 30°, in the
    field the calibrated *readings* levelled with their attitudes show (module docstring).
    Infinite when a small change of the coefficients is no ellipsoid any more."""
    field = np.array([r.rotation @ calibration.apply(r.field_board) for r in readings])
    horizontal = float(np.median(np.hypot(field[:, 0], field[:, 1])))
    level = np.array([horizontal, 0.0, float(np.median(field[:, 2]))])
    inverse = np.linalg.inv(calibration.soft_iron)
    places = [(r, inverse @ (r.T @ level) + calibration.hard_iron)
              for r in (rotation_z(math.radians(psi)) for psi in _LEVEL_HEADINGS_DEG)]
    jacobian = np.empty((len(places), len(fit.coef)))
    for j in range(len(fit.coef)):
        h = 1e-6 * max(1.0, abs(float(fit.coef[j])))
        step = np.zeros(len(fit.coef))
        step[j] = h
        try:
            plus, minus = (fit.calibration(fit.coef + s, field_ut=calibration.field_ut)
                           for s in (step, -step))
        except MagCalibrationError:
            return math.inf
        for k, (r, m) in enumerate(places):
            turn = wrap_angle(compass_heading(plus.apply(m), r) - compass_heading(minus.apply(m), r))
            jacobian[k, j] = turn / (2 * h)
    variance = np.einsum("kj,jl,kl->k", jacobian, fit.covariance, jacobian)
    return math.degrees(math.sqrt(max(float(variance.max()), 0.0)))


class WiggleCalibration:
    """One module's in-situ calibration (module docstring). *stop_step_m* and
    *max_heading_sigma_deg* default to NavShoe's and ours (:data:`STOP_STEP_M`,
    :data:`MAX_FIT_HEADING_SIGMA_DEG`)."""

    #: The commands (meaning, payload fields) that start the magnetometer stream.
    START: tuple[tuple[Command, Mapping[str, Any]], ...] = MAG_STREAM_START
    #: The commands that stop it, once :meth:`feed` said the calibration ended.
    STOP: tuple[tuple[Command, Mapping[str, Any]], ...] = MAG_STREAM_STOP

    def __init__(self, *, stop_step_m: float = STOP_STEP_M,
                 max_heading_sigma_deg: float = MAX_FIT_HEADING_SIGMA_DEG):
        if not stop_step_m > 0 or not max_heading_sigma_deg > 0:
            raise ValueError("stop_step_m and max_heading_sigma_deg must be positive")
        self.stop_step_m = float(stop_step_m)
        self.max_heading_sigma_deg = float(max_heading_sigma_deg)
        #: the stream's readings so far
        self.readings: list[StanceReading] = []
        #: steps seen while calibrating (the one that ended it included)
        self.steps = 0
        #: packets seen after the calibration ended (the stream until the stop took effect)
        self.late_packets = 0
        #: whether the calibration ended (fitted or refused)
        self.done = False
        #: the result, None until it ended or when it was refused
        self.calibration: MagCalibration | None = None
        #: why it was refused (None: not refused)
        self.refusal: str | None = None
        #: the ellipsoid fit's calibration, before the attitude turned it (None: no fit)
        self.ellipsoid: MagCalibration | None = None
        #: the field's rotation from the attitudes (None: not fitted, or refused)
        self.rotation: IronRotation | None = None
        #: why the calibration is the ellipsoid's alone (None: turned, or no calibration)
        self.rotation_refusal: str | None = None
        #: the fit's 1σ heading error on a level compass [deg] (:func:`fit_heading_sigma_deg`)
        self.heading_sigma_deg = math.nan
        #: how far the readings reach into every half of the sphere [deg] (:func:`coverage_deg`)
        self.coverage_deg = math.nan

    # -- input ------------------------------------------------------------------------

    def feed(self, events: Iterable[Any], module_serial: str = "") -> bool:
        """The host session's events, in order; True when one of them ended the calibration.
        *module_serial* names the module the calibration is fitted on."""
        ended = False
        for event in events:
            if isinstance(event, PacketEvent):
                self.add_packet(event.states)
            elif isinstance(event, StepEvent):
                ended = self.add_step(event.step.dx, module_serial) or ended
        return ended

    def add_packet(self, states: Mapping[int, Any] | None) -> None:
        """A decoded packet: a reading when it is the stream's (attitude and magnetometers, no step)."""
        if states is None or StateId.DX in states:
            return
        if self.done:
            self.late_packets += 1
            return
        reading = stance_reading(states)
        if reading is not None:
            self.readings.append(reading)

    def add_step(self, dx, module_serial: str = "") -> bool:
        """A step's displacement (dx, dy, dz, dψ); True when it ends the calibration (fitted then,
        or refused)."""
        if self.done:
            return False
        self.steps += 1
        d = np.asarray(dx, dtype=np.float64)
        if not math.hypot(float(d[0]), float(d[1])) > self.stop_step_m:
            return False
        self.finish(module_serial)
        return True

    def finish(self, module_serial: str = "") -> MagCalibration | None:
        """End the calibration now and fit the readings (what the first long step does); returns
        the calibration, or None when refused (:attr:`refusal`)."""
        self.done = True
        if not self.readings:
            self.refusal = ("no magnetometer reading came: the module did not stream its attitude and "
                            "magnetometers (states 0x22, 0x90–0x92)")
            return None
        try:
            fit = fit_quadric([r.field_board for r in self.readings])
            calibration = fit.calibration(module_serial=module_serial)
        except MagCalibrationError as exc:
            self.refusal = f"{exc}"
            return None
        self.coverage_deg = coverage_deg(calibration, self.readings)
        residual = f"they scatter {calibration.rms_residual_ut:.2f} µT RMS about the fit"
        if not self.coverage_deg >= MIN_COVERAGE_DEG:
            self.refusal = (f"the field's directions end {-self.coverage_deg:.0f}° short of one half of the "
                            f"sphere (at most {-MIN_COVERAGE_DEG:.0f}°; {residual}): the shoe did not turn "
                            f"through enough orientations, or the field changed while it turned — "
                            f"{_WIGGLE_HOW}")
            return None
        self.heading_sigma_deg = fit_heading_sigma_deg(fit, calibration, self.readings)
        if not self.heading_sigma_deg <= self.max_heading_sigma_deg:
            self.refusal = (f"the readings leave a level compass uncertain by {self.heading_sigma_deg:.1f}° "
                            f"(1σ; at most {self.max_heading_sigma_deg:.1f}°; {residual}) — {_WIGGLE_HOW}")
            return None
        self.ellipsoid = calibration
        try:
            self.rotation = fit_iron_rotation(calibration, self.readings, self.max_heading_sigma_deg)
        except MagCalibrationError as exc:
            self.rotation_refusal = f"{exc}"
        else:
            calibration = calibration.turned(self.rotation.rotation)
        self.calibration = calibration
        return calibration

    # -- output -----------------------------------------------------------------------

    def release(self, tracker: Any) -> None:
        """Hand the result to *tracker* (a :class:`hostlib.fusion.tracker.FusionTracker` holding its compass
        since the calibration began): the calibration, the first reading aligning the heading with
        σ :data:`HEADING_SIGMA_DEG`; refused, the readings uncalibrated and the compass's own σ."""
        calibrated = self.calibration is not None
        tracker.release_compass(self.calibration, math.radians(HEADING_SIGMA_DEG) if calibrated else None)

    def summary(self) -> str:
        """One line: what the calibration did."""
        what = f"{len(self.readings)} readings over {self.steps} steps of wiggle"
        if not self.done:
            return (f"magnetometers not calibrated yet: {what}, no step longer than {self.stop_step_m:g} m "
                    f"came to end the wiggle")
        if self.calibration is None:
            return f"magnetometers not calibrated ({what}): {self.refusal}; navigating uncalibrated"
        cal = self.calibration
        hard = ", ".join(f"{v:+.2f}" for v in cal.hard_iron)
        if self.rotation is not None:
            turned = (f"the attitude turned the field {cal.rotation_deg:.1f}° (inclination "
                      f"{self.rotation.inclination_deg:.1f}°, ±{self.rotation.heading_sigma_deg():.2f}° in "
                      f"heading)")
        else:
            turned = f"the ellipsoid's alone, not turned with the attitude: {self.rotation_refusal}"
        return (f"magnetometers calibrated from {what}: hard iron [{hard}] µT, field "
                f"{cal.field_ut:.1f} µT, residual {cal.rms_residual_ut:.2f} µT RMS, coverage "
                f"{self.coverage_deg:+.0f}°, heading ±{self.heading_sigma_deg:.2f}° from the fit's scatter; "
                f"{turned}")

    def __repr__(self) -> str:
        state = "calibrated" if self.calibration is not None else "refused" if self.done else "collecting"
        return f"WiggleCalibration({state}, {len(self.readings)} readings, {self.steps} steps)"
