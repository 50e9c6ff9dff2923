"""The plan of the ``hostile`` target of `python -m lab.bench` (:mod:`lab.bench.hostile`): how many
modules, for how long, the baseline beside or before the load, the walk, the seed and the hostile
clients' behaviour."""

from __future__ import annotations

import random
from dataclasses import dataclass, field

from .hostile_load import CommandFuzzer, HostileConfig

__all__ = ["CHECK_STEPS", "HOSTILE_MINUTES", "HOSTILE_MODULES", "HOSTILE_SCENARIO", "HostilePlan",
           "hostile_plan"]

HOSTILE_MINUTES = 10.0
HOSTILE_MODULES = 10
HOSTILE_SCENARIO = "stand:3+walk:100"
#: Steps the clean host must get after 0x34.
CHECK_STEPS = 5


@dataclass(frozen=True)
class HostilePlan:
    """How the hostile target runs."""

    modules: int
    minutes: float
    baseline: str = "side-by-side"  #: or "before"
    scenario: str = HOSTILE_SCENARIO
    seed: int = 0
    config: HostileConfig = field(default_factory=HostileConfig)
    check_steps: int = CHECK_STEPS

    @property
    def short(self) -> bool:
        return self.minutes < HOSTILE_MINUTES or self.modules < HOSTILE_MODULES

    @property
    def sample_s(self) -> float:
        """Seconds between two samples of the serve processes (10, or a 20th of a short run)."""
        return max(0.5, min(10.0, self.minutes * 60 / 20))


def hostile_plan(modules: int, minutes: float, baseline: str = "side-by-side", seed: int = 0,
                 rate_hz: float = 10.0, check_steps: int = CHECK_STEPS,
                 commands: tuple[str, ...] = ()) -> HostilePlan:
    """The plan of a run; ValueError for a value it cannot run (*commands*: only these, by name)."""
    if modules < 1 or minutes <= 0 or rate_hz <= 0:
        raise ValueError("hostile: --modules must be >= 1, --minutes and --hostile-rate > 0")
    if baseline not in ("side-by-side", "before"):
        raise ValueError(f"hostile: unknown baseline {baseline!r}")
    config = HostileConfig(rate_hz=rate_hz, commands=tuple(commands))
    CommandFuzzer(random.Random(0), only=config.commands)  # refuses an unknown name now
    return HostilePlan(modules, minutes, baseline, seed=seed, config=config, check_steps=check_steps)
