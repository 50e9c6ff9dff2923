"""Each module's own calibrations: a saved magnetometer calibration found for the module a walk or
capture comes from, and a drift or magnetometer calibration made with another module refused.

A module names itself by its MCU serial number (the fusion set-up asks for it once; a capture
holds it). A magnetometer calibration is kept per module (:mod:`hostlib.calibration.magcal`), a
drift calibration names the module it was made with (:mod:`hostlib.calibration.drift`); both refuse
another module's serial number, and with a module on each foot a pair given in the wrong order
is named as swapped.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING

from protocol.board import FOOT_SIDES

from ..calibration.drift import DriftCalibration, serial_text
from ..calibration.magcal import MagCalibration, load_for_module
from ..errors import HostError
from .options import AidOptions

if TYPE_CHECKING:
    from ..fusion.feet import TwoFeetTracker
    from ..link.device import Device
    from .aid_setup import AidSetup

__all__ = ["await_serial", "check_feet_modules", "check_mag_module", "check_module", "saved_calibration",
           "serial_wait_s", "use_saved_calibrations"]


def serial_wait_s(dev: Device) -> float:
    """How long to wait for a module to name itself: twice its ack timeout, at least 2 s."""
    return max(2.0, 2 * dev.ack_timeout)


def await_serial(dev: Device, timeout: float) -> None:
    """Wait up to *timeout* s for the packet with the module's serial number (the fusion set-up's
    MCU_ID), reading packets meanwhile."""
    deadline = time.monotonic() + timeout
    while dev.session.mcu_serial is None and time.monotonic() < deadline:
        dev.recv_packet(timeout=max(0.0, min(0.5, deadline - time.monotonic())))


def saved_calibration(options: AidOptions, serial: bytes | None) -> tuple[MagCalibration, Path] | None:
    """The saved magnetometer calibration (calibration, file) of the module whose serial number is
    *serial*, when the options want one (:attr:`~hostlib.run.options.AidOptions.wants_saved_calibration`);
    else None."""
    if not options.wants_saved_calibration or not serial:
        return None
    return load_for_module(serial_text(serial), options.mag_cal_dir)


def use_saved_calibrations(options: AidOptions, aids: AidSetup, serials: Mapping[str | None, bytes | None]
                           ) -> None:
    """Before the first step: give the compass of each module (side → its serial number, None
    unknown; side None: the only module) the module's saved magnetometer calibration, if there is
    one (:func:`saved_calibration`); the summary says which file each came from."""
    for side, serial in serials.items():
        found = saved_calibration(options, serial)
        if found is None:
            continue
        source = f"saved {found[1]}"
        if side is None:
            aids.tracker.release_compass(found[0])
            aids.calibration_source = source
        else:
            aids.tracker.foot(side).release_compass(found[0])
            aids.foot_calibration_sources[side] = source


def check_mag_module(cal: MagCalibration, serial: bytes | None) -> None:
    """Refuse a magnetometer calibration fitted on another module than the one whose MCU serial
    number is *serial* (None: unknown, accepted)."""
    cal.check_module(serial_text(serial) if serial else "")


def check_module(serial: bytes | None, drift: DriftCalibration | None, cal: MagCalibration | None) -> None:
    """Refuse another module's drift or magnetometer calibration (*serial*: the module's, None
    unknown: accepted)."""
    if serial is None:
        return
    if drift is not None:
        drift.check_module(serial)
    if cal is not None:
        check_mag_module(cal, serial)


def check_feet_modules(tracker: TwoFeetTracker, serials: Mapping[str, bytes | None], files: Mapping[str, str]
                       ) -> None:
    """Refuse a foot's drift or magnetometer calibration made with another module than the one on
    that foot (*serials*: side → the module's serial number, None unknown; *files*: side → where
    its stream came from); a pair given in the wrong order is named as swapped."""
    checks: list[tuple[str, str, Callable[[bytes | None], None]]] = []
    for side in FOOT_SIDES:
        drift = tracker.drift.get(side)
        if drift is not None:
            checks.append((side, "drift", drift.check_module))
        cal = tracker.foot(side).settings.mag_calibration
        if cal is not None:
            checks.append((side, "magnetometer", lambda serial, cal=cal: check_mag_module(cal, serial)))
    for side, what, check in checks:
        try:
            check(serials[side])
        except HostError as exc:
            other = FOOT_SIDES[1 - FOOT_SIDES.index(side)]
            try:
                check(serials[other])
                hint = f"; it fits the {other} foot's module: give the left foot's calibration first"
            except HostError:
                hint = ""
            raise type(exc)(f"the {side} foot ({files[side]}): {what} calibration: {exc}{hint}") from None
