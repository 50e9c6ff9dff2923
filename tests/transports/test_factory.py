"""EmulatorSettings refuse bad values by name; build() makes the module, its links and endpoints."""

from __future__ import annotations

import socket
import sys
from dataclasses import fields

import numpy as np
import pytest

from firmware_sim.links.link import Link
from firmware_sim.mcu.imu_bus import ScriptedSource
from firmware_sim.sensors.imu_array import make_feet_sources
from firmware_sim.sensors.playback import HoldLastSource, StartOnFirstRead
from firmware_sim.transports.factory import (
    ENDPOINT_KINDS,
    URL_OPTIONS,
    EmulatorSettings,
    SettingsError,
    build,
    indexed_address,
    module_label,
    module_path,
    module_serial,
    open_tcp,
)
from firmware_sim.transports.hub import HostTap
from firmware_sim.transports.rfc2217 import Rfc2217Endpoint
from firmware_sim.transports.tcp import TcpEndpoint

linux_only = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="ptys are tested on Linux")
LOCAL = ("127.0.0.1", 0)


def quick(**kw) -> EmulatorSettings:
    """Settings of a module that builds at once (a still wearer for one second)."""
    return EmulatorSettings(scenario="stand:1", **kw)


@pytest.fixture
def built_modules():
    """Build modules with build(); their endpoints are closed after the test."""
    made = []

    def make(settings: EmulatorSettings, index: int = 0):
        made.append(build(settings, index))
        return made[-1]

    yield make
    for b in made:
        for endpoint in b.endpoints:
            endpoint.close()


# --------------------------------------------------------------------------- settings


@pytest.mark.parametrize(("option", "value"), [
    ("speed", -1.0), ("speed", float("nan")), ("modules", 0), ("command_set", "2013"),
    ("interface", "wifi"), ("link", "wifi"), ("loss", 1.5), ("corrupt", -0.1),
    ("stall_rate", -1.0), ("disconnect_rate", float("nan")), ("tcp", ("127.0.0.1", 70000)),
    ("rfc2217", ("127.0.0.1", -1)), ("usb_tcp", ("127.0.0.1", 65536)),
])
def test_a_bad_value_is_refused_naming_its_option(option, value):
    with pytest.raises(ValueError, match=option) as caught:
        EmulatorSettings(**{option: value}, **({"interface": "bt"} if option.startswith("usb") else {}))
    assert isinstance(caught.value, SettingsError)
    assert caught.value.options[0] == option


def test_the_message_names_the_option_and_the_refused_value():
    with pytest.raises(SettingsError) as caught:
        EmulatorSettings(speed=-1.0)
    assert str(caught.value) == "speed must be >= 0, got -1.0"
    cli = caught.value.spelled(lambda name: "--" + name.replace("_", "-"), with_value=False)
    assert cli == "--speed must be >= 0"


def test_usb_endpoints_need_a_served_bluetooth_interface():
    with pytest.raises(SettingsError) as caught:
        EmulatorSettings(interface="usb", usb_pty="/tmp/x")
    assert caught.value.options == ("usb_pty", "usb_tcp", "interface")
    assert str(caught.value) == "usb_pty/usb_tcp need interface bt"
    EmulatorSettings(interface="bt", usb_pty="/tmp/x")  # beside Bluetooth they are fine


def test_ports_of_several_modules_stay_in_range():
    EmulatorSettings(tcp=("127.0.0.1", 65534), modules=2)
    EmulatorSettings(tcp=("127.0.0.1", 0), modules=100)  # each picks a free port
    with pytest.raises(SettingsError, match="tcp port 65534 .* 3 modules"):
        EmulatorSettings(tcp=("127.0.0.1", 65534), modules=3)


