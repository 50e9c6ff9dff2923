"""The GPS receiver of `openshoe-emu serve --gps-pty`, without a subprocess: its epochs come as the
module's clock reaches them, it is where the walk is since the module first read its sensors (on
the body with two feet), a reader that is not there or does not read loses whole sentences,
counted, and never holds the module up; its options are refused by name.

Virtual time: the tests move the module's clock by hand.
"""

from __future__ import annotations

import datetime as dt
import errno
import os
from dataclasses import replace

import numpy as np
import pynmea2
import pytest

from firmware_sim.app.served_gps import GpsPtyEndpoint, GpsSettings, WalkReceiver, open_gps_pty
from firmware_sim.mcu.clock import Clock
from firmware_sim.mcu.imu_bus import ScriptedSource
from firmware_sim.sensors.feet import body_truth
from firmware_sim.sensors.gps import DEFAULT_ORIGIN, DEFAULT_START, GpsErrors, Receiver
from firmware_sim.sensors.playback import StartOnFirstRead
from firmware_sim.transports.factory import EmulatorSettings, build
from hostlib.aids.gps import NmeaReader, local_positions

from .serve_args import serve_args

#: A receiver without errors: its fixes are where the walker is.
EXACT = GpsErrors(horizontal_rms_m=0.0, vertical_rms_m=0.0, white_m=0.0)
SECOND = 64_000_000  # module cycles


def _walk_north(seconds: float = 10.0,
                errors: GpsErrors = EXACT) -> tuple[Clock, StartOnFirstRead, WalkReceiver]:
    """A receiver on a walker going north at 1 m/s for *seconds*, on a 1 kHz module's clock."""
    clock = Clock(1000.0)
    walk = StartOnFirstRead(ScriptedSource(np.zeros((1, 4, 6), np.int16)))
    t = np.arange(0.0, seconds + 1e-9, 0.001)
    pos = np.column_stack([t, np.zeros_like(t), np.zeros_like(t)])
    vel = np.column_stack([np.ones_like(t), np.zeros_like(t), np.zeros_like(t)])
    return clock, walk, WalkReceiver(clock, [walk], t, pos, vel, Receiver(errors=errors))


def _seconds_of(line: str) -> float:
    """The UTC of a sentence as seconds after the receiver's start."""
    time_of_day = pynmea2.parse(line, check=True).timestamp.replace(tzinfo=None)
    start = DEFAULT_START.replace(tzinfo=None)
    return (dt.datetime.combine(start.date(), time_of_day) - start).total_seconds()


