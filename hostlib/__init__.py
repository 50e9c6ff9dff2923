"""Host SDK for OpenShoe modules, real or emulated.

Its data path uses only :mod:`protocol` and pyserial (numpy for the numbers;
matplotlib only for :mod:`hostlib.files.plot`), so it talks to a real module on
``/dev/rfcomm0`` exactly as to the emulator.

* :class:`Device` — open a link, typed commands with acks, reader thread,
  lossless acking, steps and packets (:mod:`hostlib.link.device`);
* :class:`HostSession` — the same protocol logic without I/O (:mod:`hostlib.link.session`);
* the events a host receives — :class:`CommandAckEvent`, :class:`PacketEvent`,
  :class:`StepEvent`, :class:`GapEvent`, :class:`LinkEvent` (:mod:`hostlib.events`);
* :class:`StepTracker`, :class:`Track` — step-wise dead reckoning with covariance
  (:mod:`hostlib.track.steps`);
* :mod:`hostlib.calibration.drift` — closed-loop drift correction of one module (calibrate from closed
  loops walked with the fusion set-up, apply to its later tracks);
* :mod:`hostlib.files.export` (CSV, GeoJSON), :mod:`hostlib.files.plot` (PNG), :mod:`hostlib.cli`.
"""

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
    from .link.device import Device
    from .link.session import HostSession

__all__ = [
    "AckTimeout",
    "CommandAckEvent",
    "Device",
    "DeviceClosed",
    "Event",
    "GapEvent",
    "HostError",
    "HostSession",
    "LinkEvent",
    "LinkLost",
    "NotSupportedByCommandSet",
    "PacketEvent",
    "QueueFullWarning",
    "StepEvent",
    "StepOutcome",
    "StepTracker",
    "StreamEvent",
    "Track",
]


def __getattr__(name: str):
    # Device and HostSession pull in pyserial/protocol.stream; import them on first use so that
    # `import hostlib.track.steps` stays light for users who only sum steps.
    if name == "Device":
        from .link.device import Device

        return Device
    if name == "HostSession":
        from .link.session import HostSession

        return HostSession
    raise AttributeError(f"module 'hostlib' has no attribute {name!r}")