def test_two_feet_are_one_walker_walking_a_scenario():
    assert EmulatorSettings(feet=2).module_count == 2 and EmulatorSettings(modules=3).module_count == 3
    with pytest.raises(SettingsError, match="feet must be 1 or 2, got 3"):
        EmulatorSettings(feet=3)
    with pytest.raises(SettingsError, match="feet 2 is one walker's two modules: it does not go with "
                                            "modules N") as caught:
        EmulatorSettings(feet=2, modules=2)
    assert caught.value.options == ("feet", "modules")
    with pytest.raises(SettingsError, match="feet 2 walks a scenario on both feet, not replay") as caught:
        EmulatorSettings(feet=2, replay="walk.txt")
    assert caught.value.options == ("feet", "replay")
    with pytest.raises(SettingsError, match="feet 2 puts modules 199999998 and 199999999 on the feet"):
        EmulatorSettings(feet=2, module=99_999_999)
    with pytest.raises(SettingsError, match="feet 2 puts modules -2 and -1 on the feet"):
        EmulatorSettings(feet=2, seed=-1)
    with pytest.raises(SettingsError, match="tcp port 65535 .* 2 modules"):
        EmulatorSettings(feet=2, tcp=("127.0.0.1", 65535))


def test_the_served_interface_follows_the_link_unless_given():
    assert EmulatorSettings().served_interface == "usb"
    assert EmulatorSettings(link="bt").served_interface == "bt"
    assert EmulatorSettings(link="bluetooth").served_interface == "bt"
    assert EmulatorSettings(link="ideal", interface="bt").served_interface == "bt"
    assert EmulatorSettings(link="usb", interface="bluetooth").served_interface == "bt"


def test_a_url_gives_only_its_own_options():
    s = EmulatorSettings.from_url("openshoe://?scenario=stand&seed=3&link=bt&speed=2&loss=0.1")
    assert (s.scenario, s.seed, s.link, s.speed, s.loss) == ("stand", 3, "bt", 2.0, 0.1)
    assert s.served_interface == "bt"
    with pytest.raises(ValueError, match="unknown option 'pty'.*known: " + ", ".join(URL_OPTIONS)):
        EmulatorSettings.from_url("openshoe://?pty=/tmp/x")
    with pytest.raises(SettingsError, match="loss must be a probability"):
        EmulatorSettings.from_url("openshoe://?loss=2")


def test_a_url_names_the_simulated_module():
    assert EmulatorSettings.from_url("openshoe://?scenario=stand&seed=1&module=3").module == 3
    assert EmulatorSettings.from_url("openshoe://?seed=1").module is None, "default: the seed's own module"
    with pytest.raises(SettingsError, match="module must be >= 0, got -1") as caught:
        EmulatorSettings.from_url("openshoe://?module=-1")
    assert caught.value.options == ("module",)
    with pytest.raises(ValueError, match="module='x' .* is not a number"):
        EmulatorSettings.from_url("openshoe://?module=x")


def test_a_url_switches_the_stance_sway():
    for raw, value in (("1", True), ("true", True), ("on", True), ("0", False), ("no", False)):
        assert EmulatorSettings.from_url(f"openshoe://?scenario=walk&stance_sway={raw}").stance_sway is value
    assert EmulatorSettings.from_url("openshoe://?seed=1").stance_sway is None, "default: gait's default"
    with pytest.raises(ValueError, match="stance_sway='maybe' .* is not a switch: give 1 or 0"):
        EmulatorSettings.from_url("openshoe://?stance_sway=maybe")
    with pytest.raises(SettingsError, match="stance_sway goes with a scenario, not replay") as caught:
        EmulatorSettings(replay="walk.txt", stance_sway=True)
    assert caught.value.options == ("stance_sway", "replay")
    with pytest.raises(SettingsError, match="stance_sway must be a switch"):
        EmulatorSettings(stance_sway=2)  # type: ignore[arg-type]


def test_a_built_module_sways_in_its_stances_unless_asked_not_to():
    assert _simulated(build(quick(stance_sway=True))).trajectory.stance_sway is not None
    assert _simulated(build(quick())).trajectory.stance_sway is not None
    assert _simulated(build(quick(stance_sway=False))).trajectory.stance_sway is None
    left, right = (_simulated(build(quick(seed=3, feet=2, stance_sway=True), i)) for i in range(2))
    assert left.trajectory.stance_sway is not None and right.trajectory.stance_sway is not None


def test_a_module_identity_goes_with_a_scenario_not_a_recording():
    with pytest.raises(SettingsError, match="module goes with a scenario, not replay") as caught:
        EmulatorSettings(replay="walk.txt", module=2)
    assert caught.value.options == ("module", "replay")


