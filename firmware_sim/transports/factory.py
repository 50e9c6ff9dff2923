"""Build an emulated module with a link model on one interface, from a few settings.

The settings are those of the ``openshoe://`` URL (and fit a CLI's options)::

    scenario     sensor scenario name (firmware_sim.sensors.make_source), "default"
    seed         seed of the sensors and the link's jitter/faults, 0
    link         "ideal", "bt" or "usb" (firmware_sim.links.link profiles), "ideal"
    interface    "usb" or "bt"; default: "bt" for link=bt, else "usb"
    command_set  "2015" (current numbering) or "2014", "2015"
    speed        0 = virtual time as the host waits; s > 0 = real time × s, 0
    loss, corrupt   per-byte fault probabilities on both directions, 0

The served interface gets the link; the other one is left unplugged.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from urllib.parse import parse_qs, urlsplit

from firmware_sim.links.link import Link, LinkFaults, make_link
from firmware_sim.mcu.imu_bus import SensorSource
from firmware_sim.mcu.module import Module, ModuleConfig
from firmware_sim.mcu.port import IdealPort
from firmware_sim.nav.firmware import build_module
from firmware_sim.sensors.imu_array import make_source
from firmware_sim.sensors.playback import served_source


@dataclass(frozen=True)
class EmulatorSettings:
    """What an ``openshoe://`` URL asks for."""

    scenario: str = "default"
    seed: int = 0
    link: str = "ideal"
    interface: str = ""
    command_set: str = "2015"
    speed: float = 0.0
    loss: float = 0.0
    corrupt: float = 0.0

    @property
    def served_interface(self) -> str:
        if self.interface:
            return self.interface
        return "bt" if self.link in ("bt", "bluetooth") else "usb"

    @classmethod
    def from_url(cls, url: str) -> EmulatorSettings:
        """Parse ``openshoe://?key=value&...``; unknown keys and bad values are refused."""
        parts = urlsplit(url)
        if parts.scheme.lower() != "openshoe":
            raise ValueError(f"expected an openshoe:// URL, got {url!r}")
        known = {f.name: f for f in fields(cls)}
        kw: dict[str, object] = {}
        for key, values in parse_qs(parts.query, keep_blank_values=True).items():
            if key not in known:
                raise ValueError(f"unknown option {key!r} in {url!r}; known: {', '.join(known)}")
            raw = values[-1]
            typ = known[key].type
            try:
                if typ in ("int", int):
                    kw[key] = int(raw)
                elif typ in ("float", float):
                    kw[key] = float(raw)
                else:
                    kw[key] = raw
            except ValueError:
                raise ValueError(f"option {key}={raw!r} in {url!r} is not a number") from None
        s = cls(**kw)  # type: ignore[arg-type]
        if s.speed < 0 or math.isnan(s.speed):
            raise ValueError(f"speed must be >= 0, got {s.speed}")
        if s.served_interface not in ("usb", "bt", "bluetooth"):
            raise ValueError(f"interface must be usb or bt, got {s.interface!r}")
        return s


def make_sensors(scenario: str, seed: int, rate_hz: float) -> SensorSource:
    """The sensor source of a scenario as a served module plays it.

    The scenario starts at the module's first sensor read and the wearer then
    stands still where it ended (:func:`~firmware_sim.sensors.playback.served_source`),
    so a host never meets silent sensors after a short scenario.
    """
    try:
        source = make_source(scenario, seed=seed, rate_hz=rate_hz)
    except KeyError as e:  # an unknown scenario name, reported as a bad option
        raise ValueError(f"unknown scenario {scenario!r}: {e}") from None
    return served_source(source)


def build(settings: EmulatorSettings) -> tuple[Module, Link]:
    """A module whose served interface has the asked-for link (connected), the other unplugged."""
    faults = None
    if settings.loss or settings.corrupt:
        faults = LinkFaults.both(byte_loss=settings.loss, corrupt=settings.corrupt)
    link = make_link(settings.link, seed=settings.seed, faults=faults)
    config = ModuleConfig(command_set=settings.command_set)
    sensors = make_sensors(settings.scenario, settings.seed, config.rate_hz)
    unplugged = IdealPort(connected=False)
    if settings.served_interface == "usb":
        module = build_module(config, sensors, usb_port=link, bt_port=unplugged)
    else:
        module = build_module(config, sensors, usb_port=unplugged, bt_port=link)
    return module, link
