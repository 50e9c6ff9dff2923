"""openshoe-host track with the heading aids, of one module and of a module on each foot: --compass
and --gps from a receiver read live (its fixes on the module's clock; with two feet, the body's, on
each module's clock) or from a file; the CSV gets lat/lon/alt with GPS; each foot's magnetometer
calibration (a file, or the module's saved one) checked against the module on that foot; what does
not go together is refused with status 2 before any port opens. ``log --calibrate-mag`` records the
in-situ calibration's wiggle as ``track --calibrate-mag`` runs it, for ``replay`` to fit it again.

Scripted module and receiver behind pyserial URLs (tests/hostlib/protocol_fakeshoe.py,
protocol_fakegps.py); the end-to-end walk against ``openshoe-emu serve`` is in
tests/e2e/test_serve_gps.py.
"""

from __future__ import annotations

import io
import re

import pytest
import serial

from firmware_sim.sensors.gps import DEFAULT_ORIGIN
from hostlib.cli import build_parser, main
from hostlib.files.export import CSV_COLUMNS, GEO_COLUMNS

from .protocol_fakegps import epochs


@pytest.fixture(autouse=True)
def fake_schemes():
    serial.protocol_handler_packages.append("tests.hostlib")
    yield
    serial.protocol_handler_packages.remove("tests.hostlib")


def fusion_counts(text: str) -> tuple[int, int]:
    """(compass updates, GPS updates) of the summary's fusion line."""
    found = re.search(r"fusion: (\d+) compass updates .*?, (\d+) GPS updates", text)
    assert found, text
    return int(found.group(1)), int(found.group(2))


def csv_header_and_first_row(path) -> tuple[tuple[str, ...], list[str]]:
    with open(path) as f:
        return tuple(f.readline().strip().split(",")), f.readline().strip().split(",")


@pytest.mark.parametrize(("argv", "message"), [
    (["--no-fusion", "--compass"], "--compass needs the fusion set-up, which --no-fusion turns off: the "
                                   "compass needs the magnetometers and the attitude"),
    (["--no-fusion", "--gps", "/dev/gps-does-not-exist"],
     "--gps needs the fusion set-up, which --no-fusion turns off: a fix is put on the module's clock"),
    (["/dev/right-does-not-exist", "--no-fusion", "--compass", "--gps", "/dev/gps-does-not-exist"],
     "--compass needs the fusion set-up"),
    (["/dev/right-does-not-exist", "--fusion", "--compass", "--mag-cal", "l.json"],
     "--mag-cal takes one file per module with two URLs"),
    (["--fusion", "--gps-bias"], "--gps-bias needs --gps: it is the error of the receiver's fixes"),
])
def test_track_refuses_aids_it_cannot_use_before_opening_a_port(argv, message, capsys):
    assert main(["track", "/dev/left-does-not-exist", *argv], io.StringIO()) == 2
    assert message in capsys.readouterr().err


def test_two_urls_still_take_a_drift_calibration_per_foot():
    from hostlib.cli import usage_refusal

    args = build_parser().parse_args(["track", "/dev/a", "/dev/b", "--fusion", "--drift", "l.json", "r.json"])
    assert usage_refusal(args) is None


def test_track_fuses_the_compass_and_a_live_receiver_that_is_then_pulled_out(tmp_path, capsys):
    out, csv = io.StringIO(), tmp_path / "t.csv"
    argv = ["track", "fakeshoe://5/fusion", "--fusion", "--compass", "--gps", "fakegps://3",
            "--csv", str(csv), "--steps", "5", "--duration", "30"]
    assert main(argv, out) == 0
    text, err = out.getvalue(), capsys.readouterr().err
    # the three fixes came before the first step: held, put before it, applied at the next step
    # (the first places the origin; the receiver's bias is held by default, so every fix after it
    # updates: two)
    assert fusion_counts(text) == (4, 2)
    assert "3 fixes, 0 without a fix, 1 garbled (skipped)" in text
    assert "WMM at the first fix, 2026-06-01" in text, "the first fix placed the walk"
    assert err.count("the GPS receiver fakegps://3 is gone") == 1, err
    assert "packets     5 | steps     5" in text, "tracking went on without the receiver"
    header, first = csv_header_and_first_row(csv)
    assert header == CSV_COLUMNS + GEO_COLUMNS
    lat, lon = float(first[-3]), float(first[-2])
    assert abs(lat - DEFAULT_ORIGIN[0]) < 1e-6 and abs(lon - DEFAULT_ORIGIN[1]) < 1e-6