def test_endpoint_requests_list_only_what_is_asked_for():
    s = EmulatorSettings(interface="bt", pty="/tmp/p", tcp=LOCAL, usb_tcp=("h", 5))
    assert s.endpoint_requests() == {"bt": {"pty": "/tmp/p", "tcp": LOCAL}, "usb": {"tcp": ("h", 5)}}
    assert EmulatorSettings().endpoint_requests() == {}
    assert EmulatorSettings(interface="usb", tcp=LOCAL).endpoint_requests() == {"usb": {"tcp": LOCAL}}


# --------------------------------------------------------------------------- the builder


def test_without_endpoints_the_served_interface_has_the_link_and_the_other_is_unplugged():
    b = build(quick(link="bt", seed=4))
    assert b.interface == "bt" and list(b.links) == ["bt"] and b.endpoints == [] and b.ready == []
    assert b.module.bt.port is b.link and isinstance(b.link, Link)
    assert not b.module.usb.port.connected
    b = build(quick(link="usb"))
    assert b.interface == "usb" and b.module.usb.port is b.link


def test_a_given_sensor_source_is_played_as_it_is():
    source = ScriptedSource(np.zeros((10, 4, 6), np.int16), rate_hz=250.0)
    b = build(EmulatorSettings(scenario="never-built"), sensors=source)
    assert b.module.sensors is source and b.module.clock.rate_hz == 250.0


def test_module_index_adds_to_the_seed():
    assert build(quick(link="bt", seed=4), 2).link.seed == build(quick(link="bt", seed=6)).link.seed


def _simulated(built):
    """The simulated source a built module plays (under served_source's wrappers)."""
    held = built.module.sensors
    assert isinstance(held, HoldLastSource) and isinstance(held.source, StartOnFirstRead)
    return held.source.source


def test_several_modules_of_one_identity_count_up_from_it_as_seeds_do():
    settings = quick(seed=10, module=5, modules=2)
    sources = [_simulated(build(settings, i)) for i in range(2)]
    assert [(s.module, s.seed) for s in sources] == [(5, 10), (6, 11)]
    assert_chips_equal(sources[1], _simulated(build(quick(seed=0, module=6))))


def test_without_a_module_identity_each_seed_is_its_own_module():
    sources = [_simulated(build(quick(seed=10, modules=2), i)) for i in range(2)]
    assert [(s.module, s.seed) for s in sources] == [(10, 10), (11, 11)]


def assert_chips_equal(a, b) -> None:
    """*a* and *b* have the same chips' errors (the same module)."""
    assert len(a.chips) == len(b.chips)
    for ca, cb in zip(a.chips, b.chips, strict=True):
        for f in fields(ca):
            assert np.array_equal(getattr(ca, f.name), getattr(cb, f.name)), f.name


def test_every_endpoint_kind_has_an_opener():
    assert set(ENDPOINT_KINDS) == {"pty", "tcp", "rfc2217"}


def test_tcp_endpoint_on_the_link(built_modules):
    b = built_modules(quick(link="usb", tcp=LOCAL))
    (endpoint,) = b.endpoints
    assert isinstance(endpoint, TcpEndpoint) and endpoint.port is b.link
    assert b.ready == [("usb-tcp", f"127.0.0.1:{endpoint.address[1]}")]


def test_rfc2217_endpoint_on_the_link(built_modules):
    b = built_modules(quick(interface="bt", rfc2217=LOCAL))
    (endpoint,) = b.endpoints
    assert isinstance(endpoint, Rfc2217Endpoint) and endpoint.port is b.link
    assert b.ready == [("bt-rfc2217", f"127.0.0.1:{endpoint.address[1]}")]


@linux_only
def test_pty_endpoint_on_the_link(built_modules, tmp_path):
    b = built_modules(quick(interface="bt", pty=str(tmp_path / "os0")))
    (endpoint,) = b.endpoints
    assert endpoint.port is b.link and (tmp_path / "os0").is_symlink()
    assert b.ready == [("bt-pty", str(tmp_path / "os0"))]


@linux_only
def test_endpoints_on_one_interface_share_its_link_through_a_hub(built_modules, tmp_path):
    b = built_modules(quick(interface="bt", link="usb", pty=str(tmp_path / "p"), tcp=LOCAL, rfc2217=LOCAL))
    assert [k for k, _ in b.ready] == ["bt-pty", "bt-tcp", "bt-rfc2217"]
    taps = [e.port for e in b.endpoints]
    assert all(isinstance(t, HostTap) for t in taps) and [t.name for t in taps] == ["pty", "tcp", "rfc2217"]
    assert len({id(t.hub) for t in taps}) == 1 and taps[0].hub.port is b.link


