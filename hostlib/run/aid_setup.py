"""Setting the host-side aids up from what a user has: a GPS log, a place and date, a calibration.

:func:`prepare_aids` turns what a user has, an :class:`~hostlib.run.options.AidOptions`, into a ready
:class:`~hostlib.fusion.tracker.FusionTracker`:

* with a GPS log, the fixes are read (:mod:`hostlib.aids.gps`; garbled lines and missing fixes are
  skipped and counted), placed north/east of the first fix (pymap3d), and queued on the tracker;
  the first fix is also the geographic origin of the track and, with its date, where the World
  Magnetic Model gives the declination prior (:mod:`hostlib.aids.declination`);
* without GPS, the declination comes from the WMM at the options' origin (and date) if given, else 0
  (the compass then gives magnetic headings, and the summary says so);
* with a receiver read live (:mod:`hostlib.run.gps_stream`), its first fix places the walk in the same
  way, and the later fixes are queued as they come;
* a magnetometer calibration (:class:`hostlib.calibration.magcal.MagCalibration`) is applied to every
  reading; one fitted on another module is refused once the module names itself.
* the models held by default (the module's errors, with an aid or without; the compass's local
  deviation, the receiver's bias and the compass's swing where their aid is used:
  :meth:`AidOptions.resolved <hostlib.run.options.AidOptions.resolved>`) are resolved once, and
  :meth:`AidSetup.describe`, the ``aids:`` line, says of each whether it is held by default, as given,
  or turned off.

:func:`prepare_feet_aids` does the same for a module on each foot: a
:class:`~hostlib.fusion.feet.TwoFeetTracker` with the aids on the joint filter, each foot's own
magnetometer and drift calibration, the fixes queued for the body and for each foot (or, from a
receiver read live, its first fix placing the walk as for one module).
"""

from __future__ import annotations

import datetime as dt
import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ..aids.declination import MagneticField, magnetic_field
from ..aids.geodesy import parse_origin
from ..aids.gps import GpsFix, NmeaStats, fix_place, fixes_of_log, local_positions, seconds_since
from ..calibration.drift import DriftCalibration
from ..fusion.compass_trust import field_check
from ..fusion.deviation import INDOORS, OUTDOORS, CompassDeviation
from ..fusion.feet import FOOT_SIDES, FeetSettings, TwoFeetTracker
from ..fusion.module_errors import ModuleErrors, preset_name
from ..fusion.tracker import FusionSettings, FusionTracker
from .options import DEFAULTED, AidOptions

__all__ = ["AidSetup", "feet_tracker", "prepare_aids", "prepare_feet_aids"]


