"""openshoe-host replay with the heading aids: --compass, --gps FILE, --declination, --mag-cal; the
CSV keeps its local columns and adds lat/lon/alt with GPS; bad aid inputs are refused clearly."""

from __future__ import annotations

import io

import numpy as np
import pytest

from firmware_sim.sensors.gps import simulate_fixes, write_nmea
from hostlib.calibration.magcal import fit_ellipsoid
from hostlib.cli import main
from hostlib.files.export import CSV_COLUMNS, GEO_COLUMNS, read_csv

from .loops import fusion_capture, rectangle


def _capture(tmp_path, with_setup=True, name="walk.bin"):
    path = tmp_path / name
    path.write_bytes(fusion_capture(rectangle((0.0, 0.0, 0.0)), b"OSEMU-M00000003", with_setup=with_setup))
    return str(path)


def _nmea(tmp_path, garbage: bool = False):
    t = np.arange(0.0, 30.0, 0.01)
    pos = np.zeros((len(t), 3))
    path = write_nmea(tmp_path / "gps.nmea", simulate_fixes(t, pos, np.zeros_like(pos), seed=1))
    if garbage:
        with path.open("a") as f:
            f.write("$GPGGA,garbled*00\r\nnot nmea at all\r\n")
    return str(path)


def test_replay_with_the_compass_counts_its_updates_and_writes_the_local_csv(tmp_path):
    out, csv = io.StringIO(), tmp_path / "t.csv"
    args = ["replay", _capture(tmp_path), "--compass", "--declination", "0", "--csv", str(csv)]
    assert main(args, out) == 0
    text = out.getvalue()
    assert "declination +0.00° (given)" in text and "heading aligned by compass" in text
    assert "compass updates" in text
    with csv.open() as f:
        assert tuple(f.readline().strip().split(",")) == CSV_COLUMNS
    assert len(read_csv(csv)) == len(rectangle((0.0, 0.0, 0.0)).dx)


def test_replay_with_gps_places_the_track_on_the_globe(tmp_path):
    out, csv = io.StringIO(), tmp_path / "t.csv"
    assert main(["replay", _capture(tmp_path), "--compass", "--gps", _nmea(tmp_path, garbage=True),
                 "--csv", str(csv)], out) == 0
    text = out.getvalue()
    assert "WMM at the first fix, 2026-06-01" in text
    assert "2 garbled (skipped)" in text
    with csv.open() as f:
        header = tuple(f.readline().strip().split(","))
        first = f.readline().strip().split(",")
    assert header == CSV_COLUMNS + GEO_COLUMNS
    lat, lon = float(first[-3]), float(first[-2])
    assert abs(lat - 59.3498) < 1e-3 and abs(lon - 18.0707) < 1e-3  # KTH, the receiver's default
    track = read_csv(csv)
    assert len(track) > 0


def test_the_compass_on_a_capture_without_the_fusion_set_up_says_what_is_missing(tmp_path):
    out = io.StringIO()
    assert main(["replay", _capture(tmp_path, with_setup=False), "--compass"], out) == 0
    assert "record with the fusion set-up" in out.getvalue()


def test_a_gps_log_without_a_fix_or_a_bad_calibration_is_refused(tmp_path, capsys):
    empty = tmp_path / "none.nmea"
    empty.write_text("hello\r\n")
    assert main(["replay", _capture(tmp_path), "--gps", str(empty)], io.StringIO()) == 1
    assert "no GPS fix" in capsys.readouterr().err
    bad = tmp_path / "cal.json"
    bad.write_text("{}")
    assert main(["replay", _capture(tmp_path), "--compass", "--mag-cal", str(bad)], io.StringIO()) == 1
    assert "cal.json" in capsys.readouterr().err


def test_a_magnetometer_calibration_is_applied(tmp_path):
    rng = np.random.default_rng(0)
    v = rng.normal(size=(500, 3))
    v *= 51.5 / np.linalg.norm(v, axis=1, keepdims=True)
    cal = tmp_path / "cal.json"
    fit_ellipsoid(v + [3.0, 0.0, 0.0]).save(cal)
    out = io.StringIO()
    args = ["replay", _capture(tmp_path), "--compass", "--mag-cal", str(cal), "--declination", "0"]
    assert main(args, out) == 0
    assert "(calibrated)" in out.getvalue()


def test_replay_with_the_module_errors_widens_the_covariance_and_leaves_the_track(tmp_path, capsys):
    """--module-errors holds the module's step-length scale and climb: the track is the plain sum,
    its covariance grows by the distance (the rectangle's height most); malformed, refused (two
    captures: tests/hostlib/test_feet_module_errors.py)."""
    capture = _capture(tmp_path)
    plain_csv, held_csv = tmp_path / "plain.csv", tmp_path / "held.csv"
    assert main(["replay", capture, "--no-module-errors", "--csv", str(plain_csv)], io.StringIO()) == 0
    out = io.StringIO()
    assert main(["replay", capture, "--module-errors", "0.001,0.002", "--csv", str(held_csv)], out) == 0
    held_text = "module errors held: step-length scale σ 0.001, climb σ 0.002 m/m, turn scale σ 0"
    assert held_text in out.getvalue()
    plain, held = read_csv(plain_csv), read_csv(held_csv)
    np.testing.assert_allclose(held.poses, plain.poses, atol=1e-12)
    path = plain.distance
    extra_z = held.final_covariance[2, 2] - plain.final_covariance[2, 2]
    np.testing.assert_allclose(extra_z, (0.002 * path) ** 2, rtol=1e-6)
    with pytest.raises(SystemExit) as exit_:
        main(["replay", capture, "--module-errors", "0.1"], io.StringIO())
    assert exit_.value.code == 2 and "SCALE,CLIMB" in capsys.readouterr().err


