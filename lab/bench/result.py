"""One benchmark target's figure against its goal, as the summary line and the JSON give it."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

__all__ = ["Result"]


@dataclass
class Result:
    """One target's figure against its goal (``higher`` = bigger is better)."""

    name: str
    figure: float
    unit: str
    target: float
    higher: bool = True
    passed: bool = False
    short: bool = False
    details: dict[str, Any] = field(default_factory=dict)

    note: str = ""
    #: a table to print above the summary lines (not in the JSON: its figures are in *details*)
    table: str = ""

    @property
    def ratio(self) -> float:
        """figure / target (≥ 1 meets a higher-is-better target, ≤ 1 a lower-is-better one)."""
        return self.figure / self.target if self.target else float("inf")

    def line(self) -> str:
        fig = f"{self.figure:.0f}" if abs(self.figure) >= 100 else f"{self.figure:.3g}"
        tgt = f"{self.target:.0f}" if abs(self.target) >= 100 else f"{self.target:g}"
        extra = "" if self.passed else " NOT MET"
        if self.note:
            extra += f"; {self.note}"
        if self.short:
            extra += "; SHORT run (see --help for the full one)"
        return f"{self.name}: {fig} {self.unit} (target {tgt}, ratio {self.ratio:.2f}){extra}"
