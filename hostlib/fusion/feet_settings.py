"""How :class:`~hostlib.fusion.feet.TwoFeetTracker` fuses a walker's two feet: :class:`FeetSettings`
(the inter-foot constraint's bound γ, the feet's start, a restarted foot's heading σ). A module of
its own, without the filter, so that a command line can make it, and show its defaults, without
importing the fusion."""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["FeetSettings"]


@dataclass(frozen=True)
class FeetSettings:
    """How the :class:`~hostlib.fusion.feet.TwoFeetTracker` fuses the two feet."""

    #: apply the inter-foot constraint (off: the joint filter is the two single tracks)
    constraint: bool = True
    #: γ [m]: the feet's last rests are never farther apart (:mod:`hostlib.fusion.feet`)
    max_separation_m: float = 1.0
    #: lateral distance between the feet at the start [m]: the left foot starts half of it to the
    #: left of the body, the right foot to the right (the host's frame starts at the body)
    step_width_m: float = 0.12
    #: heading uncertainty of a foot restarted at the other foot after a gap [rad]
    restart_heading_sigma_rad: float = math.radians(5.0)

    def __post_init__(self) -> None:
        if not self.max_separation_m > 0:
            raise ValueError(f"the feet's maximum separation must be > 0 m, got {self.max_separation_m}")
        if not self.step_width_m >= 0:
            raise ValueError(f"the step width must be ≥ 0 m, got {self.step_width_m}")