@dataclass
class AidSetup:
    """A tracker with its aids, and what setting them up found."""

    tracker: FusionTracker | TwoFeetTracker
    origin: tuple[float, float, float] | None  #: lat, lon, alt of the track's (0, 0, 0), if known
    declination_source: str  #: "WMM at the first fix, 2026-06-01", "given", "none (magnetic headings)"
    gps_stats: NmeaStats | None = None
    #: where the magnetometer calibration came from, for the summary ("saved <path>", "in situ, …")
    calibration_source: str = ""
    #: with two feet: side → where that foot's calibration came from, if said ("saved <path>")
    foot_calibration_sources: dict[str, str] = field(default_factory=dict)
    #: why the models held by default are on or off (:meth:`AidOptions.defaulted
    #: <hostlib.run.options.AidOptions.defaulted>`): option → "by default", "given" or "off"
    defaulted: dict[str, str] = field(default_factory=dict)
    #: why the steps may carry no module time, for the ``aids:`` line (set by a
    #: :class:`~hostlib.run.tracking_run.TrackingRun`: the fusion set-up off, or not taken by the
    #: module; "": a capture recorded without it)
    plain_packets: str = ""

    def describe(self) -> str:
        """The ``aids:`` line: what is on, and why each model held by default is on or off."""
        s = self.tracker.aid_settings
        parts = []
        if s.compass and s.compass_deviation is not None:
            parts.append(f"compass σ {math.degrees(s.compass_sigma_rad):g}° per step, local deviation held"
                         f"{self._why('compass_deviation')} ({_deviation_name(s.compass_deviation)}"
                         f"{s.compass_deviation.describe()})" + self._calibrated())
        elif s.compass:
            parts.append(f"compass σ {math.degrees(s.compass_sigma_rad):.0f}° per step" + self._calibrated())
            parts += self._off("compass_deviation", "local deviation")
        if s.compass:
            parts.append("every reading used (no gate)" if s.compass_gate_sigmas is None else
                         f"readings beyond {s.compass_gate_sigmas:g}σ of their innovation rejected")
            parts += self._compass_trust()
        if s.compass or s.gps:
            parts.append(f"declination {math.degrees(s.declination_rad):+.2f}° ({self.declination_source})")
        else:
            parts.append("no compass or GPS")
        if self.gps_stats is not None:
            parts.append(self.gps_stats.summary())
        if s.gps and s.gps_bias is not None:
            every = s.gps_update_interval_s
            parts.append(f"GPS receiver's bias held{self._why('gps_bias')} ({s.gps_bias.describe()}; "
                         + ("every fix used)" if every == 0 else f"a fix every {every:g} s)"))
        elif s.gps:
            parts += self._off("gps_bias", "GPS receiver's bias")
        if s.compass and s.hard_iron is not None:
            parts.append(f"the shoe's hard iron learned ({s.hard_iron.describe()})")
        elif s.compass and s.compass_swing is not None:
            parts.append(f"a calibrated compass's swing held{self._why('compass_swing')} "
                         f"({s.compass_swing.describe()}, while it reads with a calibration)")
        elif s.compass:
            parts += self._off("compass_swing", "a calibrated compass's swing")
        if s.module_errors is not None:
            e = s.module_errors
            preset = preset_name(e)
            parts.append(f"module errors held{self._why('module_errors')}"
                         + ("" if preset is None else f" ({preset})")
                         + f": step-length scale σ {e.step_scale_sigma:g}, "
                         f"climb σ {e.climb_sigma:g} m/m, turn scale σ {e.turn_scale_sigma:g}"
                         + (f", heading drift σ {math.degrees(e.heading_drift_sigma) * 3600.0:.3g} °/h"
                            if e.holds_drift else "")
                         + (f", warm-up σ {math.degrees(e.heading_warmup_sigma):.3g} °/s "
                            f"(τ {e.warmup_tau_s:g} s)" if e.holds_warmup else "")
                         + self._untimed(e))
        else:
            parts += self._off("module_errors", "module errors")
        return "; ".join(parts)

    def _compass_trust(self) -> list[str]:
        """The field check's reference, and the weight of an uncalibrated compass
        (:mod:`hostlib.fusion.compass_trust`)."""
        t, s = self.tracker, self.tracker.aid_settings
        parts = []
        calibration = t._compass_calibration(t.pose_blocks[0])
        check = field_check(s, calibration)
        if check is not None:
            parts.append(f"each reading's field checked against {check.describe()}")
        elif s.compass_gate_sigmas is not None:
            parts.append("the readings' field not checked (no place and no calibration's field to "
                         "check it against)")
        if t.iron_weight_rad > 0.0 or t.iron_weight_pending:
            iron = s.uncalibrated_iron
            where = ("its first reading's" if s.magnetic_field is None
                     else f"WMM: {t.iron_weight_horizontal_ut:.1f} µT")
            what = "the local deviation's σ" if s.compass_deviation is not None else "each reading's σ"
            weight = ("" if t.iron_weight_pending else
                      f" = {math.degrees(t.iron_weight_rad):.1f}°")
            parts.append(f"compass uncalibrated (no calibration, the shoe's iron not learned): weighed for "
                         f"an unknown iron of σ {iron.sigma_ut:g} µT per axis, atan(σ / H) with H the "
                         f"horizontal field ({where}){weight} in quadrature with {what}")
        return parts

    def _untimed(self, errors: ModuleErrors) -> str:
        """What of the module's *errors* its steps could not count: a drift or a warm-up grows with the
        steps' module times, which only the fusion set-up's packets carry (one module's tracker)."""
        if not (errors.holds_drift or errors.holds_warmup) or not isinstance(self.tracker, FusionTracker):
            return ""
        times = self.tracker.step_times
        if len(times) == 0 or np.isfinite(times).any():
            return ""
        what = " and ".join(w for w, held in (("drift", errors.holds_drift), ("warm-up", errors.holds_warmup))
                            if held)
        why = self.plain_packets or ("the fusion set-up's packets do, which openshoe-host track and log "
                                     "ask for unless --no-fusion")
        return f"; its {what} not counted: no step carried the module's time ({why})"

    def _why(self, name: str) -> str:
        return " by default" if self.defaulted.get(name) == "by default" else ""

    def _off(self, name: str, what: str) -> list[str]:
        """*what* turned off where its default would hold it, with the switch that did it."""
        return [f"{what} not held (off: {DEFAULTED[name]})"] if self.defaulted.get(name) == "off" else []

    def _calibrated(self) -> str:
        if isinstance(self.tracker, FusionTracker):
            if self.tracker.settings.mag_calibration is None:
                return f" (not calibrated: {self.calibration_source})" if self.calibration_source else ""
            return f" (calibrated: {self.calibration_source})" if self.calibration_source else " (calibrated)"
        sides = [side for side in FOOT_SIDES if self.tracker.foot(side).settings.mag_calibration is not None]
        if not sides:
            return ""
        sources = self.foot_calibration_sources
        if not any(side in sources for side in sides):
            return f" (calibrated: {' and '.join(sides)} foot)"
        return " (calibrated: " + "; ".join(f"{side} foot" + (f", {sources[side]}" if side in sources else "")
                                            for side in sides) + ")"


