"""openshoe-host with the fusion set-up: `drift calibrate`, `replay --drift`, `track
[--height-compensation] [--drift]` and `log` (which send the set-up unless --no-fusion; a module that
does not take it is tracked on plain packets), on hand-built captures and against the scripted module
of tests/hostlib/protocol_fakeshoe.py."""

from __future__ import annotations

import csv
import io
import json
import re

import numpy as np
import pytest
import serial

from hostlib.calibration.drift import DriftCalibration
from hostlib.cli import main
from hostlib.files.export import read_csv
from hostlib.files.replay import replay_capture_session
from protocol.extensions import FUSION_SETUP, height_compensation_on
from protocol.frames import build_command
from protocol.ids import Command

from . import protocol_fakeshoe
from .loops import fusion_capture, rectangle

V_ERR = (0.04, -0.03, 0.01)
SERIAL = b"OSEMU-M00000003"


@pytest.fixture(autouse=True)
def fakeshoe_scheme():
    serial.protocol_handler_packages.append("tests.hostlib")
    yield
    serial.protocol_handler_packages.remove("tests.hostlib")


def _capture(tmp_path, name: str, seed: int, serial_number: bytes | None = SERIAL, **kw) -> str:
    path = tmp_path / name
    path.write_bytes(fusion_capture(rectangle(V_ERR, seed=seed), serial_number, **kw))
    return str(path)


def _calibrate(tmp_path, *captures: str) -> tuple[int, str, str]:
    out = io.StringIO()
    cal = str(tmp_path / "cal.json")
    return main(["drift", "calibrate", *captures, "-o", cal], out), out.getvalue(), cal


def test_calibrate_writes_the_modules_drift_and_prints_each_loop(tmp_path):
    a, b = _capture(tmp_path, "a.bin", 1), _capture(tmp_path, "b.bin", 2)
    rc, text, cal_path = _calibrate(tmp_path, a, b)
    assert rc == 0
    cal = DriftCalibration.load(cal_path)
    np.testing.assert_allclose(cal.dv, np.negative(V_ERR), atol=1e-5)
    assert (cal.captures, cal.steps, cal.module_serial) == (2, 48, SERIAL)
    lines = text.splitlines()
    assert re.fullmatch(rf"{a}: 24 steps, 18\.\d\d m, T_swing \d+\.\d{{3}} s, closure 0\.\d{{3}} m "
                        r"\(Δp = \[[-+]0\.\d{3}, [-+]0\.\d{3}, [-+]0\.\d{3}\] m\)", lines[0])
    assert lines[1].startswith(f"{b}: 24 steps")
    assert lines[2].startswith("Δv = [")
    assert f"T_total {cal.t_total_s:.3f} s, 48 steps, 2 capture(s)" in lines[2]
    assert "module OSEMU-M00000003" in lines[2] and lines[3] == f"→ {cal_path}"


def test_replay_with_the_drift_closes_the_loop_one_csv_row_per_step(tmp_path):
    rc, _, cal = _calibrate(tmp_path, _capture(tmp_path, "a.bin", 1))
    walk, out_csv = _capture(tmp_path, "walk.bin", 7), tmp_path / "out.csv"
    out = io.StringIO()
    assert main(["replay", walk, "--csv", str(out_csv), "--drift", cal], out) == 0
    with out_csv.open() as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 1 + 24, "the start, then one row per step"
    track = read_csv(out_csv)
    last = [float(rows[-1][k]) for k in ("x_north_m", "y_east_m", "z_down_m")]
    np.testing.assert_array_equal(last, track.final_pose[:3])
    assert track.closure_error(horizontal=False) < 1e-4
    uncorrected = replay_capture_session(walk).tracker.track
    assert uncorrected.closure_error() > 0.3
    assert f"closure {uncorrected.closure_error():.3f} m uncorrected → 0.000 m corrected" in out.getvalue()


def test_replay_without_the_drift_writes_the_track_as_summed(tmp_path):
    walk, out_csv = _capture(tmp_path, "walk.bin", 7), tmp_path / "out.csv"
    assert main(["replay", walk, "--csv", str(out_csv)], io.StringIO()) == 0
    np.testing.assert_array_equal(read_csv(out_csv).poses, replay_capture_session(walk).tracker.track.poses)


