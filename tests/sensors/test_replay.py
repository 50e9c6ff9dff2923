"""Replay of recorded walks: strict parsing, lossless CSV, registers of a replicated board."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from firmware_sim.board import MIMU22BT
from firmware_sim.mcu.imu_bus import SensorSource
from firmware_sim.sensors.registers import accel_to_lsb, gyro_to_lsb, lsb_to_accel, lsb_to_gyro
from firmware_sim.sensors.replay import (
    CSV_HEADER,
    OPENSHOE_HEADER,
    Recording,
    RecordingFormatError,
    ReplaySource,
    load_csv,
    load_openshoe,
    load_recording,
    save_csv,
)
from tests.conftest import WALK_IDS, walk_path

TITLE_LINES = ["", "Inertial data.", "", OPENSHOE_HEADER]



def half_sample_ahead(acc: np.ndarray) -> np.ndarray:
    """What the replay serves of a recorded accelerometer: each sample's mean with the next, the
    last as it is."""
    out = acc.copy()
    out[:-1] = (acc[:-1] + acc[1:]) / 2
    return out

def openshoe_row(k: int, acc=(-0.1, 0.15, 0.99), gyro=(0.001, -0.002, 0.003), mag="-0.12 -0.01 -0.46") -> str:
    return (
        f"   0xcb   {acc[0]:+.8f}   {acc[1]:+.8f}   {acc[2]:+.8f}   {gyro[0]:+.8f}   {gyro[1]:+.8f}"
        f"   {gyro[2]:+.8f}   {1000 + 78720 * k}    0x15fd   {k + 1} {100.0 + k * 0.004:.6f}"
        f" {100.0 + k * 0.004:.6f} {100.004 + k * 0.004:.6f}  250.000001   {mag} "
    )


def write_openshoe(path: Path, rows: list[str], tail: str = "") -> Path:
    path.write_bytes(("\r\n".join(TITLE_LINES + rows) + "\r\n" + tail).encode("ascii"))
    return path


# ---------------------------------------------------------------------------------------------
# the shared walks


def terminated_data_lines(path: Path) -> int:
    data = path.read_bytes()
    return data.count(b"\n") - len(TITLE_LINES)


@pytest.mark.parametrize("walk", WALK_IDS)
def test_replaying_a_walk_gives_every_sample_back_within_one_lsb(walks_dir, walk):
    path = walk_path(walk)
    rec = load_recording(path)
    src = ReplaySource(rec)
    n = terminated_data_lines(path)
    assert len(rec) == n and len(src) == n
    assert np.array_equal(rec.nr, np.arange(1, n + 1))  # no sample lost or repeated
    assert rec.missing_samples == 0
    assert src.rate_hz == 250.0
    assert src.read(n - 1) is not None and src.read(n) is None

    # undo each chip's mounting and the z-up → z-down turn: the recording comes back
    mount = MIMU22BT.mounting.astype(float)
    acc_board = np.einsum("kji,nkj->nki", mount, lsb_to_accel(src.imu[..., :3]))
    gyro_board = np.einsum("kji,nkj->nki", mount, lsb_to_gyro(src.imu[..., 3:]))
    flip = np.array([1.0, -1.0, -1.0])
    acc_served = half_sample_ahead(rec.acc_g)  # the accelerometer goes half a sample ahead (Timing)
    for chip in range(4):
        assert np.max(np.abs(acc_board[:, chip] * flip - acc_served)) <= 1 / 2048
        assert np.max(np.abs(gyro_board[:, chip] * flip - rec.gyro)) <= math.radians(1 / 16.4)
    # the four chips agree once calibrated, so the firmware's average is the recorded sample
    assert np.array_equal(acc_board[:, 0], acc_board[:, 3])
    # at rest at the start the board reads about (0, 0, −1) g: z down
    assert acc_board[:50, 0, 2].mean() == pytest.approx(-1.0, abs=0.05)


def test_the_last_row_cut_off_by_the_recorder_is_kept_aside_not_parsed(walks_dir):
    rec = load_openshoe(walk_path("31"))
    assert rec.partial_tail is not None and rec.partial_tail.split()[0] == "0xcb"
    assert rec.nr[-1] == len(rec)


# ---------------------------------------------------------------------------------------------
# strict OpenShoe parser


def test_a_small_openshoe_file_parses_into_the_recording_frame(tmp_path):
    path = write_openshoe(tmp_path / "w.txt", [openshoe_row(k) for k in range(3)])
    rec = load_openshoe(path)
    assert len(rec) == 3 and rec.partial_tail is None
    assert rec.t == pytest.approx([0.0, 0.004, 0.008])
    assert rec.board_acc_g()[0] == pytest.approx([-0.1, -0.15, -0.99])
    assert rec.mag[0] == pytest.approx([-0.12, -0.01, -0.46])


def test_missing_magnetometer_readings_are_nan_and_replay_holds_the_last_one(tmp_path):
    rows = [openshoe_row(0), openshoe_row(1, mag="+nan +nan +nan")]
    rec = load_openshoe(write_openshoe(tmp_path / "w.txt", rows))
    assert np.isnan(rec.mag[1]).all()
    src = ReplaySource(rec)
    assert np.array_equal(src.read(1).mag, src.read(0).mag)


CORRUPTIONS = {
    "drop a column": lambda toks: toks[:-1],
    "extra column": lambda toks: toks + ["1.0"],
    "garbage acc": lambda toks: toks[:2] + ["abc"] + toks[3:],
    "nan gyro": lambda toks: toks[:5] + ["nan"] + toks[6:],
    "inf acc": lambda toks: toks[:1] + ["inf"] + toks[2:],
    "bad hex id": lambda toks: ["0xZZ"] + toks[1:],
    "negative nr": lambda toks: toks[:9] + ["-3"] + toks[10:],
    "underscore number": lambda toks: toks[:3] + ["1_0"] + toks[4:],
    "empty line": lambda toks: [],
}


@settings(max_examples=60, suppress_health_check=[HealthCheck.function_scoped_fixture], deadline=None)
@given(n=st.integers(1, 12), data=st.data(), kind=st.sampled_from(sorted(CORRUPTIONS)))
def test_a_corrupted_row_is_refused_with_its_line_number(tmp_path, n, data, kind):
    bad = data.draw(st.integers(0, n - 1))
    rows = [openshoe_row(k) for k in range(n)]
    rows[bad] = "   ".join(CORRUPTIONS[kind](rows[bad].split()))
    path = write_openshoe(tmp_path / f"bad_{kind.replace(' ', '_')}.txt", rows)
    with pytest.raises(RecordingFormatError) as err:
        load_recording(path)
    line = len(TITLE_LINES) + bad + 1
    assert err.value.line == line
    assert f"line {line}" in str(err.value) and path.name in str(err.value)
    assert isinstance(err.value, ValueError)


def test_a_wrong_header_is_refused(tmp_path):
    path = tmp_path / "w.txt"
    path.write_bytes(b"\r\nTitle\r\n\r\nHeader: a_x [m/s2]:\r\n")
    with pytest.raises(RecordingFormatError, match="line 4: unexpected header"):
        load_openshoe(path)


def test_non_ascii_bytes_are_refused_with_their_line(tmp_path):
    path = write_openshoe(tmp_path / "w.txt", [openshoe_row(0), openshoe_row(1)])
    path.write_bytes(path.read_bytes().replace(b"0xcb", b"0x\xcb", 2).replace(b"0x\xcb", b"0xcb", 1))
    with pytest.raises(RecordingFormatError, match="line 6: not ASCII"):
        load_openshoe(path)


# ---------------------------------------------------------------------------------------------
# CSV

finite = st.floats(-20, 20, allow_nan=False, allow_infinity=False, width=64)


@settings(max_examples=40, suppress_health_check=[HealthCheck.function_scoped_fixture], deadline=None)
@given(
    n=st.integers(1, 20), with_mag=st.booleans(), data=st.data(),
    rate=st.floats(1, 2000, allow_nan=False),
)
def test_csv_round_trip_is_lossless(tmp_path, n, with_mag, data, rate):
    vals = np.array(data.draw(st.lists(st.lists(finite, min_size=9, max_size=9), min_size=n, max_size=n)))
    t = np.cumsum(np.abs(data.draw(st.lists(st.floats(1e-4, 1.0), min_size=n, max_size=n))))
    mag = vals[:, 6:9] if with_mag else np.full((n, 3), np.nan)
    rec = Recording(t=t, acc_g=vals[:, 0:3], gyro=vals[:, 3:6], mag=mag, rate_hz=rate)
    back = load_csv(save_csv(rec, tmp_path / "r.csv"))
    assert np.array_equal(back.t, rec.t) and np.array_equal(back.acc_g, rec.acc_g)
    assert np.array_equal(back.gyro, rec.gyro)
    assert np.array_equal(back.mag, rec.mag, equal_nan=True)
    assert back.rate_hz == rate


def test_an_openshoe_walk_converted_to_csv_keeps_its_board_frame_values(tmp_path):
    rows = [openshoe_row(k, acc=(0.01 * k, 0.2, 1.0)) for k in range(5)]
    rec = load_openshoe(write_openshoe(tmp_path / "w.txt", rows))
    back = load_recording(save_csv(rec, tmp_path / "w.csv", comments=["from w.txt"]))
    assert back.format == "csv" and back.rate_hz == 250.0
    assert np.array_equal(back.board_acc_g(), rec.board_acc_g())
    a, b = ReplaySource(rec), ReplaySource(back)
    assert all(np.array_equal(a.read(i).imu, b.read(i).imu) for i in range(5))


@pytest.mark.parametrize(
    "row, reason",
    [("0.2,0,0,-1,0,0", "expected 7 fields"), ("0.2,0,0,-1,0,0,x", "field 'gz'"),
     ("0.1,0,0,-1,0,0,0", "t must increase"), ("0.2,0,0,nan,0,0,0", "field 'az'")],
)
def test_a_malformed_csv_row_is_refused_with_its_line_number(tmp_path, row, reason):
    path = tmp_path / "r.csv"
    path.write_text("# rate_hz=100\nt,ax,ay,az,gx,gy,gz\n0.1,0,0,-1,0,0,0\n" + row + "\n0.3,0,0,-1,0,0,0\n")
    with pytest.raises(RecordingFormatError, match=f"r.csv, line 4: .*{reason}"):
        load_csv(path)


# ---------------------------------------------------------------------------------------------
# the source


def test_replay_source_is_a_sensor_source_at_the_recordings_rate(tmp_path):
    path = write_openshoe(tmp_path / "w.txt", [openshoe_row(k) for k in range(4)], tail="   0xcb  -0.1")
    src = ReplaySource.from_file(path)
    assert isinstance(src, SensorSource)
    assert src.rate_hz == 250.0 and len(src) == 4
    s = src.read(0)
    assert s.imu.dtype == np.int16 and s.imu.shape == (4, 6) and s.mag.shape == (4, 3)
    # −0.99 g on board z (z down) on the upright chips, +0.99 g on the upside-down ones
    assert list(s.imu[:, 2]) == [-2028, -2028, 2028, 2028]
    assert src.read(4) is None
    src.set_dlpf(3)
    with pytest.raises(ValueError):
        src.set_dlpf(7)


def test_a_replays_registers_are_one_block_in_sample_order(tmp_path):
    """The compiled loop reads a stretch of samples as they lie (firmware_sim.mcu.imu_bus.imu_block):
    laid out otherwise, every stretch would be copied first."""
    src = ReplaySource.from_file(write_openshoe(tmp_path / "w.txt", [openshoe_row(k) for k in range(8)]))
    assert src.imu.flags["C_CONTIGUOUS"] and src.imu.shape == (8, 4, 6)


def test_quantisation_saturates_at_int16(tmp_path):
    rec = Recording(t=np.array([0.0]), acc_g=np.array([[17.0, -17.0, 0.0]]), gyro=np.array([[40.0, 0, 0]]),
                    mag=np.full((1, 3), np.nan), rate_hz=250.0)
    s = ReplaySource(rec).read(0)
    assert list(s.imu[0]) == [32767, -32768, 0, 32767, 0, 0]


@settings(max_examples=30, deadline=None)
@given(st.integers(2, 40), st.data())
def test_each_chip_gets_its_own_axes_registers_saturated_as_its_own(n, data):
    values = st.floats(-20.0, 20.0, allow_nan=False)
    edges = st.sampled_from([15.99975, -15.99975, 16.0, -16.0, 16.00025, -16.00025, 0.0, -0.0])
    acc = np.reshape(data.draw(st.lists(st.one_of(values, edges), min_size=3 * n, max_size=3 * n)), (n, 3))
    gyro = np.reshape(data.draw(st.lists(values, min_size=3 * n, max_size=3 * n)), (n, 3))
    rec = Recording(t=np.arange(n) / 250.0, acc_g=acc, gyro=gyro, mag=np.full((n, 3), np.nan), rate_hz=250.0,
                    body_to_board=np.diag([1.0, -1.0, -1.0]))
    src = ReplaySource(rec)
    for k, mount in enumerate(np.asarray(MIMU22BT.mounting, dtype=np.float64)):
        chip_acc = half_sample_ahead(rec.board_acc_g() @ mount.T)
        chip_gyro = rec.board_gyro() @ mount.T
        assert np.array_equal(src.imu[:, k, :3], accel_to_lsb(chip_acc))
        assert np.array_equal(src.imu[:, k, 3:], gyro_to_lsb(chip_gyro))


def test_a_simulated_walk_written_as_csv_replays_as_its_board_signals(tmp_path):
    from firmware_sim.sensors.config import IDEAL_CONFIG
    from firmware_sim.sensors.imu_array import make_source

    sim = make_source("stand:1+walk:3", config=IDEAL_CONFIG, rate_hz=250.0)
    rec = load_recording(save_csv(sim.to_recording(), tmp_path / "sim.csv"))
    assert rec.rate_hz == 250.0 and len(rec) == len(sim)
    assert np.array_equal(rec.board_acc_g(), sim.truth.f_b / 9.80665)  # lossless
    replay = ReplaySource(rec)
    # replayed chips hold the board-centre signals (no lever arms): equal to the simulation's mean chip
    acc = np.einsum("kji,nkj->nki", MIMU22BT.mounting.astype(float), lsb_to_accel(replay.imu[..., :3]))
    expected = half_sample_ahead(sim.truth.f_b / 9.80665)
    assert np.abs(acc.mean(axis=1) - expected).max() <= 1 / 4096 + 1e-12


def test_an_empty_recording_is_refused(tmp_path):
    path = write_openshoe(tmp_path / "w.txt", [])
    with pytest.raises(RecordingFormatError, match="no samples"):
        load_openshoe(path)
    (tmp_path / "e.csv").write_text("t,ax,ay,az,gx,gy,gz\n")
    with pytest.raises(RecordingFormatError, match="no samples"):
        load_csv(tmp_path / "e.csv")


@settings(max_examples=40, suppress_health_check=[HealthCheck.function_scoped_fixture], deadline=None)
@given(n=st.integers(1, 10), data=st.data(),
       junk=st.sampled_from(["", "x", "1,,2", "nan", "1e", "--1", "0x10", "1 2"]))
def test_a_corrupted_csv_field_is_refused_with_its_line_number(tmp_path, n, data, junk):
    rows = [f"{0.01 * (k + 1)!r},0.0,0.0,-1.0,0.1,0.2,0.3" for k in range(n)]
    bad = data.draw(st.integers(0, n - 1))
    col = data.draw(st.integers(1, 6))
    fields = rows[bad].split(",")
    fields[col] = junk
    rows[bad] = ",".join(fields)
    path = tmp_path / "c.csv"
    path.write_text("# made by a test\n" + CSV_HEADER + "\n" + "\n".join(rows) + "\n")
    with pytest.raises(RecordingFormatError) as err:
        load_csv(path)
    assert err.value.line == bad + 3


def test_samples_the_recorder_skipped_are_counted(tmp_path):
    rows = [openshoe_row(k) for k in (0, 1, 4, 5)]  # nr 1 2 5 6
    rec = load_openshoe(write_openshoe(tmp_path / "w.txt", rows))
    assert len(rec) == 4 and rec.missing_samples == 2 and rec.longest_gap == 2


def test_samples_the_recorder_skipped_are_served_interpolated_between_their_neighbours(tmp_path):
    rows = [openshoe_row(k, acc=(0.01 * k, 0.0, 1.0), gyro=(0.1 * k, 0.0, 0.0)) for k in (0, 1, 4, 5)]
    rec = load_openshoe(write_openshoe(tmp_path / "w.txt", rows))
    filled = rec.with_missing_filled()
    assert list(filled.nr) == [1, 2, 3, 4, 5, 6] and filled.missing_samples == 0
    np.testing.assert_allclose(filled.acc_g[:, 0], [0.0, 0.01, 0.02, 0.03, 0.04, 0.05], atol=1e-12)
    np.testing.assert_allclose(filled.gyro[:, 0], [0.0, 0.1, 0.2, 0.3, 0.4, 0.5], atol=1e-12)
    np.testing.assert_allclose(filled.t, np.arange(6) * 0.004, atol=1e-9)
    assert np.isnan(filled.mag[2:4]).all() and not np.isnan(filled.mag[[0, 1, 4, 5]]).any()
    source = ReplaySource(rec)
    assert len(source) == 6 and (source.filled_samples, source.longest_gap) == (2, 2)
    assert rec.with_missing_filled() is not rec and filled.with_missing_filled() is filled


@settings(max_examples=60, deadline=None)
@given(steps=st.lists(st.integers(1, 5), min_size=1, max_size=40))
def test_filling_puts_every_written_sample_at_its_own_number(steps):
    """Whatever the gaps, the filled recording numbers its samples without a gap, holds every written
    sample unchanged at its number, and has as many more samples as were missing."""
    nr = 7 + np.concatenate([[0], np.cumsum(steps)])
    n = len(nr)
    rng = np.random.default_rng(len(steps))
    rec = Recording(t=(nr - 7) * 0.004, acc_g=rng.normal(size=(n, 3)), gyro=rng.normal(size=(n, 3)),
                    mag=rng.normal(size=(n, 3)), rate_hz=250.0, nr=nr)
    filled = rec.with_missing_filled()
    assert len(filled) == n + rec.missing_samples
    assert np.array_equal(filled.nr, np.arange(nr[0], nr[-1] + 1))
    at = nr - nr[0]
    assert np.array_equal(filled.acc_g[at], rec.acc_g) and np.array_equal(filled.gyro[at], rec.gyro)
    assert np.array_equal(filled.mag[at], rec.mag) and np.allclose(filled.t[at], rec.t)


def test_a_replay_says_how_many_samples_the_recorder_skipped(tmp_path, capsys):
    from firmware_sim.app import cli

    rows = [openshoe_row(k) for k in (0, 1, 2, 6, 7, 9)]  # nr 1 2 3 7 8 10: 4 missing, 3 at most
    path = write_openshoe(tmp_path / "w.txt", rows)
    assert cli.main(["replay", str(path), "--wire", str(tmp_path / "w.bin")]) == 0
    err = capsys.readouterr().err
    assert (f"{path}: 4 samples the recorder skipped (gaps in its sample numbers, the longest 3) are "
            "served interpolated") in err
    assert f"{path}: 10 samples in" in err
