"""Carrying out a walk: what a user has, as options (:mod:`~hostlib.run.options`: :class:`AidOptions`,
:class:`RunOptions`); the aids set up from them (:mod:`~hostlib.run.aid_setup`); what a host sends
besides 0x34 and the acks (:mod:`~hostlib.run.host_setup`, shared with the emulator's replayed host);
a walk with live modules (:class:`~hostlib.run.tracking_run.TrackingRun`: the in-situ calibration,
:mod:`~hostlib.run.in_situ`; each module's calibrations, :mod:`~hostlib.run.calibrations`; the status
line, :mod:`~hostlib.run.status`); and a GPS receiver read live (:mod:`~hostlib.run.gps_stream`)."""

from .aid_setup import AidSetup, prepare_aids, prepare_feet_aids
from .host_setup import HostSetup, SessionSetup
from .options import AidOptions, RunOptions
from .status import LiveLine, Messages
from .tracking_run import DeviceSetup, TrackedModule, TrackingRun

__all__ = ["AidOptions", "AidSetup", "DeviceSetup", "HostSetup", "LiveLine", "Messages", "RunOptions",
           "SessionSetup", "TrackedModule", "TrackingRun", "prepare_aids", "prepare_feet_aids"]