def test_track_reads_a_gps_file_as_replay_does(tmp_path):
    nmea = tmp_path / "walk.nmea"
    nmea.write_text("".join(line + "\r\n" for line in epochs(3)))
    out, csv = io.StringIO(), tmp_path / "t.csv"
    argv = ["track", "fakeshoe://4/fusion", "--fusion", "--gps", str(nmea), "--csv", str(csv),
            "--steps", "4", "--duration", "30"]
    assert main(argv, out) == 0
    assert "6 NMEA lines: 3 fixes" in out.getvalue() and "WMM at the first fix" in out.getvalue()
    assert csv_header_and_first_row(csv)[0] == CSV_COLUMNS + GEO_COLUMNS


def test_a_gps_receiver_that_is_not_there_fails_clearly(capsys):
    argv = ["track", "fakeshoe://2/fusion", "--fusion", "--gps", "/dev/gps-does-not-exist",
            "--duration", "0.5"]
    assert main(argv, io.StringIO()) == 1
    assert "cannot open the GPS receiver /dev/gps-does-not-exist" in capsys.readouterr().err


def test_track_without_the_aids_writes_the_plain_csv(tmp_path):
    csv = tmp_path / "t.csv"
    assert main(["track", "fakeshoe://2/fusion", "--fusion", "--steps", "2", "--duration", "30",
                 "--csv", str(csv)],
                io.StringIO()) == 0
    assert csv_header_and_first_row(csv)[0] == CSV_COLUMNS


def assert_the_stream_ran_from_the_fusion_set_up_to_a_stop() -> None:
    """The scripted module (the last port opened) was asked for the magnetometer stream right after
    the fusion set-up's MCU_ID, and later to stop it."""
    from protocol.extensions import MAG_STREAM_START, MAG_STREAM_STOP
    from protocol.frames import build_command

    from .protocol_fakeshoe import PORTS

    sent = PORTS[-1].commands
    start, stop = (build_command(m, **f) for (m, f) in (*MAG_STREAM_START, *MAG_STREAM_STOP))
    assert sent.index(start) == sent.index(bytes.fromhex("04 00 04")) + 1, "after the fusion set-up"
    assert stop in sent and sent.index(stop) > sent.index(start)


def test_track_calibrates_in_situ_stops_the_stream_and_a_later_walk_reuses_it(tmp_path, capsys):
    from .protocol_fakeshoe import MCU_ID

    out = io.StringIO()
    argv = ["track", "fakeshoe://5/fusion/wiggle", "--fusion", "--compass", "--calibrate-mag",
            "--mag-cal-dir", str(tmp_path), "--steps", "5", "--duration", "30"]
    assert main(argv, out) == 0
    text, err = out.getvalue(), capsys.readouterr().err
    assert_the_stream_ran_from_the_fusion_set_up_to_a_stop()
    saved = tmp_path / f"{MCU_ID.hex('-').upper()}.json"
    assert f"(calibrated: in situ, saved {saved})" in text and saved.is_file()
    assert "wiggle the shoe in one place" in err and "magnetometers calibrated from" in err
    compass, _ = fusion_counts(text)
    assert compass == 3, "the first of 5 steps ends the calibration, the next aligns, 3 update"
    again = io.StringIO()
    argv = ["track", "fakeshoe://5/fusion", "--fusion", "--compass", "--mag-cal-dir", str(tmp_path),
            "--steps", "5", "--duration", "30"]
    assert main(argv, again) == 0
    assert f"(calibrated: saved {saved})" in again.getvalue()


