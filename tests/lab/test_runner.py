"""The lab's runs go through the project's Dask runner (firmware_sim.app.cluster), in order."""

from __future__ import annotations

import functools

from firmware_sim.app import cluster
from lab.runner import JOB, map_runs, seeded_rows


def test_every_job_is_a_run_of_the_projects_runner_and_comes_back_in_order(monkeypatch):
    given = []

    def execute(runs, client=None, **kw):
        given.append(list(runs))
        return real(runs, client, **kw)

    real = cluster.execute
    monkeypatch.setattr(cluster, "execute", execute)
    monkeypatch.setattr(cluster, "prepare_process", lambda **_: None)
    assert map_runs(len, ["a", "bb", (1, 2, 3)], workers=0) == [1, 2, 3]
    assert [(r.kind, r.seed, dict(r.settings)["job"]) for r in given[0]] == [
        (JOB, 0, "a"), (JOB, 1, "bb"), (JOB, 2, (1, 2, 3))]
    assert seeded_rows(lambda seed: [seed, -seed], [2, 1], workers=0) == [2, -2, 1, -1]


def test_a_local_cluster_gives_the_results_in_the_jobs_order():
    assert map_runs(functools.partial(pow, 2), [3, 1, 2], workers=1) == [8, 2, 4]