def test_replay_with_the_compass_deviation_holds_it_for_one_module_or_both_feet(tmp_path, capsys):
    """--compass-deviation holds the local deviation (a preset or σ,ℓ), the compass σ then only the
    white part; with two captures one for both feet; without --compass, or malformed, refused."""
    capture = _capture(tmp_path)
    out = io.StringIO()
    args = ["replay", capture, "--compass", "--compass-deviation", "outdoors", "--declination", "0"]
    assert main(args, out) == 0
    text = out.getvalue()
    assert "compass σ 1.5° per step, local deviation held (outdoors: σ 3° over 9 m)" in text
    assert "local deviation at the end" in text
    out = io.StringIO()
    right = _capture(tmp_path, name="right.bin")  # the same walk on the other foot
    args = ["replay", capture, right, "--compass", "--compass-deviation", "5,10", "--compass-sigma", "2",
            "--declination", "0"]
    assert main(args, out) == 0
    assert "compass σ 2° per step, local deviation held (σ 5° over 10 m)" in out.getvalue()
    assert main(["replay", capture, "--compass-deviation", "indoors"], io.StringIO()) == 2
    assert "--compass-deviation needs --compass" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exit_:
        main(["replay", capture, "--compass", "--compass-deviation", "3"], io.StringIO())
    assert exit_.value.code == 2 and "SIGMA_DEG,LENGTH_M" in capsys.readouterr().err


def test_replay_with_the_gps_bias_holds_the_receivers_error_for_one_module_or_both_feet(tmp_path, capsys):
    """--gps-bias holds the receiver's bias with its defaults and uses every fix; with two captures
    one bias for the body; without --gps refused."""
    capture, nmea = _capture(tmp_path), _nmea(tmp_path)
    out = io.StringIO()
    assert main(["replay", capture, "--gps", nmea, "--gps-bias"], out) == 0
    text = out.getvalue()
    assert "GPS receiver's bias held (σ 2.1 m per axis over τ 120 s, white σ 0.3 m; every fix used)" in text
    assert "GPS bias at the end N" in text and "0 fixes between updates" in text
    out = io.StringIO()
    right = _capture(tmp_path, name="right.bin")
    assert main(["replay", capture, right, "--gps", nmea, "--gps-bias"], out) == 0
    assert "GPS bias at the end N" in out.getvalue()
    assert main(["replay", capture, "--compass", "--gps-bias"], io.StringIO()) == 2
    assert "--gps-bias needs --gps" in capsys.readouterr().err


def test_replay_with_a_heading_drift_prior_widens_the_heading_with_the_time_walked(tmp_path, capsys):
    """--module-errors' fourth number is the heading drift's 1σ in °/h: held, the heading's
    covariance grows with the time walked; the track is the plain sum."""
    capture = _capture(tmp_path)
    plain_csv, held_csv = tmp_path / "plain.csv", tmp_path / "held.csv"
    assert main(["replay", capture, "--module-errors", "0,0,0", "--csv", str(plain_csv)], io.StringIO()) == 0
    out = io.StringIO()
    assert main(["replay", capture, "--module-errors", "0,0,0,20", "--csv", str(held_csv)], out) == 0
    assert "heading drift σ 20 °/h" in out.getvalue()
    plain, held = read_csv(plain_csv), read_csv(held_csv)
    np.testing.assert_allclose(held.poses, plain.poses, atol=1e-12)
    assert held.final_covariance[3, 3] > plain.final_covariance[3, 3]
    with pytest.raises(SystemExit) as exit_:
        main(["replay", capture, "--module-errors", "0,0,0,20,1,120,7"], io.StringIO())
    assert exit_.value.code == 2 and "DRIFT_DEG_PER_H" in capsys.readouterr().err


def test_replay_with_a_warmup_prior_widens_the_heading_further_and_names_it(tmp_path):
    """--module-errors' fifth number is the gyros' warm-up 1σ in °/s (sixth: its time constant):
    held beside the drift rate, the heading's covariance ends wider still; the track is the plain
    sum, and the summary names the warm-up."""
    capture = _capture(tmp_path)
    drift_csv, warmup_csv = tmp_path / "drift.csv", tmp_path / "warmup.csv"
    assert main(["replay", capture, "--module-errors", "0,0,0,20", "--csv", str(drift_csv)],
                io.StringIO()) == 0
    out = io.StringIO()
    assert main(["replay", capture, "--module-errors", "0,0,0,20,0.05,90", "--csv", str(warmup_csv)],
                out) == 0
    assert "heading drift σ 20 °/h, warm-up σ 0.05 °/s (τ 90 s)" in out.getvalue()
    drift, warmup = read_csv(drift_csv), read_csv(warmup_csv)
    np.testing.assert_allclose(warmup.poses, drift.poses, atol=1e-12)
    assert warmup.final_covariance[3, 3] > drift.final_covariance[3, 3]
