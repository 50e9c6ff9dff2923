"""`openshoe-emu sweep`: the spec, the settings, and the same table serially and on Dask —
also when a worker process dies in the middle of the sweep."""

from __future__ import annotations

import functools
import hashlib
import json
import os
import signal
import sys
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from firmware_sim.app import cli, runs, settings
from firmware_sim.app.sweep import SweepSpec, build_spec, run_sweep
from firmware_sim.links.link import Link
from firmware_sim.nav import fastpath
from protocol.ids import StateId

RECIPE = "stand:3+walk:3+stand:2"
TIMINGS = list(runs.TIMINGS)


def parse(argv: list[str]):
    return cli.build_parser().parse_args(["sweep", *argv, "--out", "unused"])


def small_spec(seeds=(0, 1, 2)) -> SweepSpec:
    spec = SweepSpec(scenarios=(RECIPE,), seeds=tuple(seeds), rate_hz=250.0,
                     settings=(("frontend.zupt_threshold", (16000, 4000)),))
    spec.check()
    return spec


def table(path: Path) -> str:
    """The table without its timing columns, as text (NaN equals NaN, floats to the last bit)."""
    return repr(pq.read_table(path).drop_columns(TIMINGS).to_pylist())


# ---------------------------------------------------------------------------------------------
# spec and settings


def test_the_command_line_spec_is_the_product_sorted_by_run_key():
    spec = build_spec(parse(["--scenario", "walk", "--scenario", "stand", "--seeds", "0:2",
                             "--set", "frontend.zupt_threshold=2e4,1e4", "--set", "link.byte_loss=0,1e-3"]))
    assert spec.setting_names == ("frontend.zupt_threshold", "link.byte_loss")
    assert spec.settings[0][1] == (20000, 10000)
    keys = [r.key for r in spec.runs()]
    assert len(keys) == 2 * 2 * 2 * 2 == len(set(keys)) and keys == sorted(keys)
    assert keys[0] == ("scenario", "stand", 0, 0, 10000, 0.0)  # module 0 (the seed's own), seed 0
    assert spec.runs()[0].name == "stand_seed0_zupt_threshold=10000_byte_loss=0.0"


def test_a_spec_file_and_the_command_line_add_up(tmp_path):
    toml = tmp_path / "s.toml"
    toml.write_text('scenarios = ["walk"]\nseeds = "3:5"\nrate_hz = 250.0\n'
                    '[settings]\n"sensors.noise" = [true, false]\n')
    spec = build_spec(parse(["--spec", str(toml), "--set", "sensors.gyro.noise_density_rad_s=1e-4"]))
    assert spec.seeds == (3, 4) and spec.rate_hz == 250.0
    assert dict(spec.settings) == {"sensors.noise": (True, False),
                                   "sensors.gyro.noise_density_rad_s": (1e-4,)}
    as_json = tmp_path / "s.json"
    data = {"scenarios": ["walk"], "seeds": [1, 2], "settings": {"link.profile": "usb"}}
    as_json.write_text(json.dumps(data))
    assert build_spec(parse(["--spec", str(as_json)])).settings == (("link.profile", ("usb",)),)


@pytest.mark.parametrize("argv, message", [
    (["--scenario", "walk", "--set", "frontend.nope=1"], "unknown setting"),
    (["--scenario", "walk", "--set", "sensors.accel.nope=1"], "SensorConfig has no field"),
    (["--scenario", "walk", "--set", "frontend.zupt_threshold=1.5"], "takes int values"),
    (["--scenario", "walk", "--set", "sensors.noise=maybe"], "takes bool values"),
    (["--scenario", "walk", "--set", "link.profile=wifi"], "takes one of ideal, bt, usb"),
    (["--scenario", "walk", "--set", "sensors.model=perfect"], "takes one of default, ideal"),
    (["--scenario", "walk", "--set", "scenario.rate_hz=0"], "takes positive numbers"),
    (["walk.txt", "--set", "scenario.rate_hz=250"], "scenarios only"),
    (["--scenario", "walk", "--set", "scenario.stance_sway=maybe"], "takes bool values"),
    (["walk.txt", "--set", "scenario.stance_sway=true"], "scenarios only"),
    (["--scenario", "walk", "--leave-one-out", "closure_pct"], "needs a setting"),
    (["--scenario", "walk", "--set", "sensors.noise=0,1", "--group-by", "speed"], "no column speed"),
    (["--scenario", "walk", "--set", "frontend.zupt_threshold=1,1"], "give each value once"),
    (["--scenario", "walk", "--set", "frontend.zupt_threshold"], "NAME=V1,V2"),
    (["walk.txt", "--set", "sensors.noise=false"], "scenarios only"),
    (["walk.txt", "--scenario", "walk"], "one of them"),
    ([], "one of them"),
])
def test_a_wrong_spec_is_refused(argv, message, capsys):
    assert cli.main(["sweep", *argv, "--out", "unused", "--workers", "0"]) == 2
    assert message in capsys.readouterr().err


