"""The two-feet CSV: the body track in the usual columns, which foot stepped and both fused feet in
more; written and read back exactly, its body read by read_csv, a bad line refused by number."""

from __future__ import annotations

import csv
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from hostlib.files.export import CSV_COLUMNS, FEET_COLUMNS, read_csv, read_feet_csv, write_csv, write_feet_csv
from hostlib.fusion.feet import FOOT_SIDES, FeetSettings, TwoFeetTracker


def upper(covariances: np.ndarray) -> np.ndarray:
    """The upper triangles of (…, 4, 4) covariances: what a track CSV holds of each (the midpoint's
    M P Mᵀ may differ from its transpose in the last bit)."""
    rows, cols = np.triu_indices(4)
    return covariances[..., rows, cols]


@dataclass
class _Step:
    dx: np.ndarray
    dp: np.ndarray
    counter: int


def _walked(rows, constraint: bool = True) -> TwoFeetTracker:
    tracker = TwoFeetTracker(FeetSettings(constraint=constraint))
    counters = {side: 0 for side in FOOT_SIDES}
    for side, skip, *dx in rows:
        counters[side] += 1 + skip  # a skipped counter: steps lost, the foot restarts at the other
        tracker.foot(side).add(_Step(np.array(dx), np.diag([1e-4, 2e-4, 1e-4, 1e-5]), counters[side]))
    return tracker


step_rows = st.lists(st.tuples(st.sampled_from(FOOT_SIDES), st.sampled_from([0, 0, 0, 2]),
                               st.floats(-1.5, 1.5), st.floats(-1.5, 1.5), st.floats(-0.3, 0.3),
                               st.floats(-0.5, 0.5)), max_size=30)


@settings(max_examples=40, deadline=None)
@given(step_rows, st.booleans())
@example([("left", 0, 0.0, 0.0, 0.0, 2.225073858507e-311), ("right", 0, 0.0, 0.0, 0.0, 0.0),
          ("right", 2, 0.0, 0.935546875, 0.0, 0.0)], False)  # a subnormal covariance
def test_the_feet_csv_reads_back_exactly_and_its_body_is_read_csvs_track(rows, constraint):
    tracker = _walked(rows, constraint)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "feet.csv"
        write_feet_csv(tracker, path)
        feet, body = read_feet_csv(path), read_csv(path)
        with path.open() as fh:
            header = next(csv.reader(fh))
    assert tuple(header) == CSV_COLUMNS + FEET_COLUMNS
    expected = tracker.body
    for track in (feet.body, body):
        assert np.array_equal(track.poses, expected.poses)
        assert np.array_equal(upper(track.covariances), upper(expected.covariances))
        # the lower triangle is the upper's mirror: the sum's own may differ by its rounding, which
        # below the smallest normal double is absolute (a subnormal has fewer digits)
        assert np.allclose(track.covariances, expected.covariances, rtol=1e-12, atol=np.finfo(float).tiny)
        assert np.array_equal(track.counters, expected.counters)
    assert feet.sides == tuple(tracker.sides)
    for side in FOOT_SIDES:
        assert np.array_equal(feet.feet[side], tracker.fused_foot(side))
        assert np.array_equal(feet.sigmas[side], tracker.fused_foot_sigmas(side))


def test_the_columns_name_each_foot_and_the_first_row_has_no_foot(tmp_path):
    tracker = _walked([("right", 0, 0.7, 0, 0, 0), ("left", 0, 1.4, 0, 0, 0)])
    path = tmp_path / "feet.csv"
    write_feet_csv(tracker, path)
    with path.open() as fh:
        rows = list(csv.DictReader(fh))
    assert [r["foot"] for r in rows] == ["", "right", "left"]
    assert float(rows[0]["left_y_east_m"]) == pytest.approx(-0.06)
    assert float(rows[2]["left_x_north_m"]) == pytest.approx(1.4)
    assert float(rows[2]["x_north_m"]) == pytest.approx(0.5 * (1.4 + 0.7))
    assert float(rows[1]["right_sigma_east_m"]) > 0 and float(rows[1]["left_sigma_east_m"]) == 0


@pytest.mark.parametrize(("line", "column", "value", "message"), [
    (3, "foot", "middle", "line 3: foot 'middle' is not left or right"),
    (2, "foot", "left", "line 2: foot 'left' in the initial pose's row"),
    (4, "right_sigma_down_m", "wide", "line 4: could not convert"),
    (3, "x_north_m", "", "line 3: could not convert"),
])
def test_a_bad_line_is_refused_with_its_number(tmp_path, line, column, value, message):
    path = tmp_path / "feet.csv"
    steps = [("right", 0, 0.7, 0, 0, 0), ("left", 0, 1.4, 0, 0, 0), ("right", 0, 1.4, 0, 0, 0)]
    write_feet_csv(_walked(steps), path)
    with path.open() as fh:
        rows = list(csv.reader(fh))
    rows[line - 1][rows[0].index(column)] = value
    with path.open("w", newline="") as fh:
        csv.writer(fh).writerows(rows)
    for read in (read_feet_csv, read_csv):
        with pytest.raises(ValueError, match=message):
            read(path)


def test_a_short_line_and_a_one_module_csv_are_refused(tmp_path):
    path = tmp_path / "feet.csv"
    write_feet_csv(_walked([("left", 0, 1.0, 0, 0, 0)]), path)
    with path.open("a") as fh:
        fh.write("2,2,1.0\n")
    with pytest.raises(ValueError, match="line 4: expected 37 fields, got 3"):
        read_csv(path)
    single = tmp_path / "one.csv"
    write_csv(_walked([("left", 0, 1.0, 0, 0, 0)]).left.track, single)
    with pytest.raises(ValueError, match="line 1: no columns"):
        read_feet_csv(single)
    assert len(read_csv(single)) == 1


def test_with_an_origin_the_feet_csv_places_the_body_on_the_globe_as_one_feet_csv_does(tmp_path):
    """With GPS the two-feet CSV gets lat_deg, lon_deg, alt_m, the body's, as :func:`write_csv`
    places a one-module track; it still reads back as the feet and as the body's track."""
    tracker = _walked([("right", 0, 0.7, 0.1, 0, 0), ("left", 0, 1.4, 0.2, -0.1, 0.1)])
    origin = (58.3949, 15.5728, 90.0)
    feet_path, body_path = tmp_path / "feet.csv", tmp_path / "body.csv"
    write_feet_csv(tracker, feet_path, origin)
    write_csv(tracker.body, body_path, origin)
    with feet_path.open() as fh, body_path.open() as gh:
        feet_rows, body_rows = list(csv.DictReader(fh)), list(csv.DictReader(gh))
    assert list(feet_rows[0])[-3:] == ["lat_deg", "lon_deg", "alt_m"]
    for f, b in zip(feet_rows, body_rows, strict=True):
        assert (f["lat_deg"], f["lon_deg"], f["alt_m"]) == (b["lat_deg"], b["lon_deg"], b["alt_m"])
    assert float(feet_rows[0]["lat_deg"]) == pytest.approx(origin[0])
    back = read_feet_csv(feet_path)
    np.testing.assert_array_equal(back.feet["left"], tracker.fused_foot("left"))
    np.testing.assert_array_equal(read_csv(feet_path).poses, tracker.body.poses)
