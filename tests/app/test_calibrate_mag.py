"""The in-situ magnetometer calibration end to end: ``openshoe-emu replay --scenario
navshoe-calibration --host fusion --calibrate-mag`` (the replayed host streams the magnetometers
after the fusion set-up and stops the stream at the first long step), then ``openshoe-host replay
--compass --calibrate-mag`` fits the shoe's iron from the capture, saves it for the module and
tracks with it; a later ``replay --compass`` finds it again."""

from __future__ import annotations

import io
import math

import numpy as np
import pytest

from firmware_sim.app import cli
from firmware_sim.app.batch import run_replay
from firmware_sim.mcu.module import ModuleConfig
from firmware_sim.sensors.imu_array import make_source
from firmware_sim.transports.factory import module_serial
from hostlib import cli as host_cli
from hostlib.calibration.magcal import MagCalibration
from hostlib.files.replay import replay_session
from protocol.extensions import MAG_STREAM_STATES, fusion_step_ids
from protocol.frames import CommandAck, StatePacket
from protocol.stream import decode_all

SCENARIO = "navshoe-calibration"
MODULE = 4


@pytest.fixture(scope="module")
def capture(tmp_path_factory):
    """The calibrating replay of module 4's walk, written as ``openshoe-emu replay`` writes it."""
    out = tmp_path_factory.mktemp("cal") / "cal.bin"
    argv = ["replay", "--scenario", SCENARIO, "--module", str(MODULE), "--seed", "1", "--host", "fusion",
            "--calibrate-mag", "--wire", str(out), "--quiet"]
    assert cli.main(argv) == 0
    return out


def test_the_stream_runs_from_the_fusion_set_up_to_the_first_long_step(capture):
    frames = decode_all(capture.read_bytes())
    acks = [i for i, f in enumerate(frames) if isinstance(f, CommandAck)]
    assert [frames[i].command_id for i in acks] == [0x34, 0x23, 0x04, 0x21, 0x21]
    on, off = acks[3], acks[4]
    stream_len = 16 + 3 * 6  # the quaternion and three magnetometers
    sizes = [len(f.payload) for f in frames if isinstance(f, StatePacket)]
    step_len = len(frames[next(i for i, f in enumerate(frames) if isinstance(f, StatePacket)
                               and len(f.payload) > stream_len)].payload)
    assert set(sizes) == {15, stream_len, step_len}, "serial number, stream and steps: nothing else"
    between = [f for f in frames[on:off] if isinstance(f, StatePacket)]
    assert sum(len(f.payload) == stream_len for f in between) > 2000, "62.5 Hz for ~39 s"
    assert not any(isinstance(f, StatePacket) and len(f.payload) == stream_len for f in frames[off:]), \
        "nothing streams after the stop"
    session = replay_session(capture.read_bytes())
    assert session.stats.undecoded_packets == 0 and session.stats.gaps == 0
    lengths = np.hypot(*np.diff(session.tracker.track.poses[:, :2], axis=0).T)
    last_before_stop = sum(1 for f in frames[:off]
                           if isinstance(f, StatePacket) and len(f.payload) == step_len)
    assert lengths[last_before_stop - 1] > 0.5 and (lengths[: last_before_stop - 1] < 0.5).all(), \
        "stopped at the first step longer than 0.5 m"


@pytest.fixture(scope="module")
def source():
    """Module 4's walk (seed 1), made once for this file's replays (a replay leaves it as it was)."""
    return make_source(SCENARIO, seed=1, module=MODULE)


def test_the_stream_leaves_the_steps_as_they_were(source):
    config = ModuleConfig(rate_hz=1000.0, mcu_serial=module_serial(MODULE))
    plain = replay_session(bytes(run_replay(source, config=config, announce=None, host="fusion")))
    streamed = replay_session(bytes(run_replay(source, config=config, announce=None, host="fusion",
                                               calibrate_mag=True)))
    # the same steps, every one: only the two commands' execution shifts a sample's read by
    # microseconds (its DT), which moves the track by far less than a micrometre
    assert len(streamed.tracker.track) == len(plain.tracker.track)
    np.testing.assert_allclose(streamed.tracker.track.poses, plain.tracker.track.poses, atol=1e-6)
    np.testing.assert_allclose(streamed.tracker.track.swing_times, plain.tracker.track.swing_times, atol=1e-6)
    assert streamed.plan.conditional == fusion_step_ids()
    assert set(MAG_STREAM_STATES) <= streamed.plan.candidates