def test_a_missing_recording_is_refused_before_any_run(tmp_path, capsys):
    assert cli.main(["sweep", str(tmp_path / "none.txt"), "--out", str(tmp_path), "--workers", "0"]) == 2
    assert "no such recording" in capsys.readouterr().err


def test_settings_reach_the_module_the_sensors_and_the_link():
    applied = settings.apply((("frontend.zaru_threshold", 20), ("sensors.gyro.noise_density_rad_s", 1e-3),
                              ("sensors.drift", False), ("link.byte_loss", 1e-3)))
    assert applied.initial_states == {int(StateId.TH_ZARU): 20}
    assert applied.sensors.gyro.noise_density_rad_s == 1e-3 and applied.sensors.drift is False
    assert applied.sensors.accel == settings.DEFAULT_CONFIG.accel
    link = applied.make_link(seed=5)
    assert isinstance(link, Link) and link.profile.name == "bt"
    assert settings.apply(()).make_link(0) is None, "no link setting: the plain replay's ideal port"


def test_a_threshold_changes_the_run_and_the_defaults_change_nothing():
    (plain,) = runs.scenario_runs([RECIPE], [0], rate_hz=250.0)
    (default,) = runs.scenario_runs([RECIPE], [0], 250.0, (("frontend.zupt_threshold", 16000),))
    (strict,) = runs.scenario_runs([RECIPE], [0], 250.0, (("frontend.zupt_threshold", 500),))
    a, b, c = (runs.run_one(s) for s in (plain, default, strict))
    assert a["wire_sha256"] == b["wire_sha256"] != c["wire_sha256"]


def test_the_stance_sway_setting_is_the_replays_option_and_its_default_sways():
    """scenario.stance_sway=true makes the run the one --stance-sway replays (the same bytes), which
    is also the run without the setting; false is the still-stance run."""
    from firmware_sim.app.batch import run_replay
    from firmware_sim.sensors.imu_array import make_source

    (plain,) = runs.scenario_runs([RECIPE], [1], rate_hz=250.0)
    (off,) = runs.scenario_runs([RECIPE], [1], 250.0, (("scenario.stance_sway", False),))
    (on,) = runs.scenario_runs([RECIPE], [1], 250.0, (("scenario.stance_sway", True),))
    a, b, c = (runs.run_one(s) for s in (plain, off, on))
    assert a["wire_sha256"] == c["wire_sha256"] != b["wire_sha256"]
    still = bytes(run_replay(make_source(RECIPE, seed=1, rate_hz=250.0, stance_sway=False), announce=None))
    assert b["wire_sha256"] == hashlib.sha256(still).hexdigest()
    swaying = bytes(run_replay(make_source(RECIPE, seed=1, rate_hz=250.0, stance_sway=True), announce=None))
    assert c["wire_sha256"] == hashlib.sha256(swaying).hexdigest()
    assert settings.apply((("scenario.stance_sway", True),)).stance_sway is True


def test_a_lossy_link_still_gives_every_step_to_a_lossless_host():
    (clean,) = runs.scenario_runs([RECIPE], [2], 250.0, (("link.byte_loss", 0.0), ("link.profile", "bt")))
    (lossy,) = runs.scenario_runs([RECIPE], [2], 250.0, (("link.byte_loss", 2e-2), ("link.profile", "bt")))
    a, b = runs.run_one(clean), runs.run_one(lossy)
    assert a["wire_sha256"] != b["wire_sha256"]  # bytes were lost and sent again
    # the lossy link changes the µC loop's timing a little (the distance by micrometres), not the steps
    assert a["steps"] == b["steps"] > 0 and b["distance_m"] == pytest.approx(a["distance_m"], abs=1e-3)


# ---------------------------------------------------------------------------------------------
# serial and distributed


