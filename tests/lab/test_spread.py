"""`python -m lab.spread`: the spread of the end errors of many walks, its table, its files, and
what the simulated modules show walked 100 m straight (the module paper's experiment)."""

from __future__ import annotations

import csv
import math
import re

import pytest

from lab.spread import Spread, lines, main, walk_groups
from lab.spread.figure import ellipse_axes
from lab.spread.summary import MeanSd, horizontal_ratio

SHORT = "stand:2+walk:5"


def row(seed: int, along: float, across: float, height: float, heading: float = 0.0,
        distance: float = 100.0) -> dict:
    return {"name": f"w{seed}", "seed": seed, "module": seed, "distance_m": distance, "end_along_m": along,
            "end_across_m": across, "end_height_m": height, "end_heading_deg": heading}


# ---------------------------------------------------------------------------------------------
# the summary, on rows made by hand


HAND = [row(1, -0.10, 0.30, 0.05, 0.2, 100.0), row(2, 0.10, -0.10, 0.15, -0.4, 100.0),
        row(3, -0.30, 0.10, 0.10, 0.5, 50.0)]


def test_means_and_sample_deviations_of_the_end_errors():
    s = Spread.of(HAND)
    assert s.n == 3 and s.distance_m == pytest.approx(250.0 / 3)
    assert s.length_m.mean == pytest.approx(-0.1) and s.length_m.sd == pytest.approx(0.2)  # N−1
    assert s.across_m.mean == pytest.approx(0.1) and s.across_m.sd == pytest.approx(0.2)
    assert s.height_m.mean == pytest.approx(0.1) and s.height_m.sd == pytest.approx(0.05)
    assert s.heading_deg.mean == pytest.approx(0.1)
    assert s.heading_deg.sd == pytest.approx(math.sqrt((0.1**2 + 0.5**2 + 0.4**2) / 2))


def test_percentages_are_of_each_walks_own_distance():
    s = Spread.of(HAND)
    # length: −0.1 %, +0.1 %, −0.6 % (the third walk is 50 m)
    assert s.length_pct.mean == pytest.approx(-0.2)
    assert s.length_pct.sd == pytest.approx(math.sqrt((0.1**2 + 0.3**2 + 0.4**2) / 2))
    assert s.height_pct.mean == pytest.approx((0.05 + 0.15 + 0.2) / 3)
    assert s.across_pct.mean == pytest.approx((0.3 - 0.1 + 0.2) / 3)


def test_horizontal_spread_is_the_root_of_the_covariance_trace():
    s = Spread.of(HAND)
    assert s.covariance_m2[0][1] == s.covariance_m2[1][0] == pytest.approx(-0.02)
    assert s.horizontal_m == pytest.approx(math.hypot(0.2, 0.2))
    tight = Spread.of([row(i, 0.01 * i, -0.01 * i, 0.0) for i in range(4)])
    assert horizontal_ratio(tight, s) == pytest.approx(tight.horizontal_m / s.horizontal_m)
    assert tight.horizontal_m == pytest.approx(math.sqrt(2) * MeanSd.of([0.0, 0.01, 0.02, 0.03]).sd)


def test_one_walk_has_a_mean_and_no_deviation():
    s = Spread.of(HAND[:1])
    assert s.length_m.mean == -0.1 and math.isnan(s.length_m.sd) and math.isnan(s.horizontal_m)


def test_the_table_reads_mean_plus_minus_sd_in_metres_and_percent():
    text = "\n".join(lines(Spread.of(HAND), "walk, new module each walk"))
    assert text.startswith("walk, new module each walk: 3 walks, mean tracked distance 83.33 m")
    assert re.search(r"length error\s+−0\.100 m ± 0\.200 m\s+\(−0\.20 % ± 0\.36 %\)", text)
    assert re.search(r"across-track error\s+\+0\.100 m ± 0\.200 m", text)
    assert re.search(r"height error\s+\+0\.100 m ± 0\.050 m", text)
    assert re.search(r"heading error\s+\+0\.100° ± 0\.458°", text)
    assert re.search(r"horizontal spread\s+0\.283 m", text)