def test_calibrate_refuses_captures_of_two_modules_naming_both(tmp_path, capsys):
    a = _capture(tmp_path, "a.bin", 1)
    b = _capture(tmp_path, "b.bin", 2, serial_number=b"OSEMU-M00000004")
    rc, _, cal = _calibrate(tmp_path, a, b)
    err = capsys.readouterr().err
    assert rc == 1 and "different modules" in err
    assert f"{a}: OSEMU-M00000003" in err and f"{b}: OSEMU-M00000004" in err
    assert not (tmp_path / "cal.json").exists()


def test_calibrate_refuses_a_capture_without_swing_times(tmp_path, capsys):
    plain = _capture(tmp_path, "plain.bin", 1, with_setup=False)
    rc, _, _ = _calibrate(tmp_path, plain)
    assert rc == 1 and f"{plain}: 24 of 24 steps have no swing time" in capsys.readouterr().err


def test_replay_refuses_another_modules_calibration(tmp_path, capsys):
    rc, _, cal = _calibrate(tmp_path, _capture(tmp_path, "a.bin", 1))
    other = _capture(tmp_path, "other.bin", 2, serial_number=b"OSEMU-M00000009")
    assert main(["replay", other, "--csv", str(tmp_path / "o.csv"), "--drift", cal], io.StringIO()) == 1
    err = capsys.readouterr().err
    assert "OSEMU-M00000003" in err and "OSEMU-M00000009" in err
    assert not (tmp_path / "o.csv").exists()


def test_replay_refuses_a_bad_calibration_file_naming_it(tmp_path, capsys):
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"format": "openshoe-drift-calibration", "version": 99}))
    walk = _capture(tmp_path, "walk.bin", 1)
    assert main(["replay", walk, "--drift", str(bad)], io.StringIO()) == 1
    assert f"{bad}: not a drift calibration: format version 99 is not supported" in capsys.readouterr().err


def test_track_refuses_drift_without_fusion_before_opening_the_port(tmp_path, capsys):
    cal = tmp_path / "cal.json"
    argv = ["track", "/dev/openshoe-does-not-exist", "--no-fusion", "--drift", str(cal)]
    assert main(argv, io.StringIO()) == 2
    assert "--drift needs the fusion set-up, which --no-fusion turns off" in capsys.readouterr().err


def _cal_file(tmp_path, dv=(-0.2, 0.0, 0.0), serial_number=protocol_fakeshoe.MCU_ID) -> str:
    path = tmp_path / "cal.json"
    DriftCalibration(dv, 10.0, 20, 1, serial_number).save(path)
    return str(path)


def test_track_with_fusion_and_drift_corrects_each_step_by_its_swing_time(tmp_path):
    out_csv = tmp_path / "live.csv"
    out = io.StringIO()
    argv = ["track", "fakeshoe://5/fusion", "--fusion", "--drift", _cal_file(tmp_path), "--steps", "5",
            "--duration", "30",
            "--csv", str(out_csv)]
    assert main(argv, out) == 0
    track = read_csv(out_csv)
    assert len(track) == 5
    swing = protocol_fakeshoe.SWING_TIME_S
    np.testing.assert_allclose(track.positions[:, 0], [1.0 * k - 0.2 * swing * k for k in range(6)])
    text = out.getvalue()
    assert "(drift-corrected)" in text and "the end moved by [-0.500, +0.000, +0.000] m" in text


def test_track_refuses_the_calibration_of_another_module(tmp_path, capsys):
    cal = _cal_file(tmp_path, serial_number=b"OSEMU-M00000042")
    argv = ["track", "fakeshoe://3/fusion", "--fusion", "--drift", cal, "--duration", "1.0"]
    assert main(argv, io.StringIO()) == 1
    err = capsys.readouterr().err
    assert "OSEMU-M00000042" in err and "10 11 12 13 14 15 16 17 18 19 1A 1B 1C 1D 1E" in err
    assert protocol_fakeshoe.PORTS[-1].commands[-1] == build_command(Command.OUTPUT_ALL_OFF), "outputs off"


def _frames(*commands) -> list[bytes]:
    return [build_command(meaning, **fields) for meaning, fields in commands]


def test_track_sends_the_fusion_set_up_after_0x34_and_height_compensation_at_the_first_step(tmp_path):
    argv = ["track", "fakeshoe://3/fusion", "--fusion", "--height-compensation", "--steps", "3",
            "--duration", "30"]
    assert main(argv, io.StringIO()) == 0
    port = protocol_fakeshoe.PORTS[-1]
    start = (Command.STEPWISE_DEAD_RECKONING, {})
    off = (Command.OUTPUT_ALL_OFF, {})
    assert port.commands == _frames(start, *FUSION_SETUP, height_compensation_on(), off)
    assert port.packet_acks[:2] == [1, 2], "the serial number packet, then the first step"


