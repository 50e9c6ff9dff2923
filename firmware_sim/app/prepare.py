"""Getting a process ready to run modules and walks: whatever would otherwise compile or load on the
first one, done at once (:func:`prepare_process`). The test run does it once before its workers
start, and so does each Dask worker (:class:`~firmware_sim.app.cluster_plugin.PrepareWorker`)."""

from __future__ import annotations

__all__ = ["prepare_process"]


def prepare_process() -> None:
    """Load (or compile once) the tracking kernels, the walk reader and the simulation's loops in
    this process."""
    from firmware_sim.nav.warmup import prepare_compiled_path
    from firmware_sim.sensors import openshoe_scan, warm_up_compiled_loops

    prepare_compiled_path(None)
    openshoe_scan.warm_up()
    warm_up_compiled_loops()
