"""Carrying out a walk as a library does (hostlib.run): the options objects, the host set-up policy
without I/O (the one ``openshoe-host`` and the emulator's replayed host share), and a
:class:`~hostlib.run.tracking_run.TrackingRun` driven with :class:`~hostlib.link.device.Device`\\ s
of scripted modules (tests/hostlib/protocol_fakeshoe.py), one module and a module on each foot."""

from __future__ import annotations

import io
import math
from types import SimpleNamespace

import pytest
import serial

from hostlib.calibration.wiggle import WiggleCalibration
from hostlib.fusion.deviation import OUTDOORS, WHITE_SIGMA_RAD
from hostlib.fusion.feet import FeetSettings, TwoFeetTracker
from hostlib.fusion.gps_bias import GpsBias
from hostlib.fusion.module_errors import EMULATED_MODULE, MIMU22BT
from hostlib.fusion.settings import FusionSettings
from hostlib.link.device import Device
from hostlib.link.session import HostSession
from hostlib.run import AidOptions, HostSetup, Messages, RunOptions, SessionSetup, TrackingRun, prepare_aids
from hostlib.run.tracking_run import DeviceSetup, TrackedModule
from protocol.extensions import FUSION_SETUP, MAG_STREAM_START, MAG_STREAM_STOP, height_compensation_on
from protocol.frames import build_command, build_command_ack
from protocol.ids import Command


@pytest.fixture
def fake_schemes():
    serial.protocol_handler_packages.append("tests.hostlib")
    yield
    serial.protocol_handler_packages.remove("tests.hostlib")


def test_the_aid_options_set_the_filter_up_as_the_command_line_did():
    assert AidOptions().fusion_settings() == FusionSettings(module_errors=MIMU22BT)  # held by default
    assert AidOptions(module_errors=None).fusion_settings() == FusionSettings()
    assert AidOptions(compass_deviation=OUTDOORS, module_errors=None).fusion_settings() == FusionSettings(
        compass_sigma_rad=WHITE_SIGMA_RAD, compass_deviation=OUTDOORS)
    options = AidOptions(compass_sigma_deg=5.0, gps_bias=GpsBias(), module_errors=EMULATED_MODULE)
    assert options.fusion_settings() == FusionSettings(compass_sigma_rad=math.radians(5.0),
                                                       gps_bias=GpsBias(), module_errors=EMULATED_MODULE)
    base = FusionSettings(gps_sigma_m=7.0)
    assert AidOptions(gps_interval_s=2.0, settings=base, module_errors=None).fusion_settings() == \
        FusionSettings(gps_sigma_m=7.0, gps_interval_s=2.0)
    with pytest.raises(ValueError, match="not from both"):
        AidOptions(gps_log="walk.nmea", gps_receiver="/dev/ttyACM0")
    assert not AidOptions(declination_deg=3.0, module_errors=None).uses_aids
    assert AidOptions(declination_deg=3.0).uses_aids and AidOptions(gps_receiver="x").uses_aids


def test_a_saved_calibration_is_wanted_with_the_compass_and_no_other_calibration():
    assert AidOptions(compass=True, saved_calibration=True).wants_saved_calibration
    for other in ({"compass": False}, {"calibrate_mag": True}, {"mag_calibration": "c.json"},
                  {"foot_mag_calibrations": {"left": "c.json"}}):
        assert not AidOptions(**{"compass": True, "saved_calibration": True, **other}).wants_saved_calibration


def test_prepare_aids_takes_the_options_or_their_fields_as_keywords():
    settings = FusionSettings(gps_sigma_m=9.0)
    by_object = prepare_aids(AidOptions(compass=True, declination_deg=4.0, settings=settings))
    by_keywords = prepare_aids(compass=True, declination_deg=4.0, settings=settings)
    assert by_object.tracker.settings == by_keywords.tracker.settings
    assert by_object.tracker.settings.declination_rad == pytest.approx(math.radians(4.0))
    assert by_object.declination_source == "given"
    overridden = prepare_aids(AidOptions(compass=True), compass=False)
    assert not overridden.tracker.settings.compass, "a keyword wins over the options"


def test_run_options_refuse_no_steps():
    with pytest.raises(ValueError, match="steps"):
        RunOptions(steps=0)


def test_the_host_set_up_sends_each_command_when_it_is_due_and_once():
    wiggle = WiggleCalibration()
    setup = HostSetup(fusion=True, height_compensation=True, wiggle=wiggle)
    assert setup.after_start() == [*FUSION_SETUP, *MAG_STREAM_START]
    assert not setup.sent, "height compensation waits for the first step"
    assert setup.stepped() == [height_compensation_on()] and setup.stepped() == []
    assert setup.sent
    assert setup.stop_stream() == list(MAG_STREAM_STOP) and setup.stop_stream() == []
    assert HostSetup().after_start() == list(FUSION_SETUP), "the fusion set-up is the default, as track's"
    plain = HostSetup(fusion=False)
    assert plain.after_start() == [] and plain.stepped() == [] and plain.stop_stream() == []
    assert RunOptions().fusion, "a TrackingRun sends the fusion set-up by default, as track does"


