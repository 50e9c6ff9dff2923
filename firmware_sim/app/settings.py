"""Settings a run can vary: detector thresholds, sensor errors and noise, link faults.

A setting is a dotted name and a value; a run's settings are a tuple of ``(name, value)``
pairs, applied on top of the defaults by :func:`apply`:

``frontend.zupt_threshold``, ``frontend.zaru_threshold``
    the zero-velocity detector's thresholds TH_ZUPT / TH_ZARU (states 0x19 / 0x1A) at power-on,
    integers in LSB_f² (defaults 16000 and 16; :mod:`firmware_sim.nav.config`).
``sensors.<field>[.<field>]``
    any number or switch of :class:`~firmware_sim.sensors.config.SensorConfig`, e.g.
    ``sensors.noise`` (white noise on/off), ``sensors.drift``, ``sensors.offsets``,
    ``sensors.scale_errors``, ``sensors.temperature_effects``, ``sensors.g_sensitivity``,
    ``sensors.misalignment``, ``sensors.impacts``, ``sensors.scale_residual``,
    ``sensors.accel.noise_density_g``, ``sensors.gyro.noise_density_rad_s``,
    ``sensors.gyro.g_sensitivity_rad_s_per_g``, ``sensors.gyro.bias_random_walk_rad_s_per_sqrt_s``
    (the whole budget, with sources: ``docs/sensor-errors.md``).
    Simulated scenarios only: a recording carries its own sensor errors.
``sensors.model``
    ``default`` (the sensor-error budget) or ``ideal`` (:meth:`SensorConfig.ideal`: every error
    off, what the navigation itself loses); the other ``sensors.…`` settings apply on top of it.
``scenario.rate_hz``
    the simulated module's loop and sample rate [Hz] (default: the sweep's ``--rate``), e.g.
    1000 (the module's) against 250 (the recordings'). Scenarios only.
``scenario.stance_sway``
    whether the walking stances sway and vibrate as a real foot's do
    (:class:`firmware_sim.sensors.stance_sway.StanceSway`; default:
    :data:`~firmware_sim.sensors.stance_sway.STANCE_SWAY_DEFAULT`), e.g. ``true,false`` to see what a
    real foot's stance changes. Scenarios only.
``link.profile``
    ``ideal`` (default), ``bt`` or ``usb``: the Bluetooth interface's link model;
``link.byte_loss``, ``link.corrupt``, ``link.stall_rate_hz``, ``link.disconnect_rate_hz``
    seeded faults on both directions of that link (a ``bt`` profile unless ``link.profile``
    says otherwise); the link's seed is the run's seed. The host acknowledges what it receives
    intact, as a lossless host does; the metrics are those of the track it sums.

Values given as text (``--set name=v1,v2``) are read as the setting's type: integers for the
thresholds, ``true``/``false``/``1``/``0`` for switches, numbers for the rest.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

from firmware_sim.links.faults import MAX_EVENT_RATE_HZ
from firmware_sim.sensors.config import DEFAULT_CONFIG, IDEAL_CONFIG, SensorConfig
from protocol.ids import StateId

__all__ = ["Applied", "LINK_FAULTS", "SettingError", "apply", "check", "parse_value"]

Settings = tuple[tuple[str, Any], ...]

THRESHOLDS = {"frontend.zupt_threshold": StateId.TH_ZUPT, "frontend.zaru_threshold": StateId.TH_ZARU}
LINK_FAULTS = ("byte_loss", "corrupt", "stall_rate_hz", "disconnect_rate_hz")
LINK_PROFILES = ("ideal", "bt", "usb")
#: The sensor models a run can start from (``sensors.model``).
SENSOR_MODELS = {"default": DEFAULT_CONFIG, "ideal": IDEAL_CONFIG}
#: Settings whose values are words, and the words they take.
WORDS = {"link.profile": LINK_PROFILES, "sensors.model": tuple(SENSOR_MODELS)}
RATE = "scenario.rate_hz"
#: The link faults that are a probability per byte.
PROBABILITIES = ("link.byte_loss", "link.corrupt")
#: The largest detector threshold (the module keeps them as 32-bit unsigned states).
THRESHOLD_MAX = 2**32 - 1
STANCE_SWAY = "scenario.stance_sway"
_TRUE, _FALSE = ("true", "1", "yes", "on"), ("false", "0", "no", "off")


class SettingError(ValueError):
    """An unknown setting, or a value it cannot take."""


@dataclass
class Applied:
    """What a run's settings change: module states at boot, the sensor model, the link."""

    initial_states: dict[int, int] = field(default_factory=dict)
    sensors: SensorConfig | None = None
    link_profile: str | None = None
    link_faults: dict[str, float] = field(default_factory=dict)
    rate_hz: float | None = None  #: a simulated module's rate, when a setting says it
    stance_sway: bool | None = None  #: whether a scenario's stances sway, when a setting says it

    def make_link(self, seed: int):
        """The Bluetooth link of the run (None: the ideal port, as a plain replay)."""
        if self.link_profile in (None, "ideal") and not self.link_faults:
            return None
        from firmware_sim.links.faults import LinkFaults
        from firmware_sim.links.link import make_link

        faults = self.link_faults
        both = {k: faults[k] for k in ("byte_loss", "corrupt", "stall_rate_hz") if k in faults}
        extra = {"disconnect_rate_hz": faults["disconnect_rate_hz"]} if "disconnect_rate_hz" in faults else {}
        link_faults = LinkFaults.both(**both, **extra) if faults else None
        return make_link(self.link_profile or "bt", seed=seed, faults=link_faults)


