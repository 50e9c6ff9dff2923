"""Releases: when the bytes on a module's links reach a host, on the wall clock."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from .host_clock import HostClock


class Releases:
    """The links of the modules of a loop that run ahead, each on its module's host clock,
    and the wall time at which each module's links next have bytes reaching a host
    (``at[k]``; ``inf``: none)."""

    def __init__(self, n_mod: int):
        self.at = [math.inf] * n_mod
        self._first = math.inf  # min(at), kept as at changes (a loop of many modules asks every frame)
        self.links: list[list[Any]] = [[] for _ in range(n_mod)]
        self._clocks: list[HostClock | None] = [None] * n_mod

    def attach(self, k: int, clock: HostClock, links: list[Any], late_tolerance_cycles: int) -> None:
        """Put module *k*'s *links* on the host's *clock* (until :meth:`detach`)."""
        self._clocks[k] = clock
        self.links[k] = links
        for link in links:
            link.host_clock = clock
            link.late_tolerance_cycles = late_tolerance_cycles

    def detach(self) -> None:
        """Every link back on its module's clock."""
        for links in self.links:
            for link in links:
                link.host_clock = None

    def earliest(self) -> float:
        """When the next bytes reach a host, of any module."""
        return self._first

    def _set(self, k: int, t: float) -> None:
        old = self.at[k]
        self.at[k] = t
        if t < self._first:
            self._first = t
        elif old == self._first and t != old:
            self._first = min(self.at)

    def update(self, k: int) -> None:
        """Look again at when module *k*'s links next have bytes reaching a host."""
        clock = self._clocks[k]
        best = math.inf
        if clock is not None:
            for link in self.links[k]:
                t = link.next_host_arrival()
                if t is not None:
                    w = clock.wall_time(t)
                    if w < best:
                        best = w
        self._set(k, best)

    def release_due(self, now: float, hand_over: Callable[[int], None]) -> None:
        """Hand over (``hand_over(k)``: pump module *k*'s endpoints, then :meth:`update`) the
        bytes that reach a host by *now* on their link model's clock."""
        at = self.at
        if self._first <= now:
            for k in range(len(at)):
                if at[k] <= now:
                    hand_over(k)
                    if at[k] <= now:
                        # no endpoint took them (no host on it yet): look again after the
                        # module's next frame instead of spinning on them
                        self._set(k, math.inf)
