"""The host's clock of a module that runs ahead: the wall clock in the module's cycles."""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol


class Origin(Protocol):
    """Where a loop's schedule starts on the wall clock (moved forward by rebases)."""

    t0: float


class HostClock:
    """The wall clock in a module's cycles: tick *m* (cycle ``c0 + m·period``) is at
    ``origin.t0 + m / rate + phase`` (*cycles_per_s*: the module's cycles per wall second).

    A link model with a host clock takes a host's bytes at the host's present and
    hands the module's bytes over when this clock passes their arrival (see the
    package doc)."""

    __slots__ = ("c0", "cycles_per_s", "phase", "_origin", "_perf")

    def __init__(self, c0: int, cycles_per_s: float, phase: float, origin: Origin, perf: Callable[[], float]):
        self.c0 = c0
        self.cycles_per_s = cycles_per_s
        self.phase = phase
        self._origin = origin
        self._perf = perf

    def __call__(self) -> int:
        """The host's present, in the module's cycles."""
        return self.c0 + int((self._perf() - self._origin.t0 - self.phase) * self.cycles_per_s)

    def wall_time(self, cycle: int) -> float:
        """When (on the wall clock) the host's present reaches *cycle*."""
        return self._origin.t0 + self.phase + (cycle - self.c0) / self.cycles_per_s
