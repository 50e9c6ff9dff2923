"""Build an emulated module, its links and the endpoints hosts reach it on, from settings.

Everything that serves a module describes it as :class:`EmulatorSettings` and
calls :func:`build`: ``openshoe-emu serve``, the ``openshoe://`` URL handler
(:mod:`.protocol_openshoe`) and the demo. The settings are checked when they are
made (:class:`SettingsError`, a ValueError naming the option).

The settings (an ``openshoe://`` URL takes those in :data:`URL_OPTIONS`)::

    scenario     sensor scenario name or recipe (firmware_sim.sensors.make_source), "default"
    seed         seed of the sensors and the link's jitter/faults, 0 (module i of several: seed + i)
    module       the simulated module's identity: its own systematic errors, the same whatever the
                 seed (firmware_sim.sensors.make_source), and its MCU serial number
                 (:func:`~firmware_sim.mcu.module.module_serial`); None: the seed's own errors, the
                 default serial (module i: module + i)
    stance_sway  1/0 (true/false, yes/no, on/off): the walking stances sway and vibrate as a real
                 foot's do (firmware_sim.sensors.stance_sway.StanceSway: ZARU then seldom holds while
                 walking, as on a real module); not with a replay; None (not given):
                 stance_sway.STANCE_SWAY_DEFAULT (on), or OPENSHOE_STANCE_SWAY
    link         "ideal", "bt" or "usb" (firmware_sim.links.profiles), "ideal"
    interface    "usb" or "bt"; default: "bt" for link=bt, else "usb"
    command_set  "2015" (current numbering) or "2014", "2015"
    speed        0 = virtual time as the host waits; s > 0 = real time × s (inf: as fast as the CPU
                 allows, in the pacer's thread), 0
    loss, corrupt   per-byte fault probabilities on both directions, 0
    stall_rate, disconnect_rate   random stalls / disconnects per second, 0
    replay       a recording (OpenShoe text or CSV) played instead of the scenario
    trace        record every frame in and out (``module.trace``), False
    pty, tcp, rfc2217   endpoints on the served interface: a pty path, (host, port) pairs
    usb_pty, usb_tcp    endpoints on the USB interface beside a served Bluetooth one
    modules      how many modules the settings describe: module i gets PATH<i> and PORT + i, 1
    feet         1, or 2: a module on each foot of one walker walking the scenario
                 (firmware_sim.sensors.feet; not with modules > 1 or a replay): module 0 is the
                 left foot, 1 the right, each with its foot's seed and identity (:func:`module_identity`),
                 on PATH-left, PATH-right and PORT, PORT + 1

The served interface gets the link; the other one is left unplugged, but for USB
endpoints beside a served Bluetooth interface, which get a USB link of their own
(no faults). Two or more endpoints on one interface share its link
(:class:`~firmware_sim.transports.hub.HostHub`).
"""

from __future__ import annotations

import os
import socket
from collections.abc import Callable
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any
from urllib.parse import parse_qs, urlsplit

from firmware_sim.links.faults import MAX_EVENT_RATE_HZ, LinkFaults
from firmware_sim.links.link import Link, make_link
from firmware_sim.links.profiles import PROFILES
from firmware_sim.mcu.clock import DEFAULT_RATE_HZ
from firmware_sim.mcu.imu_bus import SensorSource
from firmware_sim.mcu.module import MAX_MODULE, Module, ModuleConfig, module_serial
from firmware_sim.mcu.port import IdealPort, Port
from firmware_sim.nav.firmware import build_module
from firmware_sim.nav.profiles import profile_for
from firmware_sim.sensors.feet import SIDES, foot_module, foot_seed
from firmware_sim.sensors.imu_array import make_foot_source, make_source
from firmware_sim.sensors.playback import served_source
from firmware_sim.sensors.recipes import RecipeError
from firmware_sim.sensors.scenarios import check as check_scenario
from protocol.commands import COMMAND_SETS

from .hub import HostHub
from .rfc2217 import Rfc2217Endpoint
from .tcp import TcpEndpoint

#: ``(host, port)`` of a listening endpoint; port 0 = pick a free one.
Address = tuple[str, int]

