"""The host's fusion filter: one state-space core with named state blocks, the one-foot and
two-feet trackers built on it, and the error and aid states they hold (the module's errors, the
compass's local deviation, the receiver's bias). No I/O.

The names below are imported when first used: importing one of the package's light modules (the
settings of an aid, :mod:`~hostlib.fusion.feet_settings`) does not import the trackers."""

from importlib import import_module
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # type checkers see the classes the lazy __getattr__ below hands out
    from .feet import TwoFeetTracker
    from .feet_settings import FeetSettings
    from .tracker import FusionSettings, FusionTracker

_LAZY = {"FeetSettings": ".feet_settings", "TwoFeetTracker": ".feet", "FusionSettings": ".tracker",
         "FusionTracker": ".tracker"}

__all__ = ["FeetSettings", "FusionSettings", "FusionTracker", "TwoFeetTracker"]


def __getattr__(name: str):
    if name in _LAZY:
        return getattr(import_module(_LAZY[name], __name__), name)
    raise AttributeError(f"module 'hostlib.fusion' has no attribute {name!r}")