def test_each_epoch_is_told_once_the_module_clock_reaches_it():
    clock, _walk, receiver = _walk_north()
    assert receiver.due(), "epoch 0 at power-on"
    first = receiver.take_due()
    assert [s[3:6] for s in first] == ["GGA", "RMC"] and [_seconds_of(s) for s in first] == [0.0, 0.0]
    clock.spend(SECOND - 1)
    assert not receiver.due() and receiver.take_due() == []
    clock.spend(1)
    assert [_seconds_of(s) for s in receiver.take_due()] == [1.0, 1.0]
    clock.spend(3 * SECOND + SECOND // 2)  # the clock jumped: every epoch it passed, in order
    assert [_seconds_of(s) for s in receiver.take_due()] == [2.0, 2.0, 3.0, 3.0, 4.0, 4.0]
    assert receiver.epochs == 5


def test_the_receiver_is_where_the_walk_is_since_the_module_first_read_its_sensors():
    clock, walk, receiver = _walk_north(errors=replace(EXACT, outages=((1.0, 2.0),)))
    lines = receiver.take_due()
    clock.spend(2 * SECOND)
    lines += receiver.take_due()  # epochs 0 … 2: no host yet, the walker stands at the start
    walk.start = 2499  # a host started the module: sample 2499 is read at 2.5 s
    assert receiver.walk_start_s() == pytest.approx(2.5)
    for _ in range(12):
        clock.spend(SECOND)
        lines += receiver.take_due()
    reader = NmeaReader()
    fixes = reader.feed_all(lines)
    north = local_positions(fixes, DEFAULT_ORIGIN)[:, 0]
    seconds = [int(round(_seconds_of(line))) for line in lines if line[3:6] == "GGA"]
    assert seconds == list(range(15))
    # epoch 4 is 1.5 s into the walk: in the outage of 1 … 2 s of the walk
    assert reader.stats.missing_fix == 1 and len(fixes) == 14
    expected = [0, 0, 0, 0.5, 2.5, 3.5, 4.5, 5.5, 6.5, 7.5, 8.5, 9.5, 10, 10]  # the walk ends at 10 m
    np.testing.assert_allclose(north, expected, atol=0.02)  # NMEA's 1e-5 minute of latitude


def test_with_two_feet_the_receiver_is_on_the_body_and_follows_the_first_foot_to_start(tmp_path):
    settings = EmulatorSettings(scenario="stand:1+walk:3+stand:1", feet=2)
    modules = [build(settings, i).module for i in range(2)]
    endpoint = open_gps_pty(GpsSettings(str(tmp_path / "gps"), errors=EXACT), modules, settings.scenario, 0)
    try:
        left, right = (m.sensors.source.source.truth for m in modules)
        t, pos, vel, _ = body_truth(left, right)
        np.testing.assert_array_equal(endpoint.receiver.pos, pos)
        np.testing.assert_array_equal(endpoint.receiver.t, t)
        walks = [m.sensors.source for m in modules]
        assert endpoint.receiver.walks == walks and endpoint.receiver.walk_start_s() is None
        walks[1].start, walks[0].start = 999, 1499
        assert endpoint.receiver.walk_start_s() == pytest.approx(1.0)
        assert endpoint.status()["kind"] == "gps-pty" and endpoint.to_module is False
    finally:
        endpoint.close()


#: A scenario the module is built with where the walk it plays does not matter (short: quick to make).
STANDING = "stand:1"


def test_a_module_playing_no_scenario_has_no_walk_to_follow(tmp_path):
    module = build(EmulatorSettings(scenario=STANDING)).module
    module.sensors = ScriptedSource(np.zeros((1, 4, 6), np.int16))
    with pytest.raises(ValueError, match="follows a simulated walk"):
        open_gps_pty(GpsSettings(str(tmp_path / "gps")), [module], "default", 0)


def _read_dry(fd: int) -> bytes:
    out = b""
    while True:
        try:
            chunk = os.read(fd, 65536)
        except BlockingIOError:
            return out
        except OSError as e:
            if e.errno == errno.EIO:
                return out
            raise
        if not chunk:
            return out
        out += chunk


def test_a_reader_that_is_not_there_or_does_not_read_loses_whole_sentences_counted(tmp_path):
    clock, _walk, receiver = _walk_north()
    endpoint = GpsPtyEndpoint(receiver, tmp_path / "gps", backlog=1024)
    try:
        for _ in range(4):  # nobody holds the pty
            endpoint.pump()
            clock.spend(SECOND)
        assert (endpoint.sentences, endpoint.dropped_sentences, endpoint.paired) == (0, 8, False)
        reader = os.open(tmp_path / "gps", os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)  # holds, never reads
        epochs = 3000  # far more than the pty's buffers and the backlog hold
        for _ in range(epochs):
            endpoint.pump()
            clock.spend(SECOND)
        assert endpoint.paired and endpoint.dropped_sentences > 8
        assert endpoint.sentences + endpoint.dropped_sentences == 2 * (epochs + 4)
        got = _read_dry(reader)
        while endpoint._tail:  # what waited in the backlog follows once the reader reads
            endpoint.pump()
            got += _read_dry(reader)
        lines = got.decode("ascii").split("\r\n")
        assert lines[-1] == ""
        assert len(lines) - 1 == endpoint.sentences
        for line in lines[:-1]:
            pynmea2.parse(line, check=True)  # every sentence whole
        os.close(reader)
        clock.spend(SECOND)
        endpoint.pump()
        assert not endpoint.paired and endpoint.status()["dropped_sentences"] == endpoint.dropped_sentences
    finally:
        endpoint.close()
    assert not (tmp_path / "gps").exists()


def test_the_gps_options_become_settings_and_ready_and_status_name_the_receiver(tmp_path):
    from firmware_sim.app.serve import build_served_module, ready_line, settings_from_args, status_text

    s = settings_from_args(serve_args("--pty", "/tmp/shoe", "--scenario", "walk", "--gps-pty", "/tmp/gps",
                                       "--origin", "58.39,15.57,90", "--gps-outage", "30:end"))
    assert s.gps is not None and s.gps.pty == "/tmp/gps" and s.gps.origin == (58.39, 15.57, 90.0)
    assert s.gps.errors.outages == ((30.0, float("inf")),)
    plain = settings_from_args(serve_args("--pty", "/tmp/shoe"))
    assert plain.gps is None and plain.emulator.scenario == "default"
    clock, _walk, receiver = _walk_north()
    endpoint = GpsPtyEndpoint(receiver, tmp_path / "gps")
    try:
        assert ready_line([], None, endpoint) == f"READY gps-pty={tmp_path / 'gps'}"
        module = build_served_module(EmulatorSettings(scenario=STANDING, pty=str(tmp_path / "shoe")), 0)
        assert status_text([module], endpoint).endswith("|| gps off: 0 sentences, 0 dropped (epoch 0)")
        for ep in module.endpoints:
            ep.close()
    finally:
        endpoint.close()


@pytest.mark.parametrize(("argv", "message"), [
    (("--pty", "/tmp/shoe", "--gps-pty", "/tmp/gps"),
     "--gps-pty follows a simulated walk: give --scenario NAME"),
    (("--pty", "/tmp/shoe", "--gps-pty", "/tmp/gps", "--replay", "walk.txt"),
     "--gps-pty follows a simulated walk: it goes with --scenario NAME, not --replay FILE"),
    (("--pty", "/tmp/shoe", "--scenario", "walk", "--origin", "58,15"),
     "--origin and --gps-outage go with --gps-pty PATH"),
    (("--pty", "/tmp/shoe", "--scenario", "walk", "--gps-pty", "/tmp/gps", "--modules", "2"),
     "--gps-pty is on one walker: not with --modules N (a walker's two feet: --feet 2)"),
    (("--pty", "/tmp/shoe", "--scenario", "walk", "--gps-pty", "/tmp/gps", "--origin", "north"),
     "--origin: origin is LAT,LON[,ALT]"),
    (("--pty", "/tmp/shoe", "--scenario", "walk", "--gps-pty", "/tmp/gps", "--gps-outage", "9"),
     "--gps-outage: a GPS outage is START:END"),
])
def test_gps_options_that_do_not_fit_exit_with_status_2_and_say_why(argv, message, capsys):
    from firmware_sim.app.serve import main

    assert main(serve_args(*argv)) == 2
    captured = capsys.readouterr()
    assert captured.err.startswith("openshoe-emu serve: " + message) and captured.out == ""