#: The settings an ``openshoe://`` URL may give, in the order its error messages list them.
URL_OPTIONS = ("scenario", "seed", "module", "stance_sway", "link", "interface", "command_set", "speed",
               "loss", "corrupt")
#: How an ``openshoe://`` URL spells a switch's two values.
_SWITCH_ON, _SWITCH_OFF = ("1", "true", "yes", "on"), ("0", "false", "no", "off")

_NO_VALUE = object()


class EndpointError(OSError):
    """An endpoint that could not open: the setting that asked for it (*option*: ``tcp``,
    ``usb_pty``), where (*where*: ``127.0.0.1:5000``, a pty's path) and why (*reason*: ``Address
    already in use``). ``str()`` names the option as the settings do; :meth:`spelled` the caller's
    way (``--tcp 127.0.0.1:5000: Address already in use``)."""

    def __init__(self, option: str, where: str, reason: str):
        self.option, self.where, self.reason = option, where, reason
        super().__init__(self.spelled())

    def spelled(self, spell: Callable[[str], str] = str) -> str:
        return f"{spell(self.option)} {self.where}: {self.reason}"


class SettingsError(ValueError):
    """A refused setting. *template* has one ``{}`` per name in *options*; *got* is the bad value.

    ``str()`` names the options as :class:`EmulatorSettings` does (``speed must be >= 0,
    got -1.0``); :meth:`spelled` names them the caller's way (a command line: ``--speed``).
    """

    def __init__(self, template: str, *options: str, got: object = _NO_VALUE):
        self.template = template
        self.options = options
        self.got = got
        super().__init__(self.spelled())

    def spelled(self, spell: Callable[[str], str] = str, with_value: bool = True) -> str:
        """The message with each option written as ``spell(name)``; *with_value*: add ``, got …``."""
        text = self.template.format(*(spell(name) for name in self.options))
        if with_value and self.got is not _NO_VALUE:
            text += f", got {self.got!r}"
        return text


def _literal(value: object) -> str:
    """*value*'s repr, safe inside a :class:`SettingsError` template."""
    return repr(value).replace("{", "{{").replace("}", "}}")


