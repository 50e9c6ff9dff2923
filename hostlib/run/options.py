"""What a walk is carried out with, as two objects made once: the aids (:class:`AidOptions`) and how
the modules are driven (:class:`RunOptions`).

A program builds them from what its user said (``openshoe-host`` from its command line) and hands
them on: :class:`AidOptions` to :func:`~hostlib.run.aid_setup.prepare_aids` /
:func:`~hostlib.run.aid_setup.prepare_feet_aids` (a replay of captures) or to a
:class:`~hostlib.run.tracking_run.TrackingRun` with :class:`RunOptions` (a walk with live modules).
Both are frozen: change one with :func:`dataclasses.replace`.

**The defaults are best practice for a real module.** Four of the filter's models are held
whenever what they describe is there, unless turned off (None) or given (a model or a preset's
word): the option's default :data:`AUTO` stands for them, and :meth:`AidOptions.resolved` says what
it becomes, in this one place for the command line and the Python API alike:

* the module's systematic errors (:attr:`AidOptions.module_errors`): always, with an aid or
  without, one module or two feet, the priors of a MIMU22BT-class module from its datasheet
  (:data:`~hostlib.fusion.module_errors.MIMU22BT`). Without an aid they leave the track where the
  steps put it and widen its covariance as a module's systematic errors grow (the steps' dP alone
  is over-confident: docs/accuracy.md, "The host's defaults"); the warm-up among them needs the
  steps' module times, which only the fusion set-up's packets carry (sent by default:
  :attr:`RunOptions.fusion`);
* the compass's local deviation (:attr:`AidOptions.compass_deviation`): with the compass, outdoors'
  (:data:`~hostlib.fusion.deviation.OUTDOORS`) when GPS is used, a building's
  (:data:`~hostlib.fusion.deviation.INDOORS`) otherwise;
* the receiver's correlated error (:attr:`AidOptions.gps_bias`): with GPS, the defaults of
  :class:`~hostlib.fusion.gps_bias.GpsBias`;
* the swing a calibrated compass gains as the module warms (:attr:`AidOptions.compass_swing`): with
  the compass and one module, :data:`~hostlib.fusion.compass_swing.WARMING_SWING`, weighed and not
  learned (used only while the compass reads with a calibration).

The shoe's hard iron learned as states (:attr:`AidOptions.hard_iron`) is not among them: with an
uncalibrated shoe and nothing but the walk's turns to learn it from, its wide prior lets the
heading wander with it (on the six shared real walks, without GPS, it doubled the compass's
closure error where the three defaults alone keep it at plain's), so it is learned only when asked
for. Not learned and not calibrated, the compass is weighed for it instead
(:attr:`AidOptions.uncalibrated_weight`): an unknown iron of 10 µT turns a heading by up to
atan(10 µT / H), and the local deviation's variance takes that in (:mod:`hostlib.fusion.compass_trust`;
on NavShoe's outage loop, seeds 1–5, an uncalibrated ``--gps --compass`` then ends 2.48 % of the
distance without GPS from its start, against 3.93 % for GPS alone and 6.27 % unweighed). Nor is a
calibrated compass's swing learned (``--compass-swing``): taught by the headings alone it took
seeds 1–5 of the outage loop from 0.91 % to 0.58 %, but the held-out seeds 6–20 from 1.01 % to
1.22 %; taught by the levelled field's dip too (:mod:`hostlib.fusion.compass_dip`) it ends 0.85 %
there, but 0.70 % and 0.82 % on seeds 21–30 (calibrated first, the wiggle inside the walk) against
the default's 0.66 % and 0.66 %. What is held by default
(:attr:`AidOptions.compass_swing`) is the swing the module's warming builds after the calibration,
weighed and not learned (:data:`~hostlib.fusion.compass_swing.WARMING_SWING`): on the outage loop,
calibrated in situ, 0.76 % on seeds 1–5 and 0.93 % on seeds 6–20 against 0.91 % and 1.01 %; with
the wiggle inside the walk 0.56 % and 0.90 % against 0.71 % and 0.91 %.
"""

from __future__ import annotations

import datetime as dt
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

from ..calibration.magcal import MagCalibration
from ..fusion.compass_swing import WARMING_SWING, CompassSwing
from ..fusion.deviation import INDOORS, OUTDOORS, WHITE_SIGMA_RAD, CompassDeviation
from ..fusion.gps_bias import GpsBias
from ..fusion.hard_iron import CALIBRATED, UNCALIBRATED, HardIron
from ..fusion.module_errors import MIMU22BT, ModuleErrors
from ..fusion.settings import FusionSettings