def test_the_ellipse_lies_along_the_cloud_with_across_on_x():
    width, height, angle = ellipse_axes(((4.0, 0.0), (0.0, 1.0)))  # along sd 2, across sd 1
    assert (width, height) == pytest.approx((4.0, 2.0)) and abs(math.remainder(angle - 90.0, 180.0)) < 1e-9
    width, height, angle = ellipse_axes(((1.0, 0.9), (0.9, 1.0)))  # along and across grow together
    assert width > height and abs(math.remainder(angle - 45.0, 180.0)) < 1e-9


# ---------------------------------------------------------------------------------------------
# the command, serially on a short route


def _csv_rows(path):
    with path.open() as f:
        return list(csv.DictReader(f))


def test_a_serial_run_prints_the_table_and_writes_csv_and_png(tmp_path, capsys):
    assert main(["--route", SHORT, "--seeds", "1:4", "--workers", "0", "--out", str(tmp_path)]) == 0
    printed = capsys.readouterr().out
    got = _csv_rows(tmp_path / "spread.csv")
    assert [(r["seed"], r["module"], r["group"]) for r in got] == [(str(s), str(s), "new module each walk")
                                                                   for s in (1, 2, 3)]
    assert {"end_along_m", "end_across_m", "end_height_m", "end_heading_deg", "distance_m"} <= got[0].keys()
    along = [float(r["end_along_m"]) for r in got]
    mean, sd = sum(along) / 3, MeanSd.of(along).sd
    expected = f"{mean:+.3f}".replace("-", "−") + f" m ± {sd:.3f} m"
    assert re.search(rf"length error\s+{re.escape(expected)}", printed), printed
    assert printed.startswith(f"{SHORT}, new module each walk: 3 walks, mean tracked distance 5.0")
    assert (tmp_path / "spread.png").stat().st_size > 10_000


def test_the_modules_start_warm_unless_asked_to_start_at_power_on(tmp_path):
    """The module paper's walks came one after another, so its modules were warm: each walk's
    module has been on for ten minutes, five time constants of the warm-up; ``--powered-for 0``
    walks from power-on, through the warm-up, as ``openshoe-emu`` does."""
    warm, cold = tmp_path / "warm", tmp_path / "cold"
    assert main(["--route", SHORT, "--seeds", "1,2", "--workers", "0", "--no-plot", "--out", str(warm)]) == 0
    assert main(["--route", SHORT, "--seeds", "1,2", "--workers", "0", "--no-plot", "--powered-for", "0",
                 "--out", str(cold)]) == 0
    warm_rows, cold_rows = _csv_rows(warm / "spread.csv"), _csv_rows(cold / "spread.csv")
    assert [r["sensors.temperature.powered_s"] for r in warm_rows] == ["600.0", "600.0"]
    assert [r["sensors.temperature.powered_s"] for r in cold_rows] == ["0.0", "0.0"]
    assert [r["wire_sha256"] for r in warm_rows] != [r["wire_sha256"] for r in cold_rows]


def test_one_module_walks_every_seed(tmp_path, capsys):
    assert main(["--route", SHORT, "--seeds", "4,5", "--module", "3", "--workers", "0", "--no-plot",
                 "--out", str(tmp_path)]) == 0
    got = _csv_rows(tmp_path / "spread.csv")
    assert [(r["seed"], r["module"]) for r in got] == [("4", "3"), ("5", "3")]
    assert "module 3: 2 walks" in capsys.readouterr().out and not (tmp_path / "spread.png").exists()


