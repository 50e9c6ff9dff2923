"""Host SDK for OpenShoe modules, real or emulated.

Its data path uses only :mod:`protocol` and pyserial (numpy for the numbers; matplotlib only for
:mod:`hostlib.files.plot`), so it talks to a real module on ``/dev/rfcomm0`` exactly as to the
emulator. The public API, importable from ``hostlib``:

* **the link** — :class:`Device` (open by path or URL, a method per command with its ack, a reader
  thread, lossless acking, steps and packets; :class:`DeviceOptions`) and :class:`HostSession`
  (the same protocol logic without I/O);
* **the events** a host receives — :class:`CommandAckEvent`, :class:`PacketEvent`,
  :class:`StepEvent` (with its :class:`StepOutcome`), :class:`GapEvent`, :class:`LinkEvent`
  (:data:`StreamEvent`: the four a session decodes; :data:`Event`: any of the five);
* **the step sum** — :class:`StepTracker` sums steps into a :class:`Track` with covariance;
* **the fusion** — :class:`FusionTracker` (one module with the compass, GPS, declination and the
  error states of :class:`FusionSettings`), :class:`TwoFeetTracker` (a module on each foot,
  :class:`FeetSettings`), both configurations of one filter core, :class:`StateFilter`;
* **a walk** — :class:`TrackingRun` carries one out with live modules (the set-up after 0x34, the
  in-situ calibration, live GPS, the status line), from :class:`RunOptions` and the aids'
  :class:`AidOptions`; :func:`prepare_aids` builds an aided tracker from the same options;
* the errors — :class:`HostError` and its kinds.

Below it the sub-packages stack one way (``tests/test_layering.py``): :mod:`hostlib.track`,
:mod:`hostlib.link`, :mod:`hostlib.aids`, :mod:`hostlib.calibration`, :mod:`hostlib.fusion`,
:mod:`hostlib.files`, :mod:`hostlib.run`, :mod:`hostlib.cli`.
"""

from importlib import import_module
from typing import TYPE_CHECKING

from .errors import AckTimeout, DeviceClosed, HostError, LinkLost, NotSupportedByCommandSet, QueueFullWarning
from .events import (
    CommandAckEvent,
    Event,
    GapEvent,
    LinkEvent,
    PacketEvent,
    StepEvent,
    StepOutcome,
    StreamEvent,
)
from .track.steps import StepTracker, Track

if TYPE_CHECKING:  # type checkers see the classes the lazy __getattr__ below hands out
    from .fusion.core import StateFilter
    from .fusion.feet import FeetSettings, TwoFeetTracker
    from .fusion.settings import FusionSettings
    from .fusion.tracker import FusionTracker
    from .link.device import Device
    from .link.device_options import DeviceOptions
    from .link.session import HostSession
    from .run.aid_setup import prepare_aids
    from .run.options import AidOptions, RunOptions
    from .run.tracking_run import TrackingRun

#: What the lazy names come from: importing ``hostlib`` stays light (the events and the step sum)
#: for users who only sum steps; the link pulls in pyserial, the fusion pygeomag and pymap3d.
_LAZY = {
    "Device": ".link.device", "DeviceOptions": ".link.device_options", "HostSession": ".link.session",
    "StateFilter": ".fusion.core", "FusionSettings": ".fusion.settings", "FusionTracker": ".fusion.tracker",
    "FeetSettings": ".fusion.feet", "TwoFeetTracker": ".fusion.feet",
    "AidOptions": ".run.options", "RunOptions": ".run.options", "TrackingRun": ".run.tracking_run",
    "prepare_aids": ".run.aid_setup",
}

__all__ = [
    "AckTimeout",
    "AidOptions",
    "CommandAckEvent",
    "Device",
    "DeviceClosed",
    "DeviceOptions",
    "Event",
    "FeetSettings",
    "FusionSettings",
    "FusionTracker",
    "GapEvent",
    "HostError",
    "HostSession",
    "LinkEvent",
    "LinkLost",
    "NotSupportedByCommandSet",
    "PacketEvent",
    "QueueFullWarning",
    "RunOptions",
    "StateFilter",
    "StepEvent",
    "StepOutcome",
    "StepTracker",
    "StreamEvent",
    "Track",
    "TrackingRun",
    "TwoFeetTracker",
    "prepare_aids",
]


def __getattr__(name: str):
    if name in _LAZY:
        return getattr(import_module(_LAZY[name], __name__), name)
    raise AttributeError(f"module 'hostlib' has no attribute {name!r}")