def test_the_host_fits_the_shoes_iron_from_the_capture_and_tracks_with_it(capture, source, own_magcal_dir):
    out = io.StringIO()
    argv = ["replay", str(capture), "--compass", "--compass-sigma", "5", "--calibrate-mag"]
    assert host_cli.main(argv, out) == 0
    text = out.getvalue()
    saved = own_magcal_dir / f"OSEMU-M{MODULE:08d}.json"
    assert f"calibrated: in situ, saved {saved}" in text and "heading aligned by compass" in text
    assert "magnetometers calibrated from" in text
    cal = MagCalibration.load(saved)
    world = source.magnetic
    # the simulated iron: the offset within 1 µT (0.5 ± 0.2 µT over twenty modules,
    # docs/heading-aids.md), the distortion within 2 %, and its rotation, which the ellipsoid fit
    # cannot see (1.5° here) and the attitude can, within 0.5° (0.16 ± 0.06° over twenty modules)
    assert np.linalg.norm(cal.hard_iron - world.hard_iron) < 1.0
    m = cal.soft_iron @ world.soft_iron
    w, s, vt = np.linalg.svd(m)
    assert s.max() / s.min() < 1.02
    assert math.degrees(math.acos(min(1.0, (np.trace(w @ vt) - 1.0) / 2.0))) < 0.5
    assert 1.0 < cal.rotation_deg < 2.5 and "the attitude turned the field" in text
    again = io.StringIO()
    assert host_cli.main(["replay", str(capture), "--compass", "--compass-sigma", "5"], again) == 0
    assert f"(calibrated: saved {saved})" in again.getvalue()


def test_a_capture_without_the_stream_is_refused_and_tracked_uncalibrated(tmp_path, own_magcal_dir):
    plain = tmp_path / "plain.bin"
    argv = ["replay", "--scenario", "stand:3+walk:6+stand:2", "--host", "fusion", "--wire", str(plain), "-q"]
    assert cli.main(argv) == 0
    out = io.StringIO()
    assert host_cli.main(["replay", str(plain), "--compass", "--calibrate-mag"], out) == 0
    assert "no magnetometer reading came" in out.getvalue() and "navigating uncalibrated" in out.getvalue()
    assert not list(own_magcal_dir.iterdir())


def test_many_calibrating_replays_write_what_each_alone_writes(capture, tmp_path):
    """``--seeds A:B --wire-dir DIR --calibrate-mag``: every run streams the wiggle, byte for byte as
    its own ``--wire`` replay does."""
    argv = ["replay", "--scenario", SCENARIO, "--module", str(MODULE), "--seeds", "1:2", "--host", "fusion",
            "--calibrate-mag", "--wire-dir", str(tmp_path), "--quiet"]
    assert cli.main(argv) == 0
    (many,) = tmp_path.glob("*.bin")
    assert many.read_bytes() == capture.read_bytes()


@pytest.mark.parametrize(("argv", "message"), [
    (["--host", "plain", "--calibrate-mag"], "--calibrate-mag goes with --host fusion"),
    (["--host", "fusion", "--calibrate-mag", "--feet", "2"], "--calibrate-mag calibrates one module"),
])
def test_the_emulator_refuses_a_calibration_it_cannot_run(argv, message, tmp_path, capsys):
    assert cli.main(["replay", "--scenario", "stand:3", *argv, "--wire", str(tmp_path / "x.bin"), "-q"]) == 2
    assert message in capsys.readouterr().err


@pytest.mark.parametrize(("argv", "message"), [
    (["--calibrate-mag"], "--calibrate-mag needs --compass"),
    (["--compass", "--calibrate-mag", "--mag-cal", "c.json"], "give it or --mag-cal CAL.json"),
    (["right.bin", "--compass", "--calibrate-mag"], "--calibrate-mag calibrates one module"),
])
def test_the_host_refuses_what_does_not_go_with_calibrating(argv, message, capsys):
    assert host_cli.main(["replay", "left.bin", *argv], io.StringIO()) == 2
    assert message in capsys.readouterr().err


def test_the_tilt_of_the_wiggle_is_reported_with_the_calibration(capture):
    text = io.StringIO()
    host_cli.main(["replay", str(capture), "--compass", "--calibrate-mag"], text)
    coverage = float(text.getvalue().split("coverage ")[1].split("°")[0])
    assert math.isfinite(coverage) and coverage > -30.0