def test_track_without_options_sends_the_fusion_set_up_and_its_steps_carry_the_module_time(capsys):
    """A plain ``track`` asks for the fusion set-up after 0x34 (``--fusion`` says the same): its steps
    carry their swing time and the module's time, so the module's warm-up is counted; ``--no-fusion``
    sends 0x34 alone, as track did before."""
    start, off = (Command.STEPWISE_DEAD_RECKONING, {}), (Command.OUTPUT_ALL_OFF, {})
    for extra in ([], ["--fusion"]):
        out = io.StringIO()
        argv = ["track", "fakeshoe://2/fusion", "--steps", "2", "--duration", "30", *extra]
        assert main(argv, out) == 0
        assert protocol_fakeshoe.PORTS[-1].commands == _frames(start, *FUSION_SETUP, off)
        assert "packets     2 | steps     2" in out.getvalue()
        assert "module errors held by default" in out.getvalue() and "not counted" not in out.getvalue()
    err = capsys.readouterr().err
    assert err.count("tracking on fakeshoe://2/fusion") == 2
    assert "swing time" not in err and "plain" not in err
    out = io.StringIO()
    assert main(["track", "fakeshoe://2", "--steps", "2", "--duration", "30", "--no-fusion"], out) == 0
    assert protocol_fakeshoe.PORTS[-1].commands == _frames(start, off)
    assert "warm-up not counted: no step carried the module's time" in out.getvalue()
    assert "not sent: --no-fusion" in out.getvalue()


def test_a_module_that_ignores_the_fusion_set_up_is_tracked_on_plain_packets(capsys):
    """A module that never acknowledges STATE_IF_SETUP (a firmware without it) is tracked on its plain
    0x34 step packets: the walk goes on, said once on stderr and in the aids line; the set-up's
    MCU_ID is not waited for after it."""
    out = io.StringIO()
    argv = ["track", "fakeshoe://3/nosetup", "--steps", "3", "--duration", "30", "--ack-timeout", "0.05"]
    assert main(argv, out) == 0
    text, err = out.getvalue(), capsys.readouterr().err
    assert "packets     3 | steps     3 |     3.00 m" in text
    said = "did not acknowledge the fusion set-up's STATE_IF_SETUP (0x23; 3 attempt(s) of 0.05 s)"
    assert err.count(said) == 1 and "tracked on plain 0x34 step packets" in err, err
    assert f"warm-up not counted: no step carried the module's time (the module {said})" in text
    (setup_frame,) = _frames(FUSION_SETUP[0])
    start, off = (Command.STEPWISE_DEAD_RECKONING, {}), (Command.OUTPUT_ALL_OFF, {})
    assert protocol_fakeshoe.PORTS[-1].commands == [*_frames(start), *[setup_frame] * 3, *_frames(off)]


def test_a_real_module_answers_the_fusion_set_up_without_swing_times(capsys):
    """A real OpenShoe module acknowledges the set-up but leaves the emulator's SWING_TIME out: its
    steps are tracked on what they carry (the module's time among it: the warm-up counts), and the
    missing swing time is said once on stderr."""
    out = io.StringIO()
    assert main(["track", "fakeshoe://4/fusion/real", "--steps", "4", "--duration", "30"], out) == 0
    text, err = out.getvalue(), capsys.readouterr().err
    assert "packets     4 | steps     4 |     4.00 m" in text and "not counted" not in text
    assert err.count("its step packets carry no swing time (state 0x34 SWING_TIME") == 1, err


def test_a_logged_fusion_capture_calibrates(tmp_path):
    raw = tmp_path / "loop.bin"
    argv = ["log", "fakeshoe://4/fusion", "--start", "--fusion", "--raw", str(raw), "--steps", "4",
            "--duration", "30"]
    assert main(argv, io.StringIO()) == 0
    session = replay_capture_session(raw)
    assert session.mcu_serial == protocol_fakeshoe.MCU_ID
    np.testing.assert_array_equal(session.tracker.track.swing_times, [protocol_fakeshoe.SWING_TIME_S] * 4)
    rc, text, cal = _calibrate(tmp_path, str(raw))
    assert rc == 0 and DriftCalibration.load(cal).dv == pytest.approx((-4.0 / 2.0, 0.0, 0.0))