__all__ = ["AUTO", "DEFAULTED", "AidOptions", "RunOptions"]

#: The default of the models held where best practice holds them (module docstring,
#: :meth:`AidOptions.resolved`).
AUTO = "auto"
#: The options :data:`AUTO` may stand for, and the command line's switch that turns each off.
DEFAULTED = {"module_errors": "--no-module-errors", "compass_deviation": "--no-compass-deviation",
             "gps_bias": "--no-gps-bias", "compass_swing": "--no-compass-swing"}


@dataclass(frozen=True)
class AidOptions:
    """The heading and position aids of a walk, and the magnetometer calibrations their compass
    uses (:mod:`hostlib.fusion.tracker`, :mod:`hostlib.fusion.feet`).

    A calibration may be given as a :class:`~hostlib.calibration.magcal.MagCalibration` or as its
    file, read when the aids are prepared.
    """

    #: one compass update per step, from the magnetometers and attitude at the end of each stance
    compass: bool = False
    #: 1σ of one compass reading [deg] (None: 20°, the indoor deviation; with
    #: :attr:`compass_deviation`, the reading's own white error, 1.5°)
    compass_sigma_deg: float | None = None
    #: reject a compass reading beyond 3σ of its innovation, or whose field's magnitude or
    #: inclination is not the Earth's (:mod:`hostlib.fusion.compass_trust`; False: use every reading)
    compass_gate: bool = True
    #: with the compass, no calibration and the iron not learned (:attr:`hard_iron` None): weigh the
    #: compass for an uncalibrated shoe's hard iron, :data:`~hostlib.fusion.hard_iron.UNCALIBRATED`
    #: (:attr:`FusionSettings.uncalibrated_iron <hostlib.fusion.settings.FusionSettings.uncalibrated_iron>`)
    uncalibrated_weight: bool = True
    #: the local magnetic deviation held as a state, or its preset's word (:meth:`CompassDeviation.parse
    #: <hostlib.fusion.deviation.CompassDeviation.parse>`: "outdoors", "indoors"); :data:`AUTO`: with the
    #: compass, outdoors' with GPS and a building's without; None: not held
    compass_deviation: CompassDeviation | str | None = AUTO
    #: a file of a GPS receiver's NMEA sentences, fused as a log (its first fix places the walk)
    gps_log: str | Path | None = None
    #: a GPS receiver read as it talks (a device path or pyserial URL; :mod:`hostlib.run.gps_stream`)
    gps_receiver: str | None = None
    #: the shoe's hard iron learned as states (:mod:`hostlib.fusion.hard_iron`): its prior, or
    #: :data:`AUTO` (:data:`~hostlib.fusion.hard_iron.UNCALIBRATED`, or
    #: :data:`~hostlib.fusion.hard_iron.CALIBRATED` with a calibration); None: not held (the default)
    hard_iron: HardIron | str | None = None
    #: a calibrated compass's swing B sin ψ + C cos ψ held as two states, used while the compass
    #: reads with a calibration (:mod:`hostlib.fusion.compass_swing`); :data:`AUTO` (the default): with
    #: the compass and one module, :data:`~hostlib.fusion.compass_swing.WARMING_SWING` (weighed, not
    #: learned); :data:`~hostlib.fusion.compass_swing.CALIBRATED_SWING` learns it (``--compass-swing``);
    #: None: not held
    compass_swing: CompassSwing | str | None = AUTO
    #: the receiver's correlated error held as a state (:mod:`hostlib.fusion.gps_bias`); :data:`AUTO`:
    #: with GPS, :class:`~hostlib.fusion.gps_bias.GpsBias`' defaults; None: not held
    gps_bias: GpsBias | str | None = AUTO
    #: seconds between GPS updates (None: the filter's default, :attr:`FusionSettings.gps_interval_s
    #: <hostlib.fusion.settings.FusionSettings.gps_interval_s>`)
    gps_interval_s: float | None = None
    #: the module's systematic errors held as states, or their preset's word (:meth:`ModuleErrors.parse
    #: <hostlib.fusion.module_errors.ModuleErrors.parse>`: "mimu22bt", "emulated", "emulated-still");
    #: :data:`AUTO` (the default): :data:`~hostlib.fusion.module_errors.MIMU22BT`, with an aid or without;
    #: None: not held (the plain step sum without an aid)
    module_errors: ModuleErrors | str | None = AUTO
    #: the one module's magnetometer calibration (or its file)
    mag_calibration: MagCalibration | str | Path | None = None
    #: with a module on each foot: side → that foot's magnetometer calibration (or its file)
    foot_mag_calibrations: Mapping[str, MagCalibration | str | Path] = field(default_factory=dict)
    #: with the compass and no calibration given: take each module's saved one, if there is one
    #: (:func:`hostlib.calibration.magcal.load_for_module`, once the module named itself)
    saved_calibration: bool = False
    #: calibrate the magnetometers in situ (one module: :mod:`hostlib.calibration.wiggle`); the
    #: compass waits for the wiggle to end, and the calibration is saved for the module
    calibrate_mag: bool = False
    #: where each module's calibration is kept (None: :func:`hostlib.calibration.magcal.calibration_dir`)
    mag_cal_dir: str | Path | None = None
    #: the magnetic declination [deg], east positive (None: the World Magnetic Model at the first
    #: fix or at :attr:`origin`, else 0)
    declination_deg: float | None = None
    #: where the walk starts (latitude, longitude[, altitude], or "LAT,LON[,ALT]"), without GPS
    origin: Sequence[float] | str | None = None
    #: the day of the walk, for the World Magnetic Model (None: the first fix's, else today)
    date: dt.date | None = None
    #: the filter's settings the options above are applied to (None: :class:`FusionSettings
    #: <hostlib.fusion.settings.FusionSettings>`' own): anything they do not name, e.g. the
    #: receiver's σ or its clock offset
    settings: FusionSettings | None = None

    def __post_init__(self) -> None:
        if self.gps_log is not None and self.gps_receiver is not None:
            raise ValueError("GPS fixes come from a log or from a receiver read live, not from both")

    @property
    def uses_gps(self) -> bool:
        """Whether GPS fixes are fused: from a log or from a receiver read live."""
        return self.gps_log is not None or self.gps_receiver is not None

    @property
    def uses_aids(self) -> bool:
        """Whether one module's tracker needs the fusion filter: a compass, GPS, or the module's errors
        held (by default, or given); False only for the plain step sum, every aid and the module's
        errors off (``module_errors=None``)."""
        return bool(self.compass or self.uses_gps or self.module_errors is not None)

    def resolved(self, feet: bool = False) -> AidOptions:
        """These options with each :data:`AUTO` replaced by the model it stands for (module docstring;
        *feet*: a module on each foot) and each preset's word by its model; None stays None."""
        deviation = OUTDOORS if self.uses_gps else INDOORS
        calibrated = self.mag_calibration is not None or bool(self.foot_mag_calibrations)
        iron = CALIBRATED if calibrated else UNCALIBRATED
        return replace(
            self,
            module_errors=_model(self.module_errors, MIMU22BT, ModuleErrors.parse),
            compass_deviation=_model(self.compass_deviation, deviation if self.compass else None,
                                     CompassDeviation.parse),
            hard_iron=_model(self.hard_iron, iron, _no_word("hard_iron", "a HardIron")),
            compass_swing=_model(self.compass_swing, WARMING_SWING if self.compass and not feet else None,
                                 _no_word("compass_swing", "a CompassSwing")),
            gps_bias=_model(self.gps_bias, GpsBias() if self.uses_gps else None,
                            _no_word("gps_bias", "a GpsBias")))

    def defaulted(self, feet: bool = False) -> dict[str, str]:
        """Why each model :data:`AUTO` may stand for is on or off here, where it matters: option name
        (:data:`DEFAULTED`) → "by default" (held, the default), "given" (held as asked) or "off"
        (not held, where the default would hold it). An option the walk has no use for is left out."""
        auto = replace(self, **{name: AUTO for name in DEFAULTED}).resolved(feet)
        why = {}
        for name in DEFAULTED:
            value, default = getattr(self, name), getattr(auto, name)
            if value == AUTO:
                if default is not None:
                    why[name] = "by default"
            elif value is None:
                if default is not None:
                    why[name] = "off"
            else:
                why[name] = "given"
        return why

    @property
    def wants_saved_calibration(self) -> bool:
        """Whether each module's compass takes its saved calibration: asked for, with the compass,
        no calibration given and none fitted in situ."""
        return bool(self.saved_calibration and self.compass and not self.calibrate_mag
                    and self.mag_calibration is None and not self.foot_mag_calibrations)

    def fusion_settings(self, feet: bool = False) -> FusionSettings:
        """The filter's settings the options change (the compass's σ, the deviation: σ is then only
        the white part, 1.5° unless given; the receiver's bias and interval; the module's errors),
        on :attr:`settings`, the defaults resolved (:meth:`resolved`; *feet*: a module on each foot);
        which aids are on and the declination are :func:`~hostlib.run.aid_setup.prepare_aids`'s to
        set."""
        o = self.resolved(feet)
        changes: dict[str, object] = {}
        if o.module_errors is not None:
            changes["module_errors"] = o.module_errors
        if o.gps_bias is not None:
            changes["gps_bias"] = o.gps_bias
        if o.gps_interval_s is not None:
            changes["gps_interval_s"] = o.gps_interval_s
        if not o.compass_gate:
            changes["compass_gate_sigmas"] = None
        if o.compass_swing is not None:
            changes["compass_swing"] = o.compass_swing
        if o.hard_iron is not None:
            changes["hard_iron"] = o.hard_iron
        elif o.compass and o.uncalibrated_weight:
            changes["uncalibrated_iron"] = UNCALIBRATED
        if o.compass_sigma_deg is not None or o.compass_deviation is not None:
            sigma = o.compass_sigma_deg
            changes.update(compass_sigma_rad=WHITE_SIGMA_RAD if sigma is None else math.radians(sigma),
                           compass_deviation=o.compass_deviation)
        return replace(o.settings or FusionSettings(), **changes)

    def loaded_calibration(self) -> MagCalibration | None:
        """:attr:`mag_calibration`, read from its file if it is one."""
        return _loaded(self.mag_calibration)

    def loaded_foot_calibrations(self) -> dict[str, MagCalibration]:
        """:attr:`foot_mag_calibrations`, each read from its file if it is one."""
        return {side: _loaded(cal) for side, cal in self.foot_mag_calibrations.items()}