@pytest.mark.parametrize(("argv", "message"), [
    (["--fusion", "--calibrate-mag"], "--calibrate-mag needs --compass"),
    (["--fusion", "--compass", "--calibrate-mag", "--mag-cal", "c.json"], "give it or --mag-cal CAL.json"),
    (["/dev/right-does-not-exist", "--fusion", "--compass", "--calibrate-mag"],
     "--calibrate-mag calibrates one module: the wiggle turns one shoe in one place, standing on the other"),
])
def test_track_refuses_a_calibration_it_cannot_run_before_opening_a_port(argv, message, capsys):
    assert main(["track", "/dev/left-does-not-exist", *argv], io.StringIO()) == 2
    assert message in capsys.readouterr().err


def test_log_records_the_wiggle_saves_its_calibration_and_a_replay_fits_it_again(tmp_path, capsys):
    from .protocol_fakeshoe import MCU_ID

    raw, name = tmp_path / "cal.bin", f"{MCU_ID.hex('-').upper()}.json"
    argv = ["log", "fakeshoe://5/fusion/wiggle", "--raw", str(raw), "--start", "--fusion", "--calibrate-mag",
            "--mag-cal-dir", str(tmp_path / "live"), "--steps", "5", "--duration", "30"]
    assert main(argv, io.StringIO()) == 0
    err = capsys.readouterr().err
    assert_the_stream_ran_from_the_fusion_set_up_to_a_stop()
    assert "wiggle the shoe in one place" in err and "openshoe-host log: magnetometers calibrated from" in err
    assert f"in situ, saved {tmp_path / 'live' / name}" in err
    out = io.StringIO()
    argv = ["replay", str(raw), "--compass", "--calibrate-mag", "--mag-cal-dir", str(tmp_path / "replayed")]
    assert main(argv, out) == 0
    assert f"(calibrated: in situ, saved {tmp_path / 'replayed' / name})" in out.getvalue()
    assert (tmp_path / "replayed" / name).read_text() == (tmp_path / "live" / name).read_text(), \
        "the capture holds the readings the live fit took"


def test_log_says_when_the_capture_ends_before_the_wiggle_and_stops_the_stream(tmp_path, capsys):
    """Without 0x34 the scripted module streams the wiggle but never steps: nothing ends it."""
    argv = ["log", "fakeshoe://5/fusion/wiggle", "--raw", str(tmp_path / "cal.bin"), "--fusion",
            "--calibrate-mag", "--mag-cal-dir", str(tmp_path / "magcal"), "--duration", "0.5"]
    assert main(argv, io.StringIO()) == 0
    assert_the_stream_ran_from_the_fusion_set_up_to_a_stop()
    assert ("no step longer than 0.5 m came to end the wiggle; nothing saved"
            in capsys.readouterr().err)
    assert not (tmp_path / "magcal").exists()


def test_log_refuses_to_calibrate_without_the_fusion_set_up_before_opening_a_port(capsys):
    argv = ["log", "/dev/openshoe-does-not-exist", "--raw", "cal.bin", "--start", "--no-fusion",
            "--calibrate-mag"]
    assert main(argv, io.StringIO()) == 2
    assert ("openshoe-host log: --calibrate-mag needs the fusion set-up, which --no-fusion turns off: the "
            "calibration is saved for the module") in capsys.readouterr().err


# -- a module on each foot ------------------------------------------------------------------

#: Two scripted modules of 5 steps (1 m north each) with the fusion set-up, serial numbers 2 and 3.
FEET = ["fakeshoe://5/fusion/module2", "fakeshoe://5/fusion/module3"]


def _mag_calibration(module: int):
    """A magnetometer calibration (no iron) of ``fakeshoe://…/moduleK``."""
    import numpy as np

    from hostlib.calibration.drift import serial_text
    from hostlib.calibration.magcal import MagCalibration

    from .protocol_fakeshoe import module_id

    return MagCalibration(np.zeros(3), np.eye(3), module_serial=serial_text(module_id(module)))