def test_a_session_set_up_sends_the_next_command_once_the_one_before_was_acked():
    host = SessionSetup(HostSetup(fusion=True))
    assert host.start() == build_command(Command.STEPWISE_DEAD_RECKONING)
    assert host.received(b"") == (b"", b"")
    sent = [Command.STEPWISE_DEAD_RECKONING, *(meaning for meaning, _ in FUSION_SETUP)]
    for meaning, (next_meaning, next_fields) in zip(sent, [*FUSION_SETUP, (None, None)], strict=True):
        acks, command = host.received(build_command_ack(host.session.wire_id(meaning)))
        assert acks == b""
        assert command == (b"" if next_meaning is None else build_command(next_meaning, **next_fields))
    assert host.awaiting is None and not host.queue


def test_a_library_drives_one_module_through_a_tracking_run(fake_schemes):
    said = io.StringIO()
    run = TrackingRun(RunOptions(height_compensation=True, steps=5, duration_s=30.0),
                      AidOptions(compass=True), messages=Messages("walk", said))
    with run, Device("fakeshoe://5/fusion", tracker=run.tracker_for(None)) as dev:
        assert run.tracker is run.aids.tracker and dev.tracker is run.tracker
        modules = run.start(dev)
        assert [m.side for m in modules] == [None]
        run.follow()
        text, key = run.status()
    assert len(dev.track) == 5 and key == 5
    assert text.startswith("packets     5 | steps     5 |") and text.endswith("| compass 4 | GPS 0 updates")
    assert run.aids.tracker.fusion.compass_updates == 4, "the first step aligns, the four after update"
    assert said.getvalue() == "tracking on fakeshoe://5/fusion (2015 commands); Ctrl-C to stop\n"
    assert modules[0].setup.sent, "height compensation went out at the first step"


def test_a_module_speaking_the_2014_numbering_goes_without_the_fusion_set_up():
    """The 2014 numbering has no STATE_IF_SETUP: a device set-up goes on without the fusion set-up
    (the module is tracked on plain packets) and says so once, never failing the walk."""

    class Module2014:
        name = "/dev/rfcomm0"
        session = HostSession(command_set="2014")
        sent: list[Command] = []

        def command(self, meaning, **fields):
            self.session.encode_command(meaning, **fields)  # what Device.command sends first
            self.sent.append(meaning)

        def on_packet(self, fn):
            self.watcher = fn

        def remove_callback(self, fn):
            assert fn == self.watcher
            self.watcher = None

    said = io.StringIO()
    dev = Module2014()
    setup = DeviceSetup(dev, HostSetup(height_compensation=True), messages=Messages("track", said))
    setup.after_start()
    assert setup.plain_packets == ("the fusion set-up's STATE_IF_SETUP does not exist in the 2014 command "
                                   "numbering")
    assert said.getvalue() == (f"track: /dev/rfcomm0: {setup.plain_packets}; tracked on plain 0x34 step "
                               "packets (no module time, attitude or magnetometers: the module's warm-up is "
                               "not counted, and the compass, GPS and drift correction get nothing from "
                               "them)\n")
    assert dev.sent == [] and not setup.sent, "nothing more of the set-up; height compensation waits"
    assert dev.watcher is None, "no packet is looked at for the set-up's steps"


def test_a_library_drives_a_module_on_each_foot_through_a_tracking_run(fake_schemes):
    run = TrackingRun(RunOptions(steps=3, duration_s=30.0), feet=FeetSettings(),
                      messages=Messages(stream=io.StringIO()))
    with run:
        assert run.sides == ("left", "right") and isinstance(run.tracker, TwoFeetTracker)
        with Device("fakeshoe://3", tracker=run.tracker_for("left")) as left, \
                Device("fakeshoe://3", tracker=run.tracker_for("right")) as right:
            with pytest.raises(ValueError, match="a device for each"):
                run.start({"left": left})
            run.start({"right": right, "left": left})  # in any order
            run.follow()
            text, (steps, links, failed) = run.status()
    assert len(run.tracker) == 6 and steps == 6 and links == (True, True) and failed == ()
    assert text.startswith("left    3/   3 steps    3.00 m gaps 0 (missing 0) | right    3/   3 steps")


def test_a_foot_whose_link_was_lost_holds_the_end_back_again_once_it_steps():
    """The step count's stop waits for no foot whose link was lost and that sent no step since, as
    long as another foot walks; a foot back on its link that steps again is waited for again."""

    def foot(side, steps):
        dev = SimpleNamespace(session=SimpleNamespace(stats=SimpleNamespace(steps=steps)))
        return TrackedModule(side, dev, SimpleNamespace(sent=True))

    run = TrackingRun(RunOptions(steps=3), feet=FeetSettings(), messages=Messages(stream=io.StringIO()))
    left, right = run.modules = [foot("left", 1), foot("right", 3)]
    assert not left.quiet_since_link_loss and not run._enough_steps()
    left.steps_at_link_loss = 1  # (what the link's going down records)
    assert left.quiet_since_link_loss and run._enough_steps()
    left.dev.session.stats.steps = 2  # back, and stepping again: waited for
    assert not left.quiet_since_link_loss and not run._enough_steps()
    left.dev.session.stats.steps = 3
    assert run._enough_steps()
    left.steps_at_link_loss = right.steps_at_link_loss = 3
    assert not run._enough_steps(), "with every foot's link lost, no foot ends the walk"


def test_the_in_situ_calibration_goes_with_one_module_only():
    with pytest.raises(ValueError, match="one module"):
        TrackingRun(aids=AidOptions(compass=True, calibrate_mag=True), feet=FeetSettings())
