"""Export round trips (CSV, GeoJSON local and geographic) and the PNG plot."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from hostlib.files.export import (
    enu_to_geodetic,
    geodetic_to_enu,
    read_csv,
    read_geojson,
    to_geojson,
    write_csv,
    write_geojson,
)
from hostlib.files.plot import PlotOptions, along_track, ellipse_params, ellipse_scale, plot_track
from hostlib.track.steps import StepTracker


def walk(n: int = 12, seed: int = 3) -> StepTracker:
    rng = np.random.default_rng(seed)
    t = StepTracker(position=(1.0, 2.0, 0.0), heading=0.3)
    c = 0
    for _ in range(n):
        c += 2 if rng.random() < 0.2 else 1  # a few gaps
        dx = [0.7 + 0.1 * rng.normal(), 0.05 * rng.normal(), 0.01 * rng.normal(), 0.3 * rng.normal()]
        a = rng.normal(size=(4, 4)) * 0.01
        t.add_step(dx, a @ a.T, c)
    return t


def test_csv_round_trip_is_exact(tmp_path):
    t = walk()
    path = tmp_path / "walk.csv"
    write_csv(t.track, path)
    back = read_csv(path)
    np.testing.assert_array_equal(back.poses, t.track.poses)
    np.testing.assert_array_equal(back.covariances, t.track.covariances)
    np.testing.assert_array_equal(back.counters, t.track.counters)
    np.testing.assert_array_equal(back.steps, t.track.steps)
    assert back.distance == pytest.approx(t.distance, rel=1e-12)
    assert back.gaps == t.gaps


def test_bad_csv_is_refused_with_its_line_number(tmp_path):
    path = tmp_path / "walk.csv"
    write_csv(walk(3).track, path)
    lines = path.read_text().splitlines()
    lines[2] = lines[2].replace(",", ",x", 1)
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(ValueError, match="line 3"):
        read_csv(path)
    (tmp_path / "other.csv").write_text("a,b\n1,2\n")
    with pytest.raises(ValueError, match="line 1"):
        read_csv(tmp_path / "other.csv")


def test_geojson_local_is_east_north_up(tmp_path):
    t = StepTracker()
    t.add_step([1.0, 2.0, 0.5, 0.0], np.zeros((4, 4)), 1)  # 1 m north, 2 m east, 0.5 m down
    doc = to_geojson(t.track)
    line = doc["features"][0]
    assert line["geometry"]["coordinates"][-1] == [2.0, 1.0, -0.5]
    assert line["properties"]["crs"] == "local-enu-m"
    path = tmp_path / "t.geojson"
    write_geojson(t.track, path)
    json.loads(path.read_text())  # valid JSON
    pos, headings = read_geojson(path)
    np.testing.assert_allclose(pos, t.track.positions)


def test_geojson_geographic_round_trip_and_scale(tmp_path):
    t = walk(30)
    origin = (58.3949, 15.5728, 90.0)  # Linköping
    path = tmp_path / "geo.geojson"
    write_geojson(t.track, path, origin)
    pos, headings = read_geojson(path)
    np.testing.assert_allclose(pos, t.track.positions, atol=1e-6)
    np.testing.assert_allclose(headings, t.track.headings)
    # 1 km north is ~0.00899° of latitude near 58° N; 1 km east ~0.01718° of longitude.
    g = enu_to_geodetic(np.array([[1000.0, 1000.0, 0.0]]), origin)[0]
    assert g[1] - origin[0] == pytest.approx(1000 / 111_360, rel=2e-3)
    assert g[0] - origin[1] == pytest.approx(1000 / (111_412 * math.cos(math.radians(origin[0]))), rel=3e-3)
    np.testing.assert_allclose(geodetic_to_enu(g, origin), [1000.0, 1000.0, 0.0], atol=1e-6)
    near_pole = enu_to_geodetic(np.array([[100.0, -50.0, 2.0]]), (89.5, 0.0))  # exact, poles included
    np.testing.assert_allclose(geodetic_to_enu(near_pole, (89.5, 0.0)), [[100.0, -50.0, 2.0]], atol=1e-6)
    with pytest.raises(ValueError, match="LAT,LON"):
        enu_to_geodetic(np.zeros(3), (95.0, 0.0))


def test_ellipse_of_north_uncertainty_is_vertical():
    w, h, ang = ellipse_params(np.diag([4.0, 1.0]))  # σ_north = 2, σ_east = 1
    assert (w, h) == pytest.approx((4.0, 2.0))
    assert abs(abs(ang) - 90.0) < 1e-9


def test_png_is_written(tmp_path):
    pytest.importorskip("matplotlib")
    out = plot_track(walk(25).track, tmp_path / "t.png", every=5)
    data = out.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 5000
    with pytest.raises(ValueError, match="every"):
        plot_track(walk(2).track, tmp_path / "u.png", every=0)


def test_png_options_as_an_object_or_as_keywords_draw_the_same_picture(tmp_path):
    pytest.importorskip("matplotlib")
    track = walk(12).track
    options = PlotOptions(every=3, title="a walk", height_profile=False, dpi=60)
    by_object = plot_track(track, tmp_path / "a.png", options).read_bytes()
    by_keywords = plot_track(track, tmp_path / "b.png", every=3, title="a walk", height_profile=False,
                             dpi=60).read_bytes()
    assert by_object == by_keywords
    assert plot_track(track, tmp_path / "c.png", options, dpi=120).read_bytes() != by_object, \
        "a keyword wins over the options"


def test_png_can_draw_a_reference_path_and_refuses_a_malformed_one(tmp_path):
    pytest.importorskip("matplotlib")
    track = walk(10).track
    truth = track.positions[:, :2] + 0.05  # rows of (north, east)
    out = plot_track(track, tmp_path / "ref.png", reference=truth, reference_label="survey")
    assert out.read_bytes().startswith(b"\x89PNG\r\n\x1a\n")
    with pytest.raises(ValueError, match="north, east"):
        plot_track(track, tmp_path / "bad.png", reference=np.zeros(5))


def test_ellipses_are_enlarged_by_a_round_factor_until_visible():
    assert ellipse_scale(100.0, 0.5) == 10.0  # 0.5 m on a 100 m plot: ×10 makes 5 m (5 %)
    assert ellipse_scale(100.0, 0.04) == 100.0
    assert ellipse_scale(10.0, 2.0) == 1.0, "already visible: drawn true to size"
    assert ellipse_scale(0.0, 0.0) == 1.0


def test_distance_along_the_track_is_horizontal():
    pts = np.array([[0.0, 0.0, 0.0], [3.0, 4.0, -1.0], [3.0, 4.0, -3.0]])
    np.testing.assert_allclose(along_track(pts), [0.0, 5.0, 5.0])


def _png_size(data: bytes) -> tuple[int, int]:
    return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")


def test_png_has_a_height_profile_under_the_plan(tmp_path):
    pytest.importorskip("matplotlib")
    track = walk(10).track
    with_profile = _png_size(plot_track(track, tmp_path / "a.png").read_bytes())
    plan_only = _png_size(plot_track(track, tmp_path / "b.png", height_profile=False).read_bytes())
    assert with_profile[0] == plan_only[0] and with_profile[1] > 1.3 * plan_only[1]
