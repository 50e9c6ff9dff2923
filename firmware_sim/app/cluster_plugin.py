"""The worker plugin of the project's Dask clusters (:func:`firmware_sim.app.cluster.open_client`).

It lives apart from :mod:`firmware_sim.app.cluster` because it needs ``distributed`` as soon as it
is defined: a sweep in this process (``--workers 0``) and the lab's serial runs then start without
loading Dask's distributed stack.
"""

from __future__ import annotations

from typing import Any

from distributed.diagnostics.plugin import WorkerPlugin

from .prepare import prepare_process

__all__ = ["PrepareWorker"]


class PrepareWorker(WorkerPlugin):
    """Prepares each worker process once, when it joins, a restarted one too
    (:func:`~firmware_sim.app.prepare.prepare_process`)."""

    name = "openshoe-prepare"

    def setup(self, worker: Any) -> None:
        prepare_process()