def _sensor_field(name: str) -> tuple[list[str], Any]:
    """The attribute path under SensorConfig and the default value a ``sensors.…`` name points to."""
    path = name.split(".")[1:]
    obj: Any = DEFAULT_CONFIG
    for part in path:
        if not dataclasses.is_dataclass(obj) or part not in {f.name for f in dataclasses.fields(obj)}:
            raise SettingError(f"unknown setting {name!r}: SensorConfig has no field {'.'.join(path)!r}")
        obj = getattr(obj, part)
    if isinstance(obj, (tuple, list)) or dataclasses.is_dataclass(obj):
        raise SettingError(f"setting {name!r} is not a single number or switch")
    return path, obj


def _kind(name: str) -> type:
    if name in THRESHOLDS:
        return int
    if name in WORDS:
        return str
    if name == RATE:
        return float
    if name == STANCE_SWAY:
        return bool
    if name.startswith("link.") and name[5:] in LINK_FAULTS:
        return float
    if name.startswith("sensors."):
        return type(_sensor_field(name)[1])
    faults = ", ".join("link." + f for f in LINK_FAULTS)
    raise SettingError(f"unknown setting {name!r} (known: {', '.join(THRESHOLDS)}, sensors.model, "
                       f"sensors.<field>, {RATE}, {STANCE_SWAY}, link.profile, {faults})")


def parse_value(name: str, value: Any) -> Any:
    """*value* (text from the command line, or a TOML/JSON value) as setting *name* takes it."""
    kind = _kind(name)
    try:
        if kind is bool:
            if isinstance(value, bool):
                return value
            text = str(value).strip().lower()
            if text not in _TRUE + _FALSE:
                raise ValueError(value)
            return text in _TRUE
        if kind is int:
            number = float(value) if isinstance(value, str) else value
            if isinstance(number, bool) or number != int(number) or (
                    name in THRESHOLDS and not 0 <= int(number) <= THRESHOLD_MAX):
                raise ValueError(value)
            return int(number)
        if kind is float:
            number = float(value)
            if isinstance(value, bool) or not _in_range(name, number):
                raise ValueError(value)
            return number
        text = str(value).strip()
        if text not in WORDS[name]:
            raise ValueError(value)
        return text
    except (TypeError, ValueError, OverflowError):
        raise SettingError(f"setting {name!r} takes {_what(name, kind)}, got {value!r}") from None


def _in_range(name: str, number: float) -> bool:
    """Whether a number setting *name* can take *number*: finite; a rate > 0 (the scenario's) or from 0
    to :data:`~firmware_sim.links.faults.MAX_EVENT_RATE_HZ` (a link fault's); a probability from 0 to 1."""
    if not math.isfinite(number):
        return False
    if name == RATE:
        return number > 0
    if name in PROBABILITIES:
        return 0.0 <= number <= 1.0
    if name.startswith("link."):
        return 0 <= number <= MAX_EVENT_RATE_HZ
    return True


def _what(name: str, kind: type) -> str:
    """What values setting *name* (of *kind*) takes, as its refusal says."""
    if name == RATE:
        return "positive numbers"
    if name in WORDS:
        return f"one of {', '.join(WORDS[name])}"
    if name in PROBABILITIES:
        return "probabilities from 0 to 1"
    if name.startswith("link."):
        return f"rates from 0 to {MAX_EVENT_RATE_HZ:g} [Hz]"
    if name in THRESHOLDS:
        return f"int values from 0 to {THRESHOLD_MAX}"
    if kind is bool:
        return "bool values (true or false)"
    return f"{kind.__name__} values" + (" (finite)" if kind is float else "")


def check(names: Iterable[str], *, recordings: bool) -> None:
    """Refuse unknown names, and sensor settings for recordings (they carry their own errors)."""
    for name in names:
        _kind(name)
        if recordings and name.startswith(("sensors.", "scenario.")):
            raise SettingError(f"setting {name!r} applies to simulated scenarios only, not to recordings")


def apply(settings: Settings) -> Applied:
    """The changes a run's settings make (values already parsed by :func:`parse_value`)."""
    out = Applied()
    model = dict(settings).get("sensors.model")
    if model is not None:
        out.sensors = SENSOR_MODELS[model]
    for name, value in settings:
        if name == "sensors.model":
            continue
        if name == RATE:
            out.rate_hz = float(value)
        elif name == STANCE_SWAY:
            out.stance_sway = bool(value)
        elif name in THRESHOLDS:
            out.initial_states[int(THRESHOLDS[name])] = int(value)
        elif name == "link.profile":
            out.link_profile = value
        elif name.startswith("link."):
            out.link_faults[name[5:]] = float(value)
        else:
            out.sensors = _replace(out.sensors or DEFAULT_CONFIG, _sensor_field(name)[0], value)
    return out


def _replace(obj: Any, path: list[str], value: Any) -> Any:
    if len(path) == 1:
        return dataclasses.replace(obj, **{path[0]: value})
    return dataclasses.replace(obj, **{path[0]: _replace(getattr(obj, path[0]), path[1:], value)})
