"""The simulated GPS receiver: fixes of the true walk with a receiver's errors, as NMEA a host reads."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from firmware_sim.app import cli
from firmware_sim.sensors.gps import DEFAULT_ORIGIN, Fix, GpsErrors, nmea_lines, parse_outages, simulate_fixes
from hostlib.aids.gps import NmeaReader, local_positions, read_nmea


def _still(seconds: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    t = np.arange(0.0, seconds + 0.5, 0.5)
    return t, np.zeros((len(t), 3)), np.zeros((len(t), 3))


@settings(max_examples=200, deadline=None)
@given(lat=st.floats(-89.999, 89.999), lon=st.floats(-179.999, 179.999), alt=st.floats(-400, 9000))
def test_a_fix_written_as_nmea_reads_back_to_the_sentences_precision(lat, lon, alt):
    fix = Fix(12.0, True, np.zeros(3), np.zeros(3), lat, lon, alt, 1.2, 45.0)
    reader = NmeaReader()
    (got,) = reader.feed_all(nmea_lines([fix]))
    assert got.lat_deg == pytest.approx(lat, abs=1e-5 / 60 + 1e-12)  # 1e-5 minutes, about 2 cm
    assert got.lon_deg == pytest.approx(lon, abs=1e-5 / 60 + 1e-12)
    assert got.alt_m == pytest.approx(alt, abs=0.005)
    assert reader.stats.garbled == 0 and reader.stats.other == 1  # the RMC
    assert got.date is None and got.time.second == 12


def test_the_offset_is_a_few_metres_rms_and_correlated_over_minutes():
    errors = GpsErrors()
    t, pos, vel = _still(6 * 3600.0)
    ned = np.array([f.ned for f in simulate_fixes(t, pos, vel, errors=errors, seed=3)])
    horizontal = math.sqrt(np.mean(np.sum(ned[:, :2] ** 2, axis=1)))
    expected = math.hypot(errors.horizontal_rms_m, errors.white_m * math.sqrt(2))
    assert horizontal == pytest.approx(expected, rel=0.2)
    assert np.std(ned[:, 2]) == pytest.approx(errors.vertical_rms_m, rel=0.25)
    x = ned[:, 0] - ned[:, 0].mean()
    lag = 60  # fixes, i.e. one minute apart
    rho = float(np.dot(x[:-lag], x[lag:]) / np.dot(x, x))
    assert rho == pytest.approx(math.exp(-60.0 / errors.correlation_s), abs=0.15)
    step = np.diff(ned[:, :2], axis=0)
    assert np.sqrt(np.mean(step ** 2)) < 0.6  # from one second to the next the fix barely moves


def test_the_same_seed_gives_the_same_sentences_and_another_seed_other_errors():
    t, pos, vel = _still(30.0)
    a, b, c = (list(nmea_lines(simulate_fixes(t, pos, vel, seed=s))) for s in (5, 5, 6))
    assert a == b != c


def test_an_outage_leaves_epochs_without_a_fix_that_the_host_counts():
    t, pos, vel = _still(100.0)
    errors = GpsErrors(outages=parse_outages(["10:20", "90:end"]))
    fixes = simulate_fixes(t, pos, vel, errors=errors)
    assert [f.t for f in fixes if not f.valid] == [*range(10, 20), *range(90, 101)]
    reader = NmeaReader()
    got = reader.feed_all(nmea_lines(fixes))
    assert len(got) == 101 - 21 and reader.stats.missing_fix == 21 and reader.stats.garbled == 0


@pytest.mark.parametrize("text", ["10", "a:b", "20:10"])
def test_a_wrong_outage_is_refused(text):
    with pytest.raises(ValueError, match="START:END|must end after"):
        GpsErrors(outages=parse_outages([text]))


def test_a_replayed_scenario_writes_fixes_of_its_true_walk(tmp_path, capsys):
    wire, nmea = tmp_path / "r.bin", tmp_path / "r.nmea"
    argv = ["replay", "--scenario", "stand:3+walk:20+stand:2", "--wire", str(wire), "--gps", str(nmea),
            "--origin", "58.3949,15.5728,90", "--gps-outage", "10:15", "-q"]
    assert cli.main(argv) == 0
    fixes, stats = read_nmea(nmea)
    assert stats.garbled == 0 and stats.missing_fix == 5 and len(fixes) + 5 == stats.lines // 2
    assert nmea.read_bytes().count(b"\r\n") == stats.lines
    # the same walk's truth at each fix's second: the fixes sit within the receiver's error of it
    from firmware_sim.sensors.imu_array import make_source

    truth = make_source("stand:3+walk:20+stand:2", seed=0).truth
    at = [int(np.searchsorted(truth.t, f.time.second)) for f in fixes]
    local = local_positions(fixes, (58.3949, 15.5728, 90.0))
    error = np.hypot(*(local[:, :2] - truth.pos[at, :2]).T)
    assert error.max() < 15.0 and np.ptp(local[:, 0]) > 10.0  # a few metres off, and it follows the walk


@pytest.mark.parametrize("argv, message", [
    (["walk.txt", "--wire", "o.bin", "--gps", "o.nmea"], "--gps goes with --scenario"),
    (["--scenario", "walk", "--wire", "o.bin", "--origin", "1,2"], "go with --gps"),
    (["--scenario", "walk", "--wire", "o.bin", "--gps", "o.nmea", "--origin", "91,0"], "LAT,LON"),
])
def test_a_wrong_gps_request_is_refused_before_any_run(argv, message, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["replay", *argv]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "o.bin").exists()


def test_the_default_origin_is_on_the_globe():
    assert -90 <= DEFAULT_ORIGIN[0] <= 90 and -180 <= DEFAULT_ORIGIN[1] <= 180