def _model(value: object, default: object, parse: Callable[[str], object]) -> object:
    """An option's model: *default* for :data:`AUTO`, a word *parse* d, else *value* itself."""
    if isinstance(value, str):
        return default if value == AUTO else parse(value)
    return value


def _no_word(name: str, what: str) -> Callable[[str], object]:
    """The parser of an option that takes no word but :data:`AUTO`: it refuses every other."""
    def parse(text: str) -> object:
        raise ValueError(f"{name} is {what}, {AUTO!r} or None, not {text!r}")
    return parse


def _loaded(calibration: MagCalibration | str | Path | None) -> MagCalibration | None:
    if calibration is None or isinstance(calibration, MagCalibration):
        return calibration
    return MagCalibration.load(calibration)


@dataclass(frozen=True)
class RunOptions:
    """How a :class:`~hostlib.run.tracking_run.TrackingRun` drives its modules, and when the walk
    ends."""

    #: send nothing to start: sum the steps of a module that is tracking already (no 0x34, and the
    #: first step counter is taken as it comes)
    attach: bool = False
    #: after 0x34 also ask for each step's swing time, the module's time, attitude and magnetometers,
    #: and the module's serial number (:data:`protocol.extensions.FUSION_SETUP`; the default, as
    #: ``openshoe-host track``'s): needed by the compass, GPS, the drift correction, the in-situ
    #: calibration and the module's warm-up (counted on the steps' module times). False
    #: (``--no-fusion``): plain 0x34 step packets. A module that does not acknowledge the set-up is
    #: tracked on plain packets, said once (:class:`~hostlib.run.tracking_run.DeviceSetup`)
    fusion: bool = True
    #: turn the module's height compensation (function 0x25) on at the first step packet (an
    #: emulator extension)
    height_compensation: bool = False
    #: the initial heading [deg] from north towards east
    heading_deg: float = 0.0
    #: seconds to track (None: until Ctrl-C)
    duration_s: float | None = None
    #: stop once this many step packets came (from each module, but a foot whose link was lost and
    #: that sent none since; None: no limit)
    steps: int | None = None
    #: leave the module's outputs on at the end (else they are switched off)
    leave_running: bool = False

    def __post_init__(self) -> None:
        if self.steps is not None and self.steps < 1:
            raise ValueError(f"steps is a whole number ≥ 1 (or None), not {self.steps}")
