"""The module's clock as the host sees it: T_INT_K unwrapped into seconds since power-on.

A step packet of the fusion set-up (:data:`protocol.extensions.FUSION_SETUP`) carries
T_INT_K, the module's 64 MHz cycle counter (:data:`protocol.states.TIMESTAMP_HZ`) when the
step's last measurement was taken. It is a uint32 and wraps every 67 s; steps come at most
about a second apart, so the host unwraps it by adding each difference modulo 2³².
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from protocol.ids import StateId
from protocol.states import TIMESTAMP_HZ

__all__ = ["ModuleClock"]

_WRAP = 1 << 32


class ModuleClock:
    """Unwraps one module's T_INT_K, packet after packet."""

    def __init__(self) -> None:
        self._cycles: int | None = None  # the last T_INT_K seen
        self._total = 0  # cycles, unwrapped (the first reading's own value to start with)

    def seconds(self, states: Mapping[int, Any] | None) -> float:
        """The module time [s] of the packet whose decoded *states* these are (NaN: no T_INT_K)."""
        if states is None or StateId.T_INT_K not in states:
            return math.nan
        cycles = int(states[StateId.T_INT_K])
        if self._cycles is None:
            self._total = cycles
        else:
            self._total += (cycles - self._cycles) % _WRAP
        self._cycles = cycles
        return self._total / TIMESTAMP_HZ