@pytest.fixture(scope="module")
def serial_table(tmp_path_factory):
    out = tmp_path_factory.mktemp("serial")
    argv = ["sweep", "--scenario", RECIPE, "--rate", "250", "--seeds", "0:3",
            "--set", "frontend.zupt_threshold=16000,4000", "--out", str(out), "--workers", "0", "-q",
            "--no-plot"]
    assert cli.main(argv) == 0
    return out


def test_the_serial_table_has_a_row_per_run_sorted_by_key(serial_table):
    t = pq.read_table(serial_table / "runs.parquet")
    assert t.num_rows == 6
    assert t.column("seed").to_pylist() == [0, 0, 1, 1, 2, 2]
    assert t.column("frontend.zupt_threshold").to_pylist() == [4000, 16000] * 3
    assert set(t.column_names) >= {"steps", "distance_m", "closure_m", "closure_pct", *TIMINGS}
    assert (serial_table / "runs.csv").read_text().count("\n") == 7


@pytest.mark.slow
def test_a_local_cluster_writes_the_serial_table(serial_table, tmp_path):
    argv = ["sweep", "--scenario", RECIPE, "--rate", "250", "--seeds", "0:3",
            "--set", "frontend.zupt_threshold=16000,4000", "--out", str(tmp_path), "--workers", "2", "-q"]
    assert cli.main(argv) == 0
    assert table(tmp_path / "runs.parquet") == table(serial_table / "runs.parquet")
    assert (tmp_path / "closure.png").stat().st_size > 1000


def kill_own_worker_once(spec: runs.RunSpec, marker: str) -> dict:
    """The run; but the run of seed 1 first kills the worker process it runs in (once)."""
    if spec.seed == 1 and spec.settings[0][1] == 4000:
        try:
            os.close(os.open(marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY))
        except FileExistsError:
            pass
        else:
            os.kill(os.getpid(), signal.SIGKILL)
    return runs.run_one(spec)


def worker_cache_use() -> dict:
    """On a worker: whether it was prepared, whether its loop was built ahead of time (no numba),
    and numba's cache hits and misses of the two kernels where numba ran them."""
    from firmware_sim.nav import fastpath, warmup
    from firmware_sim.sensors import openshoe_scan

    driver = sys.modules.get("firmware_sim.nav.driver")
    kernels = (getattr(driver, "run_loops", None), openshoe_scan._scan)
    stats = [k.stats for k in kernels if hasattr(k, "stats")]
    return {"prepared": warmup._prepared is not None, "ahead_of_time": fastpath.ahead_of_time(),
            "hits": sum(sum(s.cache_hits.values()) for s in stats),
            "misses": sum(sum(s.cache_misses.values()) for s in stats)}


@pytest.fixture
def local_cluster():
    import logging

    import cloudpickle
    from distributed import Client, LocalCluster

    cloudpickle.register_pickle_by_value(sys.modules[__name__])  # the workers need not import tests
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                      silence_logs=logging.CRITICAL) as cluster, Client(cluster) as client:
        yield cluster.scheduler_address, client
    cloudpickle.unregister_pickle_by_value(sys.modules[__name__])


@pytest.mark.slow
def test_a_worker_killed_mid_sweep_loses_no_row_and_doubles_none(serial_table, local_cluster, tmp_path):
    address, client = local_cluster
    marker = tmp_path / "killed-once"
    runner = functools.partial(kill_own_worker_once, marker=str(marker))
    rows = run_sweep(small_spec(), scheduler=address, quiet=True, runner=runner)
    assert marker.exists(), "a worker process was killed during the sweep"
    from firmware_sim.app.sweep import write_tables

    write_tables(rows, ("frontend.zupt_threshold",), tmp_path)
    assert table(tmp_path / "runs.parquet") == table(serial_table / "runs.parquet")
    if fastpath.available():
        for worker, use in client.run(worker_cache_use).items():
            loaded = use["ahead_of_time"] or use["hits"] >= 2  # built ahead of time, or numba's cache
            assert use["prepared"] and use["misses"] == 0 and loaded, worker


def test_a_run_that_fails_stops_the_sweep_with_its_reason(tmp_path, capsys):
    spec = tmp_path / "s.json"
    # a recipe within range, too many samples at this rate: refused when the run makes its walk
    spec.write_text(json.dumps({"scenarios": ["stand:250"], "rate_hz": 10000.0}))
    assert cli.main(["sweep", "--spec", str(spec), "--out", str(tmp_path), "--workers", "0", "-q"]) == 1
    assert "a walk of 250 s at 10000 Hz is 2.5e+06 samples" in capsys.readouterr().err
