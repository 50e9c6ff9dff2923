"""`openshoe-accuracy`: what height compensation and drift correction gain, per walk and on slopes."""

from __future__ import annotations

import io
import math

import pytest

from tests.conftest import WALK_IDS, requires_walks, walk_path
from tools.accuracy import main
from tools.accuracy.slopes import slope_rows, summary_lines
from tools.accuracy.speeds import SPEEDS_KMH, speed_run
from tools.accuracy.walks import VARIANTS, table_lines, walk_results


def run(argv: list[str]) -> tuple[int, str]:
    out = io.StringIO()
    return main(argv, out), out.getvalue()


def test_a_short_ramp_is_walked_with_and_without_compensation_and_summarised():
    rows = slope_rows([1], workers=0, scenarios=("stand:3+walk:8:6+stand:2",))
    assert [r["height_compensation"] for r in rows] == [False, True]
    top = rows[0]["true_top_m"]
    assert top == pytest.approx(8 * math.sin(math.radians(6)), rel=1e-6)
    for r in rows:  # the track climbs the ramp to within a few centimetres either way
        assert abs(r["top_error_m"]) < 0.1 and abs(r["end_error_m"]) < 0.1
    lines = summary_lines(rows)
    assert "height error at the top" in lines[0] and "stand:3+walk:8:6+stand:2" in lines[2]


def test_leave_one_out_needs_two_walks():
    with pytest.raises(ValueError, match="at least two"):
        walk_results(["only_one.txt"], workers=0)


def test_an_error_free_module_walks_100_m_at_5_km_h_to_within_a_decimetre():
    """At its own 1 kHz, the length is right to 0.05 % and the height to 0.1 % (the mechanization's
    half-sample skew: docs/accuracy.md)."""
    row = speed_run((5.0, 1000.0, None))
    assert row["seed"] == "ideal" and row["steps"] >= 60
    assert abs(row["along"]) < 0.05 and abs(row["across"]) < 0.05 and abs(row["height"]) < 0.1


def test_the_speed_table_has_a_row_per_speed_and_rate(tmp_path):
    code, text = run(["speeds", "--seeds", "1:2", "--workers", "0", "--out", str(tmp_path)])
    assert code == 0
    lines = text.splitlines()
    assert "error-free" in lines[0] and len(lines) == 2 + 2 * len(SPEEDS_KMH)
    assert lines[1].split()[:3] == ["3", "km/h", "1000"] and lines[-2].split()[:2] == ["run", "250"]
    assert (tmp_path / "speeds.csv").is_file()


@pytest.mark.parametrize("argv", [["walks", "no_such_walk.txt", "other.txt"], ["slopes", "--seeds", "5:1"],
                                  ["speeds", "--seeds", "x"],
                                  ["slopes", "--workers", "-1"]])
def test_bad_arguments_exit_2(argv, capsys):
    code, _ = run(argv)
    assert code == 2 and "openshoe-accuracy:" in capsys.readouterr().err


@requires_walks
def test_each_walk_is_corrected_by_the_others_and_never_by_itself(tmp_path):
    paths = [walk_path(w) for w in WALK_IDS[:3]]
    results = walk_results(paths, workers=0)
    assert [r.name for r in results] == [p.stem for p in paths]
    for r in results:
        assert set(r.horizontal_pct) == {v[0] for v in VARIANTS}
        # drift correction moves positions only: the distance walked is the plain track's
        assert r.tracks["drift"].distance == pytest.approx(r.tracks["plain"].distance)
        assert r.horizontal_pct["plain"] != r.horizontal_pct["drift"]
    # with a calibration from itself a loop would close exactly; leave-one-out does not
    assert all(r.closure_3d_pct["drift"] > 0.01 for r in results)
    table = table_lines(results)
    assert table[-2].startswith("mean") and len(table) == len(results) + 3


@requires_walks
def test_the_walks_table_and_picture_are_written(tmp_path):
    code, text = run(["walks", *map(str, (walk_path(w) for w in WALK_IDS[:2])), "--workers", "0",
                      "--out", str(tmp_path)])
    assert code == 0 and "mean" in text
    assert (tmp_path / "walks.csv").read_text().count("\n") == 3
    assert (tmp_path / "height-walk.png").stat().st_size > 10_000


def test_the_speed_tables_sweep_spec_is_the_tools_product_and_gives_its_row():
    """``openshoe-emu sweep --spec tools/accuracy/speeds.toml`` runs the same recipes, rates and
    sensor models as ``openshoe-accuracy speeds``, and a run of it gives the tool's figures."""
    from pathlib import Path

    from firmware_sim.app import runs
    from firmware_sim.app.sweep import load_spec_file
    from tools.accuracy.speeds import RATES_HZ, speed_recipe

    spec = load_spec_file(Path(__file__).parents[2] / "tools" / "accuracy" / "speeds.toml")
    spec.check()
    assert spec.scenarios == tuple(speed_recipe(v) for v in SPEEDS_KMH)
    settings = dict(spec.settings)
    assert settings["scenario.rate_hz"] == RATES_HZ and set(settings["sensors.model"]) == {"ideal", "default"}
    assert settings["scenario.stance_sway"] == (False, True)
    assert spec.group_by == ("source", "scenario.rate_hz", "sensors.model", "scenario.stance_sway")
    (ideal_5kmh,) = [r for r in spec.runs() if r.source == speed_recipe(5.0) and r.seed == 1
                     and dict(r.settings) == {"scenario.rate_hz": 250.0, "sensors.model": "ideal",
                                              "scenario.stance_sway": False,
                                              "sensors.temperature.powered_s": 600.0}]
    row = runs.run_one(ideal_5kmh)
    tool = speed_run((5.0, 250.0, None))
    for k in ("along", "across", "height"):
        assert row[f"end_{k}_m"] == pytest.approx(tool[k], abs=1e-9)  # metres on 100 m = % of it
    (warm_5kmh,) = [r for r in spec.runs() if r.source == speed_recipe(5.0) and r.seed == 2
                    and dict(r.settings) == {"scenario.rate_hz": 250.0, "sensors.model": "default",
                                             "scenario.stance_sway": True,
                                             "sensors.temperature.powered_s": 600.0}]
    row, tool = runs.run_one(warm_5kmh), speed_run((5.0, 250.0, 2))
    for k in ("along", "across", "height"):
        assert row[f"end_{k}_m"] == pytest.approx(tool[k], abs=1e-9)  # the same warm, swaying module


def test_every_experiment_explains_itself(capsys):
    """`openshoe-accuracy --help` and each experiment's --help print (argparse formats help with %,
    so a stray percent sign would crash it)."""
    from tools.accuracy.cli import build_parser

    parser = build_parser()
    parser.format_help()
    commands = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction").choices
    assert {"error-free", "consistency", "navshoe-house", "walks-compass", "magcal"} <= set(commands)
    for name, sub in commands.items():
        assert name.split("-")[0] in sub.format_help()
