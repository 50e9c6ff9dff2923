"""The host's fusion filter: one state-space core with named state blocks, the one-foot and
two-feet trackers built on it, and the error and aid states they hold (the module's errors, the
compass's local deviation, the receiver's bias). No I/O."""

from .feet import FeetSettings, TwoFeetTracker
from .tracker import FusionSettings, FusionTracker

__all__ = ["FeetSettings", "FusionSettings", "FusionTracker", "TwoFeetTracker"]
