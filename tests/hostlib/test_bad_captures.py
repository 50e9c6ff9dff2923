"""``openshoe-host replay`` and ``drift calibrate`` on captures that are not what they should be:
nothing trackable is refused in one line with what was found, and no file written; a capture that
lost part of its bytes is tracked, and the loss is said with its figures."""

from __future__ import annotations

import io
import random

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hostlib.cli import main
from protocol.codec import encode_step
from protocol.frames import build_command_ack, build_state_packet

DP = np.diag([1e-4, 1e-4, 1e-4, 1e-5])


def capture(steps: int = 5, nan_at: int | None = None) -> bytes:
    """A module's bytes after 0x34: its ack, then *steps* steps of 1 m north (the one numbered
    *nan_at* with a NaN in dx)."""
    out = bytearray(build_command_ack(0x34))
    for k in range(1, steps + 1):
        dx = np.array([np.nan if k == nan_at else 1.0, 0.0, 0.0, 0.0])
        out += build_state_packet(k, encode_step(dx, DP, k))
    return bytes(out)


def replay(tmp_path, data: bytes, capsys) -> tuple[int, str, bool]:
    """The exit status, stderr, and whether the CSV asked for was written."""
    path, csv = tmp_path / "cap.bin", tmp_path / "out.csv"
    path.write_bytes(data)
    code = main(["replay", str(path), "--csv", str(csv)], io.StringIO())
    return code, capsys.readouterr().err, csv.exists()


@pytest.mark.parametrize(("data", "said"), [
    (b"", "is empty"),
    (random.Random(1).randbytes(20000), "no OpenShoe frame in its 20000 bytes"),
    (b"1 0.01 0.02 9.81 0.001 0.002 0.003\n" * 300, "it is text: a walk recording is replayed by"),
    (build_command_ack(0x34) + build_state_packet(1, bytes(12)), "no step packet"),
], ids=["empty", "random", "walk-text", "no-step"])
def test_a_capture_with_nothing_to_track_is_refused_in_one_line_and_writes_no_file(tmp_path, capsys, data,
                                                                                    said):
    code, err, wrote = replay(tmp_path, data, capsys)
    assert code == 1 and said in err and err.count("\n") == 1 and "Traceback" not in err
    assert not wrote


def test_a_capture_cut_inside_a_frame_is_tracked_and_says_how_many_bytes_it_lost(tmp_path, capsys):
    code, err, wrote = replay(tmp_path, capture(5)[:-7], capsys)
    assert code == 0 and wrote
    assert "ends inside a frame: its last" in err and "(the capture was cut short)" in err


def test_a_mostly_garbage_capture_is_tracked_with_the_share_it_lost(tmp_path, capsys):
    data = random.Random(2).randbytes(3000) + capture(5)
    code, err, wrote = replay(tmp_path, data, capsys)
    assert code == 0 and wrote
    assert "were not frames" in err and "%" in err and "good frames gave" in err


def test_a_step_with_a_nan_is_left_out_and_said(tmp_path, capsys):
    code, err, wrote = replay(tmp_path, capture(5, nan_at=3), capsys)
    assert code == 0 and wrote
    assert "1 steps left out, their numbers impossible (the first, step 3: dx" in err


def test_drift_calibration_refuses_a_capture_that_is_not_one(tmp_path, capsys):
    bad = tmp_path / "bad.bin"
    bad.write_bytes(b"")
    code = main(["drift", "calibrate", str(bad), "-o", str(tmp_path / "cal.json")], io.StringIO())
    assert code == 1 and "is empty" in capsys.readouterr().err and not (tmp_path / "cal.json").exists()


@settings(max_examples=60, deadline=None)
@given(data=st.binary(max_size=3000), cut=st.integers(0, 400), prefix=st.binary(max_size=200))
def test_any_bytes_are_replayed_or_refused_never_a_traceback(tmp_path_factory, data, cut, prefix):
    """Random bytes, and real frames behind random bytes, cut anywhere: exit 0 with a track, or 1
    with no file; never an exception."""
    tmp = tmp_path_factory.mktemp("any")
    for blob in (data, prefix + capture(4)[:max(0, len(capture(4)) - cut)]):
        path, csv = tmp / "cap.bin", tmp / "out.csv"
        csv.unlink(missing_ok=True)
        path.write_bytes(blob)
        code = main(["replay", str(path), "--csv", str(csv)], io.StringIO())
        assert code in (0, 1) and csv.exists() == (code == 0)
