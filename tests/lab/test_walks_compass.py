"""`python -m lab.accuracy walks-compass`: the per-step compass on the six shared walks.

These check what a user relies on — six walks, the compass updating on the steps, the
magnetometers reaching the host as an Earth field, finite closures — not the closures' values.
"""

from __future__ import annotations

import io
import math

import numpy as np
import pytest

from lab.accuracy import main
from lab.accuracy.walks_compass import VARIANTS, capture_walk, compass_walk_results, stance_log, table_lines
from tests.conftest import WALK_IDS, requires_walks, walk_path


def run(argv: list[str]) -> tuple[int, str]:
    out = io.StringIO()
    return main(argv, out), out.getvalue()


def test_one_walk_is_refused_there_is_nothing_to_calibrate_on(tmp_path, capsys):
    recording = tmp_path / "walk.txt"
    recording.write_text("")
    code, _ = run(["walks-compass", str(recording), "--workers", "0", "--out", str(tmp_path)])
    assert code == 2 and "at least two" in capsys.readouterr().err


@pytest.fixture(scope="module")
def results():
    return compass_walk_results([walk_path(w) for w in WALK_IDS], workers=0, control_draws=2)


@requires_walks
def test_the_recordings_magnetometer_reaches_the_host_as_recorded():
    """Standing still before the first step, the field the host decodes from the step packet is
    the recording's (gauss → µT, the sensor's z-up axes → the board's, the AK8975's axes and back),
    to the registers' step, 0.3 µT."""
    from firmware_sim.sensors.replay import load_recording

    path = walk_path(WALK_IDS[0])
    log = stance_log(path, capture_walk(str(path)))
    first = log.readings[0]
    assert first is not None and not log.moved[0] and first.chips == 3
    standing = load_recording(path).board_mag()[:250] * 100.0  # the first second, µT
    standing = standing[np.isfinite(standing).all(axis=1)]
    assert np.abs(first.field_board - standing.mean(axis=0)).max() < 0.3


@requires_walks
def test_six_walks_each_with_the_compass_updating_on_its_steps(results):
    assert [r.name for r in results] == [walk_path(w).stem for w in WALK_IDS]
    for r in results:
        assert r.moved_steps >= 40 and r.used_steps == r.moved_steps  # every moved step brought a reading
        for v in VARIANTS[1:]:
            assert r.compass_updates[v] >= 0.9 * r.moved_steps
            assert 1.0 < r.sigma_deg[v] < 90.0


@requires_walks
def test_the_readings_are_an_earth_field_dipping_down(results):
    for r in results:
        assert 25.0 < r.field["field_ut"] < 65.0  # the Earth's field anywhere
        assert 45.0 < r.field["inclination_deg"] < 85.0  # a northern-hemisphere dip, z down
        assert r.field["horizontal_ut"] > 5.0


@requires_walks
def test_closures_are_finite_and_the_iron_comes_from_the_level_circle(results):
    for r in results:
        for v in VARIANTS:
            assert math.isfinite(r.horizontal_pct[v]) and math.isfinite(r.closure_3d_pct[v])
            assert r.closure_3d_pct[v] >= r.horizontal_pct[v]
        assert r.iron.model == "level circle" and np.isfinite(r.iron.calibration.hard_iron).all()
        assert len(r.control_pct) == 2 and np.isfinite(r.control_pct).all()
    lines = table_lines(results)
    assert lines[len(results) + 1].startswith("mean")
