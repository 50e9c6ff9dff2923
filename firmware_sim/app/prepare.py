"""Getting a process ready to run modules and walks: whatever would otherwise compile or load on the
first one, done at once (:func:`prepare_process`). The test run does it once before its workers
start, and so does each Dask worker (:class:`~firmware_sim.app.cluster_plugin.PrepareWorker`); a
command that runs its walks itself, one after the other (``--workers 0``), leaves the simulation's
loops to the first walk that needs them."""

from __future__ import annotations

__all__ = ["prepare_process"]


def prepare_process(simulation: bool = True) -> None:
    """Load (or compile once) the tracking kernels, the walk reader and, with *simulation*, the
    simulation's loops in this process. Without, each of those loads when a walk first needs it
    (the same numbers; a recording or a short walk needs none, and its process does not import
    numba for them: :mod:`firmware_sim.sensors.compiled`)."""
    from firmware_sim.nav.warmup import prepare_compiled_path
    from firmware_sim.sensors import openshoe_scan, warm_up_compiled_loops

    prepare_compiled_path(None)
    openshoe_scan.warm_up()
    if simulation:
        warm_up_compiled_loops()