def test_comparing_a_module_with_the_fleet_prints_the_ratio_of_spreads(tmp_path, capsys):
    assert main(["--route", SHORT, "--seeds", "1:4", "--compare-module", "2", "--workers", "0",
                 "--out", str(tmp_path)]) == 0
    printed = capsys.readouterr().out
    m = re.search(r"horizontal spread of module 2 / new module each walk: ([\d.]+) m / ([\d.]+) m "
                  r"= ratio ([\d.]+)", printed)
    assert m, printed
    got = _csv_rows(tmp_path / "spread.csv")
    assert [r["group"] for r in got] == ["new module each walk"] * 3 + ["module 2"] * 3
    assert [r["module"] for r in got[3:]] == ["2"] * 3
    fleet, one = (Spread.of([{k: float(v) for k, v in r.items() if k.startswith(("end_", "distance"))}
                             for r in part]) for part in (got[:3], got[3:]))
    assert (m[1], m[2], m[3]) == (f"{one.horizontal_m:.3f}", f"{fleet.horizontal_m:.3f}",
                                  f"{one.horizontal_m / fleet.horizontal_m:.2f}")
    assert (tmp_path / "spread.png").is_file()


@pytest.mark.parametrize("argv, message", [
    (["--seeds", "5:2"], "seeds must be A:B"),
    (["--seeds", "x"], "seeds must be A:B"),
    (["--seeds", "3"], "at least 2 walks"),
    (["--seeds", "1,1"], "each seed once"),
    (["--route", "no_such_route"], "unknown scenario"),
    (["--route", "stand:2+nope:3"], "unknown piece"),
    (["--route", "walk:x"], "arguments must be numbers"),
    (["--powered-for", "-1"], "--powered-for must be a number of seconds ≥ 0"),
    (["--powered-for", "nan"], "--powered-for must be a number of seconds ≥ 0"),
])
def test_bad_arguments_exit_2_with_the_reason(argv, message, tmp_path, capsys):
    assert main(["--workers", "0", "--out", str(tmp_path), *argv]) == 2  # a later --workers wins
    err = capsys.readouterr().err
    assert err.startswith("python -m lab.spread: ") and message in err
    assert not (tmp_path / "spread.csv").exists()


def test_one_module_and_a_comparison_exclude_each_other(capsys):
    with pytest.raises(SystemExit) as e:
        main(["--module", "1", "--compare-module", "2"])
    assert e.value.code == 2 and "not allowed with" in capsys.readouterr().err


# ---------------------------------------------------------------------------------------------
# the module paper's experiment: 100 m straight, many modules, and one module many times


@pytest.mark.slow
def test_straight_100m_ends_scatter_by_module_and_one_module_clusters():
    # the module paper's experiment at its own size: fifty 100 m walks, a new module each; run here in
    # turn (a local Dask cluster's path is tested by tests/app/test_sweep.py and tests/lab/test_runner.py)
    fleet_rows, one_rows = walk_groups("walk", [(range(1, 51), None), (range(1, 11), 7)], workers=0)
    assert [r["module"] for r in fleet_rows] == list(range(1, 51))
    assert [r["module"] for r in one_rows] == [7] * 10
    fleet, one = Spread.of(fleet_rows), Spread.of(one_rows)
    assert 95.0 < fleet.distance_m < 105.0
    assert 0.05 <= fleet.across_m.sd <= 0.30, fleet
    assert abs(fleet.length_pct.mean) <= 0.5 and abs(fleet.height_pct.mean) <= 0.5, fleet
    assert fleet.length_pct.sd >= 0.05, fleet
    assert one.horizontal_m <= 0.7 * fleet.horizontal_m, (one, fleet)


@pytest.mark.parametrize(("argv", "said"), [
    (["--workers", "100000"],
     "argument --workers: a whole number of processes from 0 (here, one run after the other) to 64 (more: "
     "--scheduler), not '100000'"),
    (["--workers", "-1"], "argument --workers: a whole number of processes from 0"),
    (["--route", "walk:1e9"], "piece 1 'walk:1e9': the length m [m] must be > 0 and at most 2500, got 1e+09"),
])
def test_a_bad_route_or_worker_count_is_refused_before_a_cluster_starts(tmp_path, capsys, argv, said):
    """--workers 100000 started a local cluster of 100000 processes; -1 was refused only after parsing."""
    try:
        code = main(["--seeds", "1:3", "--out", str(tmp_path / "out"), *argv])
    except SystemExit as exc:
        code = exc.code
    assert code == 2 and said in capsys.readouterr().err
    assert not (tmp_path / "out").exists()
