"""Shared test fixtures: where the real walk recordings are, and skipping without them; every test
keeps its magnetometer calibrations in a folder of its own (never the user's). For a run on several
processes (pytest-xdist, ``make test``: ``-n 3 --dist worksteal``): the compiled kernels are put in
numba's on-disk cache once before the workers start, and the long tests go first, spread over the
workers."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

#: The tests pin the simulation's own default stance (gait.STANCE_SWAY_DEFAULT), whatever the
#: user's shell asks of the tools.
os.environ.pop("OPENSHOE_STANCE_SWAY", None)

REPO = Path(__file__).resolve().parent.parent
#: The shared recordings live beside the clone (never copied into it);
#: OPENSHOE_WALKS overrides the location.
WALKS_DIR = Path(os.environ.get("OPENSHOE_WALKS", REPO.parent / "shared" / "data" / "openshoe-walks"))
WALK_IDS = ("2", "3", "30", "31", "32", "33")


def walk_path(walk_id: str) -> Path:
    return WALKS_DIR / f"walk_100521_{walk_id}.txt"


def have_walks() -> bool:
    return all(walk_path(w).is_file() for w in WALK_IDS)


requires_walks = pytest.mark.skipif(
    not have_walks(),
    reason=f"the shared OpenShoe walk recordings are not at {WALKS_DIR} "
    "(a plain clone has no ../shared; set OPENSHOE_WALKS to their folder)",
)


@pytest.fixture
def walks_dir() -> Path:
    if not have_walks():
        pytest.skip(f"shared walk recordings not found at {WALKS_DIR}")
    return WALKS_DIR


@pytest.fixture(autouse=True)
def own_magcal_dir(tmp_path_factory, monkeypatch) -> Path:
    """``OPENSHOE_MAGCAL_DIR`` (hostlib.calibration.magcal's per-module calibrations) set to an empty
    folder of
    this test's, for it and the processes it starts: no test reads or writes the user's."""
    folder = tmp_path_factory.mktemp("magcal")
    monkeypatch.setenv("OPENSHOE_MAGCAL_DIR", str(folder))
    return folder


# ---------------------------------------------------------------------------------------------
# a run on several processes


#: Compiles the tracking kernels and the walk reader into numba's on-disk cache (or loads them).
FILL_KERNEL_CACHE = "from firmware_sim.app.cluster import prepare_process; prepare_process()"


@pytest.hookimpl(tryfirst=True)
def pytest_sessionstart(session: pytest.Session) -> None:
    """On the controller of a distributed run, before its workers start: the kernels are compiled
    into numba's cache once, in a process of its own (about 30 s with an empty cache, 1 s with a
    full one), instead of in each worker at once, or in a ``serve`` a test starts before its READY
    line. tests/e2e/test_first_run.py gives each of its processes an empty cache of its own."""
    config = session.config
    if hasattr(config, "workerinput") or not getattr(config.option, "numprocesses", None):
        return
    if os.environ.get("OPENSHOE_PURE"):
        return
    subprocess.run([sys.executable, "-c", FILL_KERNEL_CACHE], cwd=REPO, check=False,
                   stdin=subprocess.DEVNULL)


#: The long tests [CPU-s or wall-clock s, whichever is more, on a 2-core machine]: a folder or a
#: test file (its tests stay together in one process, sharing their module's fixtures and, in
#: tests/oracle, the oracle's runs on the shared walks) or one test (all its parameters, or one);
#: a test in more than one goes with the most specific (the docs' three longest examples on their
#: own, the other examples together). tests/test_long_tests.py checks that each entry names a test.
LONG_TESTS = {
    "tests/docs/test_examples.py": 100,
    "tests/docs/test_examples.py::test_example_runs[docs/guides/many-runs.md:161]": 12,
    "tests/docs/test_examples.py::test_example_runs[docs/guides/many-runs.md:44]": 7,
    "tests/docs/test_examples.py::test_example_runs[docs/guides/virtual-module.md:40]": 7,
    "tests/docs/test_docs.py::test_the_site_builds_without_warnings": 34,
    "tests/e2e/test_first_run.py::test_url_handler_answers_at_once_with_an_empty_kernel_cache": 30,
    "tests/e2e/test_first_run.py::test_demo_succeeds_on_the_first_try_with_an_empty_kernel_cache": 28,
    "tests/e2e/test_first_run.py::test_serve_answers_its_first_host_at_once_with_an_empty_kernel_cache": 20,
    "tests/lab/test_two_feet.py": 36,
    "tests/nav/test_kernels.py": 30,
    "tests/lab/test_spread.py": 30,
    "tests/e2e/test_wire_golden.py::test_default_scenario_replay_is_byte_identical": 35,
    "tests/nav/test_fastpath.py": 45,
    "tests/lab/test_navshoe.py": 19,
    "tests/hostlib/test_deviation.py": 18,
    "tests/hostlib/test_gps_bias.py": 22,
    "tests/oracle": 21,
    "tests/nav/test_nonfinite.py": 20,
    "tests/links/test_lossless_under_faults.py": 17,
    "tests/lab/test_magcal.py": 11,
    "tests/lab/test_accuracy.py": 11,
    "tests/hostlib/test_history_memory.py": 12,
    "tests/nav/test_any_sequence.py": 11,
    "tests/e2e/test_serve_gps.py": 8,
    "tests/e2e/test_demo.py": 11,
    "tests/app/test_calibrate_mag.py": 10,
    "tests/lab/test_consistency.py": 8,
}


def _long_test(nodeid: str) -> str | None:
    """The entry of :data:`LONG_TESTS` that *nodeid* belongs to (the most specific), if any."""
    keys = [key for key in LONG_TESTS
            if nodeid == key or nodeid.startswith((key + "::", key + "[", key + "/"))]
    return max(keys, key=len, default=None)


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(session: pytest.Session, config: pytest.Config,
                                  items: list[pytest.Item]) -> None:
    """The long tests first, so that no worker is left with one at the end while the others wait.

    xdist's worksteal gives each of its N workers a run of consecutive tests at first (the first
    len/N to the first worker, and so on), and an idle worker then takes half of what is left on
    the busiest one, from its end. So the long tests are dealt to the N runs' heads, the longest
    to the lightest head, and the other tests keep their order behind them. Run alone, the long
    tests simply go first. (trylast: after ``-k``/``-m`` took their pick.)"""
    workers = int(getattr(config, "workerinput", {}).get("workercount", 1))
    groups: dict[str, list[pytest.Item]] = {}
    rest = []
    for item in items:
        key = _long_test(item.nodeid)
        if key is None:
            rest.append(item)
        else:
            groups.setdefault(key, []).append(item)
    if not groups:
        return
    heads: list[list[pytest.Item]] = [[] for _ in range(workers)]
    loads = [0.0] * workers
    for key in sorted(groups, key=lambda k: -LONG_TESTS[k]):
        k = loads.index(min(loads))
        heads[k] += groups[key]
        loads[k] += LONG_TESTS[key]
    ordered: list[pytest.Item] = []
    left = len(items)
    for k, head in enumerate(heads):
        share = left // (workers - k)  # what worksteal sends this worker at first
        tail = rest[:max(0, share - len(head))]
        del rest[:len(tail)]
        ordered += head + tail
        left -= len(head) + len(tail)
    items[:] = ordered + rest