def _deviation_name(deviation: CompassDeviation) -> str:
    """The deviation's preset word and a colon ("outdoors: "), or nothing for one's own."""
    return next((f"{word}: " for word, preset in (("outdoors", OUTDOORS), ("indoors", INDOORS))
                 if preset == deviation), "")


@dataclass
class _Plan:
    """The aids resolved from what the user has, before any tracker."""

    settings: FusionSettings
    fix_times: list[float]
    fix_positions: list[list[float]]
    place: tuple[float, float, float] | None
    declination_source: str
    gps_stats: NmeaStats | None
    defaulted: dict[str, str]

    def setup(self, tracker: FusionTracker | TwoFeetTracker) -> AidSetup:
        if self.fix_times:
            tracker.add_fixes(self.fix_times, self.fix_positions)
        return AidSetup(tracker, self.place, self.declination_source, self.gps_stats,
                        defaulted=self.defaulted)


def _plan(options: AidOptions, first_fix: GpsFix | None = None, feet: bool = False) -> _Plan:
    base = options.fusion_settings(feet)
    place = None if options.origin is None else parse_origin(options.origin)
    when = options.date
    fixes, stats = [], None
    if options.gps_log is not None:
        fixes, stats = fixes_of_log(options.gps_log)
        first_fix = fixes[0]
        when = when or next((f.date for f in fixes if f.date is not None), None)
    elif first_fix is not None:
        when = when or first_fix.date
    if first_fix is not None:
        place = fix_place(first_fix)
    day = when or dt.date.today()
    wmm = _field_at(place, day, strict=options.declination_deg is None)
    if options.declination_deg is not None:
        dec, source = float(options.declination_deg), "given"
    elif wmm is not None:
        dec = wmm.declination_deg
        source = f"WMM at {'the first fix' if first_fix is not None else 'the origin'}, {day.isoformat()}"
    else:
        dec, source = 0.0, "none: magnetic headings"
    live_gps = options.gps_receiver is not None
    cfg = replace(base, compass=options.compass, gps=bool(fixes) or live_gps,
                  declination_rad=math.radians(dec), magnetic_field=wmm)
    times, positions = [], []
    if fixes:
        assert stats is not None and stats.first_time is not None
        times = list(seconds_since(stats.first_time, fixes))
        positions = local_positions(fixes)[:, :2].tolist()
    return _Plan(cfg, times, positions, place, source, stats, options.defaulted(feet))


