"""The step sum: the module's step-wise displacements and heading changes, with their covariances,
chained into a track (:mod:`hostlib.track.steps`). Pure computation: no I/O, no protocol."""

from .steps import StepTracker, Track

__all__ = ["StepTracker", "Track"]
