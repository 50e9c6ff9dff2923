"""What an aid did with one reading: :class:`AidEvent`, told to whoever observes a tracker's aids
(:meth:`hostlib.fusion.aided.AidedFilter.observe_aids`) — a live view that draws each compass reading
and GPS fix where the walker was, say.

The filter keeps counts (:class:`~hostlib.fusion.settings.FusionStats`); an observer hears of each
reading as it is taken, with where the measured point was and what became of it. Observers are
called in the thread that sums the step (a device's reader thread), under the tracker's lock: they
should only note the event and return.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

__all__ = ["COMPASS_OUTCOMES", "GPS_OUTCOMES", "AidEvent", "AidObserver"]

#: What the compass did with a reading: it had none or the wearer stood ("skipped"), the heading was
#: no finite number ("refused"), the first reading aligned the heading ("aligned"), an update
#: ("used"), or the innovation gate kept it out ("rejected").
COMPASS_OUTCOMES = ("skipped", "refused", "aligned", "used", "rejected")
#: What the GPS did with a fix: it placed the origin ("origin"), came before the heading was aligned
#: ("before alignment"), fell between two updates ("skipped"), or was an update ("used").
GPS_OUTCOMES = ("origin", "before alignment", "skipped", "used")


@dataclass(frozen=True)
class AidEvent:
    """One compass reading or GPS fix as the filter took it.

    *at* is where the measured point was (north, east [m] in the track's frame) just before the
    reading: the stepping foot for the compass, the walker for a fix. *reading* is the compass's
    heading from magnetic north [rad] (None: no reading) or the fix (north, east [m] of the first
    fix); *innovation* what it differed from the filter's expectation (NaN where no update was
    tried); *declination* the filter's declination estimate then [rad] (the compass's true heading
    is *reading* plus it).
    """

    aid: str  #: "compass" or "gps"
    outcome: str  #: one of :data:`COMPASS_OUTCOMES` or :data:`GPS_OUTCOMES`
    step: int  #: the steps fused when it came
    pose: str  #: the filter's pose block it measured ("pose"; with two feet "left" or "right")
    at: tuple[float, float]
    reading: float | tuple[float, float] | None = None
    innovation: float = math.nan
    declination: float = 0.0
    time_s: float = math.nan  #: module time of the fix [s] (NaN for the compass)

    @property
    def accepted(self) -> bool:
        """Whether the reading went into the filter (an update, or the compass's alignment)."""
        return self.outcome in ("used", "aligned")


#: Who hears of the aids' readings.
AidObserver = Callable[[AidEvent], object]