def test_two_feet_fuse_each_foots_compass_and_a_live_receiver_that_is_then_pulled_out(tmp_path, capsys):
    out, geojson = io.StringIO(), tmp_path / "body.geojson"
    argv = ["track", *FEET, "--fusion", "--compass", "--gps", "fakegps://3", "--geojson", str(geojson),
            "--duration", "1.5"]
    assert main(argv, out) == 0
    text, err = out.getvalue(), capsys.readouterr().err
    # ten steps, five a foot: the first reading aligns the body's heading, the nine others (of both
    # feet) update it; the three fixes came before the first step: held, put before it, applied at
    # the next (the first places the origin; with the receiver's bias held by default the two
    # others update)
    assert fusion_counts(text) == (9, 2)
    assert ("aids: compass σ 1.5° per step, local deviation held by default (outdoors: σ 3° over 9 m); "
            "readings beyond 3σ of their innovation rejected; each reading's field checked against ") in text
    assert "compass uncalibrated (no calibration, the shoe's iron not learned): weighed for" in text
    assert "GPS receiver's bias held by default" in text
    assert "module errors held by default (mimu22bt)" in text
    assert "WMM at the first fix, 2026-06-01" in text, "the first fix placed the walk"
    assert "3 fixes, 0 without a fix, 1 garbled (skipped)" in text
    assert err.count("the GPS receiver fakegps://3 is gone") == 1, err
    for side, url in zip(("left", "right"), FEET, strict=True):
        assert f"{side} foot ({url}): 5 step packets" in text
    assert "fusion: 10 steps (left 5, right 5)" in text, "tracking went on without the receiver"
    assert '"crs": "local-enu-m"' not in geojson.read_text(), "placed on the globe at the first fix"


def test_two_feet_read_a_gps_file_as_replay_does(tmp_path):
    nmea = tmp_path / "walk.nmea"
    nmea.write_text("".join(line + "\r\n" for line in epochs(3)))
    out = io.StringIO()
    argv = ["track", *FEET, "--fusion", "--gps", str(nmea), "--steps", "5", "--duration", "30"]
    assert main(argv, out) == 0
    assert "6 NMEA lines: 3 fixes" in out.getvalue() and "WMM at the first fix" in out.getvalue()


def test_two_feet_check_each_foots_magnetometer_calibration_against_the_module_on_that_foot(tmp_path, capsys):
    files = {}
    for module in (2, 3):
        files[module] = str(tmp_path / f"mag{module}.json")
        _mag_calibration(module).save(files[module])
    base = ["track", *FEET, "--fusion", "--compass", "--steps", "5", "--duration", "30"]
    out = io.StringIO()
    assert main([*base, "--mag-cal", files[2], files[3]], out) == 0
    assert "(calibrated: left and right foot)" in out.getvalue()
    assert main([*base, "--mag-cal", "-", files[2]], io.StringIO()) == 1
    err = capsys.readouterr().err
    assert f"the right foot ({FEET[1]}): magnetometer calibration" in err
    assert "it fits the left foot's module: give the left foot's calibration first" in err
    assert main([*base, "--mag-cal", files[3], "-"], io.StringIO()) == 1
    assert f"the left foot ({FEET[0]}): magnetometer calibration" in capsys.readouterr().err


def test_two_feet_take_each_modules_saved_magnetometer_calibration(tmp_path):
    from hostlib.calibration.magcal import save_for_module

    right = save_for_module(_mag_calibration(3), tmp_path)
    out = io.StringIO()
    argv = ["track", *FEET, "--fusion", "--compass", "--mag-cal-dir", str(tmp_path), "--steps", "5",
            "--duration", "30"]
    assert main(argv, out) == 0
    assert f"(calibrated: right foot, saved {right})" in out.getvalue(), "none saved for the left module"
    left = save_for_module(_mag_calibration(2), tmp_path)
    out = io.StringIO()
    assert main(argv, out) == 0
    assert f"(calibrated: left foot, saved {left}; right foot, saved {right})" in out.getvalue()
