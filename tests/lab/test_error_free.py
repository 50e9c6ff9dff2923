"""The error-free scenario table (``python -m lab.accuracy error-free``): an error-free module at
1 kHz retraces the stairs, with still stances and with swaying ones, and its detector takes no
stair swing for a stance."""

from __future__ import annotations

import math

import numpy as np

from firmware_sim.nav.config import TH_ZUPT_DEFAULT
from firmware_sim.sensors.config import IDEAL_CONFIG
from firmware_sim.sensors.imu_array import make_source
from lab.accuracy.error_free import error_free_run, table_lines
from tests.oracle.firmware_trace import align, trace_module


def test_an_error_free_module_retraces_the_stairs_up_and_down():
    """Each of the twelve stair strides is a step and nothing else: the end is within 0.2 % of the path
    and the height within 2 cm (with the stair swing only pitching, the false stances in mid-swing
    left 1.8 % up and 3.3 % down)."""
    for name in ("stairs_up", "stairs_down"):
        row = error_free_run(name)
        assert row["steps"] == row["true_stances"] - 1 == 12, row
        assert row["end_error_pct"] < 0.2 and abs(row["height_m"]) < 0.02, row
        # a real foot's swaying stances: the same, the sway's few millimetres lost or not
        assert row["swaying_end_error_pct"] < 0.2 and abs(row["swaying_height_m"]) < 0.02, row


def test_the_detector_sees_no_stance_in_the_middle_of_a_stair_swing():
    """Error-free, at the module's 1 kHz: in the middle 80 % of every stair swing the detector's statistic
    stays above the power-on TH_ZUPT, so the module resets only where the foot rests."""
    source = make_source("stand:3+stairs_up:8+stairs_down:8+stand:2", config=IDEAL_CONFIG)
    truth = source.truth
    t1 = align(trace_module(source)).t1
    swings = list(zip(truth.stance_end[:-1], truth.stance_start[1:], strict=True))
    assert len(swings) == 8
    for lift_off, landing in swings:
        edge = 0.1 * (landing - lift_off)
        middle = (truth.t[:len(t1)] >= lift_off + edge) & (truth.t[:len(t1)] <= landing - edge)
        assert np.all(t1[middle] >= TH_ZUPT_DEFAULT), (lift_off, int(t1[middle].min()))


def test_the_table_leaves_out_what_has_no_path():
    rows = [{"scenario": "walk", "end_error_pct": 0.0694, "height_m": -0.0691, "step_packets": 71,
             "true_stances": 68, "swaying_end_error_pct": 0.0823, "swaying_height_m": -0.0819},
            {"scenario": "stand", "end_error_pct": math.nan, "height_m": 0.0, "step_packets": 9,
             "true_stances": 1, "swaying_end_error_pct": math.nan, "swaying_height_m": 0.0}]
    assert table_lines(rows) == [
        "| scenario | 3-D % | height [m] | step packets | true stances | swaying: 3-D % | height [m] |",
        "|---|---|---|---|---|---|---|", "| walk | 0.069 | −0.069 | 71 | 68 | 0.082 | −0.082 |"]


def test_the_command_prints_the_table_and_writes_its_csv(tmp_path):
    import io

    from lab.accuracy import main

    out = io.StringIO()
    assert main(["error-free", "stand:3+walk:5+stand:2", "--workers", "0", "--out", str(tmp_path)], out) == 0
    lines = out.getvalue().splitlines()
    assert lines[0].startswith("| scenario | 3-D % |") and lines[2].startswith("| stand:3+walk:5+stand:2 |")
    assert (tmp_path / "error-free.csv").read_text().count("\n") == 2
