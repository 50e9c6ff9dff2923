"""The outage loop's error budget: the truth put into the host one part at a time, and only while asked."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from hostlib.aids.compass import StanceReading
from hostlib.fusion.tracker import FusionSettings, FusionTracker
from lab.accuracy.outage_budget import _oracle, summary_lines


def _walk(heading_deg: float, deviation_deg: float) -> SimpleNamespace:
    """A walk standing still facing *heading_deg* in a field the deviation turns by *deviation_deg*, with
    the simulated declination 6°."""
    c, s = math.cos(math.radians(heading_deg)), math.sin(math.radians(heading_deg))
    rotation = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    truth = SimpleNamespace(t=np.arange(10.0), R=np.repeat(rotation[None], 10, axis=0), pos=np.zeros((10, 3)))
    magnetic = SimpleNamespace(heading_deviation=lambda pos: np.full(len(pos), math.radians(deviation_deg)))
    return SimpleNamespace(truth=truth, magnetic=magnetic,
                           config=SimpleNamespace(mag=SimpleNamespace(declination_deg=6.0)))


def _reading(magnetic_heading_deg: float) -> StanceReading:
    """A level board's reading of a field whose horizontal part lies *magnetic_heading_deg* from the board's
    x axis, clockwise (the board faces that far east of magnetic north)."""
    a = math.radians(magnetic_heading_deg)
    return StanceReading(np.array([15.0 * math.cos(a), -15.0 * math.sin(a), 48.0]), np.eye(3), 3)


def test_the_perfect_compass_reads_the_true_heading_less_the_true_declination():
    trackers: list = []
    with _oracle(_walk(50.0, 2.0), "perfect compass", trackers):
        tracker = FusionTracker(FusionSettings(compass=True))
        assert tracker.compass_heading(_reading(30.0)) == pytest.approx(math.radians(44.0))
    assert trackers and trackers[0][0] is tracker


def test_the_deviation_removed_adds_back_what_the_field_turned_the_reading_by():
    with _oracle(_walk(50.0, 2.0), "deviation removed", []):
        psi = FusionTracker(FusionSettings(compass=True)).compass_heading(_reading(30.0))
    assert psi == pytest.approx(math.radians(32.0))


def test_the_true_declination_is_held_without_doubt_and_the_host_is_itself_again_after():
    settings = FusionSettings(compass=True, gps=True, declination_rad=math.radians(7.7))
    with _oracle(_walk(50.0, 2.0), "true declination", []):
        tracker = FusionTracker(settings)
        assert tracker.compass_heading(_reading(30.0)) == pytest.approx(math.radians(30.0))
    assert math.degrees(tracker.declination) == pytest.approx(6.0)
    assert tracker.declination_sigma == 0.0
    after = FusionTracker(settings)
    assert math.degrees(after.declination) == pytest.approx(7.7)
    assert after.declination_sigma > 0.0


def test_the_table_has_a_line_per_run_with_both_end_errors():
    row = {"seed": 2, "flow": "calibrated first", "oracle": "perfect compass", "end_error_pct_csv": 0.45,
           "end_error_pct_truth": 0.38, "declination_error_silent_deg": -0.42,
           "heading_error_silent_deg": -0.6, "heading_error_outage_deg": -0.74}
    lines = summary_lines([row])
    assert len(lines) == 2
    assert "seed  2 calibrated first perfect compass" in lines[1]
    assert "0.45 /  0.38 %   D -0.42°   heading -0.60°, -0.74°" in lines[1]
