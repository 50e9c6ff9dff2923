"""pyserial's serial_for_url("openshoe://...") opens an in-process emulated module."""

from __future__ import annotations

import pytest
import serial

import firmware_sim.transports  # noqa: F401  (registers the URL handler)
from firmware_sim.transports.factory import EmulatorSettings

PING = bytes.fromhex("030003")
PING_ACK = bytes.fromhex("A00300A3")
#: "stand" builds in ~0.1 s; the walking scenarios take seconds to synthesise.
URL = "openshoe://?scenario=stand&seed=1&link=ideal&command_set=2015&speed=0"


def test_handler_is_registered():
    assert "firmware_sim.transports" in serial.protocol_handler_packages


def test_ping_in_virtual_time():
    with serial.serial_for_url(URL, timeout=0.5) as s:
        s.write(PING)
        assert s.read(4) == PING_ACK
        assert s.module.clock.ticks == 1  # the ack came on the first tick
        assert s.cd


@pytest.mark.slow
def test_the_documented_url_with_the_default_walking_scenario():
    url = "openshoe://?scenario=default&seed=1&link=ideal&command_set=2015&speed=0"
    with serial.serial_for_url(url, timeout=0.5) as s:
        s.write(PING)
        assert s.read(4) == PING_ACK
        assert type(s.module.sensors).__name__ != "ScriptedSource"


def test_unknown_scenario_is_refused():
    with pytest.raises(serial.SerialException, match="unknown scenario 'moonwalk'"):
        serial.serial_for_url("openshoe://?scenario=moonwalk")


@pytest.mark.parametrize(("recipe", "said"), [
    ("walk:1e9", "scenario: piece 1 'walk:1e9': the length m [m] must be > 0 and at most 2500, got 1e+09"),
    ("stand:inf", "scenario: piece 1 'stand:inf': the time s [s] must be > 0 and at most 1800, got inf"),
    ("stand:3+rectangle:0:0:1", "scenario: piece 2 'rectangle:0:0:1': the length l [m] must be > 0"),
])
def test_a_recipe_out_of_range_is_refused_before_anything_is_walked(recipe, said):
    with pytest.raises(serial.SerialException) as caught:
        serial.serial_for_url(f"openshoe://?scenario={recipe}")
    assert said in str(caught.value)


def test_a_plus_in_the_url_joins_the_recipe_s_pieces_as_2b_does():
    for url in ("openshoe://?scenario=stand:3+walk:10&seed=1", "openshoe://?scenario=stand:3%2Bwalk:10&seed=1"):
        assert EmulatorSettings.from_url(url).scenario == "stand:3+walk:10"


def test_bluetooth_link_in_virtual_time_is_deterministic():
    def session(seed):
        with serial.serial_for_url(f"openshoe://?scenario=stand&link=bt&seed={seed}", timeout=1.0) as s:
            s.write(PING)
            ack = s.read(4)
            s.write(bytes.fromhex("20 02 03 00 25"))  # interrupt counter every 4 ms
            data = s.read(400)
            return ack, data, s.module.clock.ticks
    a = session(5)
    assert a[0] == PING_ACK
    assert a == session(5)
    assert a[2] != session(6)[2]  # another seed, other latencies


def test_read_timeout_is_virtual_and_in_waiting_lets_time_pass():
    with serial.serial_for_url("openshoe://?scenario=stand&link=bt", timeout=0.25) as s:
        assert s.read(1) == b""  # nothing was asked for
        assert s.module.clock.ticks == 250
        s.write(PING)
        waited = 0
        while s.in_waiting < 4:
            waited += 1
            assert waited < 1000
        assert 40 <= waited <= 85  # Bluetooth round trip: 2 × (20–40 ms) + ticks
        s.reset_input_buffer()
        s.timeout = 0  # non-blocking: no ticks
        assert s.read(4) == b""


def test_2014_numbering_and_usb_interface():
    with serial.serial_for_url("openshoe://?scenario=stand&command_set=2014&link=usb", timeout=0.1) as s:
        s.write(bytes.fromhex("140014"))  # 2014 step-wise dead reckoning
        assert s.read(4) == bytes.fromhex("A01400B4")


def test_bad_urls_are_refused_clearly():
    with pytest.raises(serial.SerialException, match="unknown option 'sed'"):
        serial.serial_for_url("openshoe://?sed=1")
    with pytest.raises(serial.SerialException, match="not a number"):
        serial.serial_for_url("openshoe://?seed=x")
    with pytest.raises(serial.SerialException, match="unknown link profile"):
        serial.serial_for_url("openshoe://?link=wifi")
    with pytest.raises(serial.SerialException, match="stance_sway='2' .* is not a switch: give 1 or 0"):
        serial.serial_for_url("openshoe://?stance_sway=2")
    with pytest.raises(ValueError, match="speed"):
        EmulatorSettings.from_url("openshoe://?speed=-1")


def test_speed_inf_runs_the_module_as_fast_as_possible_and_nan_is_refused():
    with serial.serial_for_url("openshoe://?scenario=stand&link=usb&speed=inf", timeout=30) as s:
        s.write(PING)
        assert s.read(4) == PING_ACK
        assert s.pacer is not None and s.pacer.speed == float("inf") and s.pacer.status().running
    with pytest.raises(serial.SerialException, match="speed must be >= 0, got nan"):
        serial.serial_for_url("openshoe://?speed=nan")


def test_real_time_ping_with_speed_1():
    with serial.serial_for_url("openshoe://?scenario=stand&link=usb&speed=1", timeout=30) as s:
        s.write(PING)
        assert s.read(4) == PING_ACK
        assert s.pacer is not None and s.pacer.status().running
    assert not s.pacer.status().running  # closing stopped the loop


def test_closed_port_refuses_io():
    s = serial.serial_for_url(URL)
    s.close()
    with pytest.raises(serial.PortNotOpenError):
        s.write(PING)


def test_url_scenario_holds_its_last_sample_after_the_end():
    """openshoe:// plays a scenario like serve does: the sensors never go silent after it ends."""
    from firmware_sim.transports.factory import make_sensors

    source = make_sensors("stand:1", seed=1, rate_hz=1000.0)
    samples = [source.read(i) for i in range(3_000)]  # the module reads once per tick
    assert all(s is not None for s in samples), "sensors went silent after the scenario"
    end = source.ended_at
    assert end is not None and end < 3_000
    assert all((s.imu == samples[end - 1].imu).all() for s in samples[end:])