def test_usb_endpoints_beside_bluetooth_get_a_usb_link_of_their_own(built_modules):
    b = built_modules(quick(interface="bt", link="bt", tcp=LOCAL, usb_tcp=LOCAL))
    assert list(b.links) == ["bt", "usb"] and b.links["usb"].profile.name != b.links["bt"].profile.name
    assert [k for k, _ in b.ready] == ["bt-tcp", "usb-tcp"]
    assert b.endpoints[0].port is b.links["bt"] and b.endpoints[1].port is b.links["usb"]
    assert b.module.usb.port is b.links["usb"]


def test_paths_and_ports_carry_the_module_index():
    assert module_path("/tmp/os", EmulatorSettings(modules=3), 2) == "/tmp/os2"
    assert module_path("/tmp/os", EmulatorSettings(), 0) == "/tmp/os", "one module keeps the path as given"
    assert [module_path("/tmp/shoe", EmulatorSettings(feet=2), i) for i in (0, 1)] == ["/tmp/shoe-left",
                                                                                     "/tmp/shoe-right"]
    assert [module_label(EmulatorSettings(feet=2), i) for i in (0, 1)] == ["left", "right"]
    assert module_label(EmulatorSettings(modules=2), 1) == "m1" and module_label(EmulatorSettings(), 0) == ""
    assert indexed_address(("h", 4000), 3) == ("h", 4003)
    assert indexed_address(("h", 0), 3) == ("h", 0), "port 0: every module picks a free one"


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@linux_only
def test_several_modules_get_indexed_paths_ports_and_ready_keys(built_modules, tmp_path):
    port = _free_port()
    settings = quick(interface="bt", pty=str(tmp_path / "os"), tcp=("127.0.0.1", port - 1), modules=2)
    b = built_modules(settings, 1)
    assert b.ready == [("m1.bt-pty", str(tmp_path / "os1")), ("m1.bt-tcp", f"127.0.0.1:{port}")]
    assert (tmp_path / "os1").is_symlink()


@linux_only
def test_a_walkers_feet_each_wear_their_own_module(built_modules, tmp_path):
    settings = quick(interface="bt", pty=str(tmp_path / "shoe"), tcp=LOCAL, seed=3, module=7, feet=2)
    left, right = (built_modules(settings, i) for i in range(2))
    assert [k for k, _ in left.ready + right.ready] == ["left.bt-pty", "left.bt-tcp",
                                                        "right.bt-pty", "right.bt-tcp"]
    assert [b.ready[0][1] for b in (left, right)] == [str(tmp_path / n) for n in ("shoe-left", "shoe-right")]
    assert (left.label, right.label) == ("left", "right")
    walked = make_feet_sources("stand:1", seed=3, walker=7)
    for built, side in ((left, "left"), (right, "right")):
        source = _simulated(built)
        assert (source.module, source.seed) == (walked[side].module, walked[side].seed)
        assert np.array_equal(source.imu, walked[side].imu), "the foot's own walk, errors and seed"
        assert built.module.memory.mcu_serial == module_serial(walked[side].module)
        assert built.link.seed == walked[side].seed


def test_without_a_module_identity_each_foot_is_its_seeds_own_module_with_its_serial_number():
    left, right = (build(quick(seed=3, feet=2), i) for i in range(2))
    assert [_simulated(b).module for b in (left, right)] == [6, 7]
    assert (left.module.memory.mcu_serial, right.module.memory.mcu_serial) == (b"OSEMU-M00000006",
                                                                               b"OSEMU-M00000007")


def test_endpoints_opened_before_a_failure_are_closed(monkeypatch):
    opened = []

    def tcp(*args):
        endpoint, shown = open_tcp(*args)
        opened.append(endpoint)
        return endpoint, shown

    def refuse(*args):
        raise OSError("address in use")

    monkeypatch.setitem(ENDPOINT_KINDS, "tcp", tcp)
    monkeypatch.setitem(ENDPOINT_KINDS, "rfc2217", refuse)
    with pytest.raises(OSError, match="in use"):
        build(quick(interface="bt", tcp=LOCAL, rfc2217=LOCAL))
    assert len(opened) == 1 and opened[0].closed