def _field_at(place: tuple[float, float, float] | None, day: dt.date, strict: bool) -> MagneticField | None:
    """The World Magnetic Model's field at *place* on *day* (None without a place; *strict*: a day
    outside the model's lifespan is a ValueError, else None)."""
    if place is None:
        return None
    try:
        return magnetic_field(*place, day)
    except ValueError:
        if strict:
            raise
        return None


def prepare_aids(options: AidOptions | None = None, *, last_counter: int | None = None, heading: float = 0.0,
                 first_fix: GpsFix | None = None, **fields: Any) -> AidSetup:
    """A :class:`FusionTracker` with the aids *options* ask for (:class:`~hostlib.run.options.AidOptions`;
    any of its fields may also be given as a keyword, which wins over *options*): the compass, the
    GPS log's fixes, the module's calibration (read first, when it is a file); the declination from
    the options, else the World Magnetic Model at the first fix or at the origin. A receiver read
    live (:attr:`~hostlib.run.options.AidOptions.gps_receiver`; :mod:`hostlib.run.gps_stream` queues its
    fixes): GPS updates on, no fix queued now; its *first_fix*, if one came already, places the walk
    as a log's first fix does. *heading* [rad]: the initial heading; *last_counter*: the step
    counter before the first step (None: taken from the first). Raises
    :class:`~hostlib.aids.gps.GpsLogError` (a ValueError) for a GPS log that cannot be read or
    holds no fix."""
    options = replace(options or AidOptions(), **fields)
    calibration = options.loaded_calibration()
    plan = _plan(options, first_fix)
    cfg = replace(plan.settings, mag_calibration=calibration)
    return plan.setup(FusionTracker(cfg, last_counter=last_counter, heading=heading))


def prepare_feet_aids(options: AidOptions | None = None, feet: FeetSettings | None = None, *,
                      drift: Mapping[str, DriftCalibration] | None = None, last_counter: int | None = None,
                      defer: bool = True, heading: float = 0.0, first_fix: GpsFix | None = None,
                      **fields: Any) -> AidSetup:
    """:func:`prepare_aids` for a module on each foot: a :class:`TwoFeetTracker` (*feet*, *defer*,
    *heading*, *last_counter*) with the aids on the joint filter and on each foot's tracker, each
    foot's magnetometer calibration (:attr:`~hostlib.run.options.AidOptions.foot_mag_calibrations`)
    and drift calibration (side → calibration); the GPS log's fixes are the body's. A receiver read
    live and its *first_fix*, as for :func:`prepare_aids` (:mod:`hostlib.run.gps_stream` queues its
    fixes for the body and each foot)."""
    options = replace(options or AidOptions(), **fields)
    calibrations = options.loaded_foot_calibrations()
    plan = _plan(options, first_fix, feet=True)
    tracker = TwoFeetTracker(feet, last_counter=last_counter, defer=defer, heading=heading,
                             aids=plan.settings, mag_calibrations=calibrations, drift=drift)
    return plan.setup(tracker)


def feet_tracker(options: AidOptions, feet: FeetSettings | None = None, *,
                 drift: Mapping[str, DriftCalibration] | None = None, last_counter: int | None = None,
                 defer: bool = True, heading: float = 0.0, first_fix: GpsFix | None = None
                 ) -> tuple[TwoFeetTracker, AidSetup | None]:
    """The two feet's tracker *options* ask for, with each module's *drift* calibration: with aids
    (:attr:`~hostlib.run.options.AidOptions.uses_aids` of the options resolved for two feet, whose
    module errors are held by default) the one :func:`prepare_feet_aids` sets up, and
    its :class:`AidSetup`; else a plain :class:`TwoFeetTracker`, and None."""
    if not options.resolved(feet=True).uses_aids:
        tracker = TwoFeetTracker(feet, last_counter=last_counter, defer=defer, heading=heading, drift=drift)
        return tracker, None
    aids = prepare_feet_aids(options, feet, drift=drift, last_counter=last_counter, defer=defer,
                             heading=heading, first_fix=first_fix)
    return aids.tracker, aids