@dataclass(frozen=True)
class EmulatorSettings:
    """One module (or *modules* alike, or a walker's two *feet*), its link and where hosts connect;
    checked when made."""

    scenario: str = "default"
    seed: int = 0
    module: int | None = None  #: the simulated module's identity; None: the seed's own
    #: the scenario's walking stances sway (:class:`~firmware_sim.sensors.stance_sway.StanceSway`); None:
    #: :data:`~firmware_sim.sensors.stance_sway.STANCE_SWAY_DEFAULT`
    stance_sway: bool | None = None
    link: str = "ideal"
    interface: str = ""
    command_set: str = "2015"
    speed: float = 0.0
    loss: float = 0.0
    corrupt: float = 0.0
    stall_rate: float = 0.0
    disconnect_rate: float = 0.0
    replay: str = ""
    trace: bool = False
    pty: str = ""
    tcp: Address | None = None
    rfc2217: Address | None = None
    usb_pty: str = ""
    usb_tcp: Address | None = None
    modules: int = 1
    feet: int = 1

    def __post_init__(self) -> None:
        self._check_module()
        self._check_feet()
        self._check_link()
        self._check_endpoints()

    def _check_module(self) -> None:
        if str(self.command_set) not in COMMAND_SETS:
            raise SettingsError("{} must be 2014 or 2015", "command_set", got=self.command_set)
        if not self.speed >= 0:  # NaN too
            raise SettingsError("{} must be >= 0", "speed", got=self.speed)
        if self.modules < 1:
            raise SettingsError("{} must be >= 1", "modules", got=self.modules)
        if self.module is not None:
            if self.module < 0:
                raise SettingsError("{} must be >= 0", "module", got=self.module)
            if self.module + self.modules - 1 > MAX_MODULE:
                raise SettingsError(f"{{}} + one per module must stay <= {MAX_MODULE} (the serial number has "
                                    f"8 digits)", "module", got=self.module)
            if self.replay:
                raise SettingsError("{} goes with a scenario, not {} FILE: a recording carries its own "
                                    "sensors", "module", "replay")
        if self.stance_sway not in (None, True, False):
            raise SettingsError("{} must be a switch (true or false)", "stance_sway", got=self.stance_sway)
        if self.stance_sway and self.replay:
            raise SettingsError("{} goes with a scenario, not {} FILE: a recording carries its own foot's "
                                "motion", "stance_sway", "replay")

    def _check_feet(self) -> None:
        if self.feet not in (1, 2):
            raise SettingsError("{} must be 1 or 2", "feet", got=self.feet)
        if self.feet == 1:
            return
        if self.modules > 1:
            raise SettingsError("{} 2 is one walker's two modules: it does not go with {} N", "feet",
                                "modules")
        if self.replay:
            raise SettingsError("{} 2 walks a scenario on both feet, not {} FILE: a recording is one "
                                "module's", "feet", "replay")
        identities = [module_identity(self, index) for index in range(len(SIDES))]
        if not all(0 <= identity <= MAX_MODULE for identity in identities):
            raise SettingsError(f"{{}} 2 puts modules {identities[0]} and {identities[1]} on the feet "
                                f"(2N and 2N + 1 of {{}} N, else of {{}} N); they must be 0..{MAX_MODULE}",
                                "feet", "module", "seed")

    def _check_link(self) -> None:
        if self.served_interface not in ("usb", "bt"):
            raise SettingsError("{} must be usb or bt", "interface", got=self.interface)
        if self.link.lower() not in PROFILES:
            raise SettingsError(f"unknown {{}} profile {_literal(self.link)}; known: bt, usb, ideal", "link")
        for name in ("loss", "corrupt"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise SettingsError("{} must be a probability 0..1", name, got=getattr(self, name))
        for name in ("stall_rate", "disconnect_rate"):
            if not 0 <= getattr(self, name) <= MAX_EVENT_RATE_HZ:  # NaN, inf: events every cycle
                raise SettingsError(f"{{}} must be a rate from 0 to {MAX_EVENT_RATE_HZ:g} a second", name,
                                    got=getattr(self, name))

    def _check_endpoints(self) -> None:
        if (self.usb_pty or self.usb_tcp) and self.served_interface == "usb":
            raise SettingsError("{}/{} need {} bt", "usb_pty", "usb_tcp", "interface")
        for name in ("tcp", "rfc2217", "usb_tcp"):
            address = getattr(self, name)
            if address is None:
                continue
            port = address[1]
            if not 0 <= port <= 65535:
                raise SettingsError("{} port must be 0..65535", name, got=port)
            if port and port + self.module_count - 1 > 65535:
                raise SettingsError(f"{{}} port {port} + one per module runs past 65535 with "
                                    f"{self.module_count} modules", name)

    @property
    def module_count(self) -> int:
        """How many modules the settings describe: *modules*, or one per foot."""
        return len(SIDES) if self.feet == 2 else self.modules

    def side(self, index: int) -> str | None:
        """The foot module *index* is worn on (``left``, ``right``); None when not a walker's feet."""
        return SIDES[index] if self.feet == 2 else None

    @property
    def served_interface(self) -> str:
        """The interface with the link: ``interface``, or ``bt`` for a Bluetooth link, else ``usb``."""
        if self.interface:
            return "bt" if self.interface == "bluetooth" else self.interface
        return "bt" if self.link in ("bt", "bluetooth") else "usb"

    def endpoint_requests(self) -> dict[str, dict[str, Any]]:
        """Interface → endpoint kind (:data:`ENDPOINT_KINDS`) → where, for the endpoints asked for."""
        wants: dict[str, dict[str, Any]] = {
            self.served_interface: {"pty": self.pty, "tcp": self.tcp, "rfc2217": self.rfc2217}}
        if self.served_interface == "bt":
            wants["usb"] = {"pty": self.usb_pty, "tcp": self.usb_tcp}
        asked = {iface: {kind: where for kind, where in kinds.items() if where}
                 for iface, kinds in wants.items()}
        return {iface: kinds for iface, kinds in asked.items() if kinds}

    @classmethod
    def from_url(cls, url: str) -> EmulatorSettings:
        """Parse ``openshoe://?key=value&...``; unknown keys and bad values are refused. A ``+`` is a
        ``+`` (a recipe's, ``scenario=stand:3+walk:10``), not a space as in a form's query; so is
        ``%2B``."""
        parts = urlsplit(url)
        if parts.scheme.lower() != "openshoe":
            raise ValueError(f"expected an openshoe:// URL, got {url!r}")
        types = {f.name: f.type for f in fields(cls)}
        kw: dict[str, object] = {}
        for key, values in parse_qs(parts.query.replace("+", "%2B"), keep_blank_values=True).items():
            if key not in URL_OPTIONS:
                raise ValueError(f"unknown option {key!r} in {url!r}; known: {', '.join(URL_OPTIONS)}")
            raw = values[-1]
            if types[key] in ("bool | None", "bool", bool):
                kw[key] = _switch(key, raw, url)
                continue
            try:
                if types[key] in ("int", int, "int | None"):
                    kw[key] = int(raw)
                elif types[key] in ("float", float):
                    kw[key] = float(raw)
                else:
                    kw[key] = raw
            except ValueError:
                raise ValueError(f"option {key}={raw!r} in {url!r} is not a number") from None
        settings = cls(**kw)  # type: ignore[arg-type]
        settings.check_scenario()
        return settings

    def check_scenario(self) -> None:
        """Refuse a scenario that is no name and no recipe that can be walked (unless a recording is
        played instead): a :class:`SettingsError` whose message names the piece, the number and its
        range (:mod:`firmware_sim.sensors.recipes`). Milliseconds: nothing is computed."""
        if self.replay:
            return
        try:
            check_scenario(self.scenario)
        except RecipeError as e:
            raise SettingsError("{}: " + str(e).replace("{", "{{").replace("}", "}}"), "scenario") from None


def _switch(key: str, raw: str, url: str) -> bool:
    """A URL's switch *raw* (1/0, true/false, yes/no, on/off) as a bool; ValueError naming it."""
    text = raw.strip().lower()
    if text not in _SWITCH_ON + _SWITCH_OFF:
        raise ValueError(f"option {key}={raw!r} in {url!r} is not a switch: give 1 or 0 (true/false, yes/no, "
                         f"on/off)")
    return text in _SWITCH_ON


def module_seed(settings: EmulatorSettings, index: int) -> int:
    """The seed of module *index* (its walk's draws and its links'): seed + index, or on a walker's
    feet the foot's own (:func:`~firmware_sim.sensors.feet.foot_seed`)."""
    side = settings.side(index)
    return settings.seed + index if side is None else foot_seed(settings.seed, side)


def module_identity(settings: EmulatorSettings, index: int) -> int | None:
    """The identity of module *index*: its own errors and its serial number (:func:`module_serial`).

    Module + index (None without ``module``: the seed's own errors, the default serial). On a
    walker's feet, the foot's module (:func:`~firmware_sim.sensors.feet.foot_module`) or, without
    ``module``, its seed's own, serial number included: a host tells the two feet apart by it.
    """
    side = settings.side(index)
    if side is not None:
        return module_seed(settings, index) if settings.module is None else foot_module(settings.module, side)
    return None if settings.module is None else settings.module + index


def make_sensors(scenario: str, seed: int, rate_hz: float, module: int | None = None,
                 side: str | None = None, walker_seed: int | None = None,
                 stance_sway: bool | None = None) -> SensorSource:
    """The sensor source of a scenario as a served module plays it: module *module* (None: the
    seed's own) walking the scenario with seed *seed*; with *side*, worn on that foot of the
    walker whose walk *walker_seed* draws the building
    (:func:`~firmware_sim.sensors.imu_array.make_foot_source`); *stance_sway*: its walking
    stances sway (None: the default, as :func:`~firmware_sim.sensors.imu_array.make_source`).

    The scenario starts at the module's first sensor read and the wearer then
    stands still where it ended (:func:`~firmware_sim.sensors.playback.served_source`),
    so a host never meets silent sensors after a short scenario. A host's SET_IMU_BANDWIDTH
    costs the module no more than a block of registers at a time: the walk computes the new
    setting's as the module reads them (:mod:`~firmware_sim.sensors.imu_array`), nothing ahead.
    """
    try:
        if side is None:
            source = make_source(scenario, seed=seed, rate_hz=rate_hz, module=module, stance_sway=stance_sway)
        else:
            source = make_foot_source(scenario, side, seed=seed, rate_hz=rate_hz, module=module,
                                      walker_seed=walker_seed, stance_sway=stance_sway)
    except RecipeError as e:  # an unknown name, a piece refused: its message names it
        raise ValueError(str(e)) from None
    return served_source(source)


# --------------------------------------------------------------------------- endpoints


def module_label(settings: EmulatorSettings, index: int) -> str:
    """What tells module *index* apart from the others it runs with (its READY keys, its status):
    its foot (``left``, ``right``), ``m<index>`` of several modules, "" when it runs alone."""
    side = settings.side(index)
    if side is not None:
        return side
    return "" if settings.modules == 1 else f"m{index}"


def module_path(path: str, settings: EmulatorSettings, index: int) -> str:
    """The pty path of module *index*: *path* itself when there is one module, *path* + index of
    several, *path*-side on a walker's feet (``/tmp/shoe-left``)."""
    side = settings.side(index)
    if side is not None:
        return f"{path}-{side}"
    return path if settings.modules == 1 else f"{path}{index}"


def indexed_address(address: Address, index: int) -> Address:
    """The address of module *index*: port + index (port 0 stays 0: each picks a free one)."""
    host, port = address
    return host, (port + index if port else 0)


def _address_text(address: tuple[Any, ...]) -> str:
    return f"{address[0]}:{address[1]}"


def open_pty(port: Port, path: str, settings: EmulatorSettings, index: int) -> tuple[Any, str]:
    """A pty behind a stable symlink; returns it and the path hosts open."""
    from .pty_endpoint import PtyEndpoint  # ptys are POSIX only: imported when one is asked for

    path = module_path(path, settings, index)
    return PtyEndpoint(port, path), str(Path(path))


def open_tcp(port: Port, address: Address, settings: EmulatorSettings, index: int) -> tuple[Any, str]:
    """A TCP port, one host at a time; returns it and the ``HOST:PORT`` it listens on."""
    endpoint = TcpEndpoint(port, *indexed_address(address, index))
    return endpoint, _address_text(endpoint.address)


def open_rfc2217(port: Port, address: Address, settings: EmulatorSettings, index: int) -> tuple[Any, str]:
    """An RFC 2217 port (pyserial ``rfc2217://``); returns it and the ``HOST:PORT`` it listens on."""
    endpoint = Rfc2217Endpoint(port, *indexed_address(address, index))
    return endpoint, _address_text(endpoint.address)


#: Endpoint kind → how to open one for module ``index`` of ``settings`` on a port (a link or a
#: hub's tap): ``(port, where, settings, index) -> (endpoint, where hosts connect)``.
ENDPOINT_KINDS: dict[str, Callable[[Port, Any, EmulatorSettings, int], tuple[Any, str]]] = {
    "pty": open_pty,
    "tcp": open_tcp,
    "rfc2217": open_rfc2217,
}


def _where(kind: str, where: Any, settings: EmulatorSettings, index: int) -> str:
    """Where module *index*'s endpoint of *kind* was to be: its pty's path or ``HOST:PORT``."""
    if kind == "pty":
        return module_path(where, settings, index)
    return _address_text(indexed_address(where, index))


def _reason(exc: OSError) -> str:
    """An OS error in words, without its errno and address: ``Address already in use``."""
    if isinstance(exc, EndpointError):
        return exc.reason
    if isinstance(exc, socket.gaierror) or (exc.errno or 0) < 0:  # a name that does not resolve
        return str(exc.strerror or exc).split(" (while attempting")[0]  # as socket.create_server words it
    return os.strerror(exc.errno) if exc.errno else (str(exc) or type(exc).__name__)


def open_endpoints(settings: EmulatorSettings, links: dict[str, Link],
                   index: int = 0) -> tuple[list[Any], list[tuple[str, str]]]:
    """The endpoints *settings* ask for on module *index*'s *links*, and their READY fields.

    Fields are ``(key, where)``, the key ``<interface>-<kind>``, prefixed with the module's
    :func:`module_label` and a dot when it has one (``m1.bt-pty``, ``left.bt-pty``). On failure the
    endpoints opened so far are closed, and an :class:`EndpointError` names the setting and where.
    """
    endpoints: list[Any] = []
    ready: list[tuple[str, str]] = []
    label = module_label(settings, index)
    prefix = f"{label}." if label else ""
    try:
        for iface, kinds in settings.endpoint_requests().items():
            hub = HostHub(links[iface]) if len(kinds) > 1 else None
            for kind, where in kinds.items():
                try:
                    endpoint, shown = ENDPOINT_KINDS[kind](hub.tap(kind) if hub else links[iface], where,
                                                           settings, index)
                except OSError as exc:  # a port in use, an address not this machine's, a pty's folder
                    option = kind if iface == settings.served_interface else f"{iface}_{kind}"
                    raise EndpointError(option, _where(kind, where, settings, index), _reason(exc)) from None
                endpoints.append(endpoint)
                ready.append((f"{prefix}{iface}-{kind}", shown))
    except BaseException:
        for endpoint in endpoints:
            endpoint.close()
        raise
    return endpoints, ready


# --------------------------------------------------------------------------- the module


@dataclass
class BuiltModule:
    """A module with its links (interface → link) and the endpoints hosts reach it on."""

    index: int
    interface: str  #: the served interface (the one with the settings' link)
    module: Module
    links: dict[str, Link]
    endpoints: list[Any]
    ready: list[tuple[str, str]]  #: (key, where) per endpoint, e.g. ("bt-pty", "/tmp/openshoe0")
    label: str = ""  #: what tells it apart from the others it runs with (:func:`module_label`)

    @property
    def link(self) -> Link:
        """The served interface's link."""
        return self.links[self.interface]


def _faults(settings: EmulatorSettings) -> LinkFaults | None:
    s = settings
    if not (s.loss or s.corrupt or s.stall_rate or s.disconnect_rate):
        return None
    return LinkFaults.both(byte_loss=s.loss, corrupt=s.corrupt, stall_rate_hz=s.stall_rate,
                           disconnect_rate_hz=s.disconnect_rate)


def _links(settings: EmulatorSettings, seed: int) -> dict[str, Link]:
    served = settings.served_interface
    links = {served: make_link(settings.link, seed=seed, faults=_faults(settings))}
    if settings.usb_pty or settings.usb_tcp:
        links["usb"] = make_link("usb", seed=seed)
    return links


def _sensors(settings: EmulatorSettings, index: int) -> SensorSource:
    if settings.replay:
        from firmware_sim.sensors.replay import ReplaySource

        return served_source(ReplaySource.from_file(settings.replay))
    side = settings.side(index)
    return make_sensors(settings.scenario, module_seed(settings, index), DEFAULT_RATE_HZ,
                        module_identity(settings, index), side, None if side is None else settings.seed,
                        settings.stance_sway)


def build(settings: EmulatorSettings, index: int = 0, *, sensors: SensorSource | None = None) -> BuiltModule:
    """Module *index* of *settings*: its sensors, links, the module and the endpoints asked for.

    Module *index* has seed ``settings.seed + index`` and, when ``settings.module`` is given,
    identity ``settings.module + index`` (else the seed's own); on a walker's feet, module 0 is
    the left foot and 1 the right, each with its foot's seed and identity (:func:`module_seed`,
    :func:`module_identity`). It runs at its sensors' rate
    (1 kHz for a scenario, a recording's own). *sensors*: a source to play as it is, instead of
    the settings' scenario or recording. Refused settings of the sensors (an unknown
    scenario, a bad recording) raise ValueError; endpoints that cannot open, OSError.
    """
    if sensors is None:
        sensors = _sensors(settings, index)
    links = _links(settings, module_seed(settings, index))
    config = profile_for(sensors).configure(ModuleConfig(
        rate_hz=sensors.rate_hz, command_set=settings.command_set, trace=settings.trace,
        mcu_serial=module_serial(module_identity(settings, index))))
    ports: dict[str, Port] = {k: links.get(k) or IdealPort(connected=False) for k in ("bt", "usb")}
    module = build_module(config, sensors, usb_port=ports["usb"], bt_port=ports["bt"])
    endpoints, ready = open_endpoints(settings, links, index)
    return BuiltModule(index, settings.served_interface, module, links, endpoints, ready,
                       module_label(settings, index))
