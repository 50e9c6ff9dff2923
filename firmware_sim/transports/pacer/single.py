"""A :class:`Pacer`: one module run paced to the wall clock in a loop of its own."""

from __future__ import annotations

from collections.abc import Iterable
from typing import cast

from firmware_sim.mcu.module import Module
from firmware_sim.nav.warmup import Announce, to_stderr

from .endpoints import Endpoint
from .group import MultiPacer
from .member import PacedModule


class Pacer(PacedModule):
    """Runs *module* paced to the wall clock (× *speed*), pumping *endpoints*.

    Alone (:meth:`start`, :meth:`run`) it has a loop of its own, which pumps every
    endpoint on every pass; handed to a :class:`~.group.MultiPacer` it is one module of
    that loop, and keeps its own counters, status and control queue (:meth:`call`)."""

    def __init__(self, module: Module, endpoints: Iterable[Endpoint] = (), speed: float = 1.0,
                 max_lag_s: float = 0.25, asap_pump_ticks: int = 10):
        super().__init__(module, endpoints, speed=speed, max_lag_s=max_lag_s, asap_pump_ticks=asap_pump_ticks)
        MultiPacer([self], idle_pump_s=0.0, spin_load=None)

    @property
    def group(self) -> MultiPacer:
        """The loop this module runs in (its own, or a shared :class:`~.group.MultiPacer`)."""
        return cast(MultiPacer, super().group)

    def start(self, announce: Announce | None = to_stderr) -> Pacer:
        """Prepare the module (:func:`~firmware_sim.nav.warmup.prepare_module`: no compile once the
        clock runs; *announce* hears about a slow first start), then run the loop in a
        background thread (daemon)."""
        self.group.start(announce)
        return self

    def __enter__(self) -> Pacer:
        return self.start()
