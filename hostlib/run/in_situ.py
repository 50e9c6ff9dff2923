"""The in-situ magnetometer calibration of one module on a live link: NavShoe's wiggle
(:class:`~hostlib.calibration.wiggle.WiggleCalibration`) fed from a
:class:`~hostlib.link.device.Device`, its fit handed to the compass, saved for the module and said.

Threads: the device's reader thread hands the wiggle the session's packets and steps, in their
order (callbacks); when the first long step ends it, the fit goes at once to the tracker (its
compass waits for it, :meth:`~hostlib.fusion.tracker.FusionTracker.hold_compass`), under the
device's session lock. The thread that drives the walk then sees the end
(:meth:`InSituCalibration.ended`), has the stream stopped (:class:`~hostlib.run.host_setup.HostSetup`)
and reports it (:meth:`InSituCalibration.report`): the calibration saved for the module, its summary
said.
"""

from __future__ import annotations

import threading
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..calibration.drift import serial_text
from ..calibration.magcal import MagCalibrationError, save_for_module
from ..calibration.wiggle import WiggleCalibration
from .status import Messages

if TYPE_CHECKING:
    from ..link.device import Device
    from .aid_setup import AidSetup

__all__ = ["InSituCalibration", "keep_in_situ"]


def keep_in_situ(wiggle: WiggleCalibration, directory: str | Path | None, messages: Messages) -> str:
    """Save an in-situ calibration for its module (:func:`hostlib.calibration.magcal.save_for_module`,
    in *directory*); returns where the tracker's calibration came from, for the summary. A file that
    cannot be written is said to *messages*, and the walk goes on."""
    if wiggle.calibration is None:
        return "the in-situ calibration was refused"
    try:
        path = save_for_module(wiggle.calibration, directory)
    except (MagCalibrationError, OSError) as exc:
        messages.note(f"the magnetometer calibration was not saved: {exc}")
        return "in situ, not saved"
    return f"in situ, saved {path}"


class InSituCalibration:
    """One module's in-situ calibration on *dev* (module docstring): its fit goes to the tracker of
    *aids* (None: a capture of the stream is all that is kept, as ``openshoe-host log`` does), and is
    saved for the module in *directory*; *messages* hears what the wearer should do and what came of
    it. Made before the module starts tracking: from then on the device's packets and steps feed it.
    """

    def __init__(self, dev: Device, directory: str | Path | None, messages: Messages,
                 aids: AidSetup | None = None):
        self.dev, self.directory, self.messages, self.aids = dev, directory, messages, aids
        self.wiggle = WiggleCalibration()
        #: whether the end was reported (the calibration saved and said)
        self.reported = False
        #: held while the reader thread hands a step over, so that the walk's thread sees the
        #: wiggle's end only once its fit is done
        self._lock = threading.Lock()
        if aids is not None:
            aids.tracker.hold_compass()
        dev.on_packet(lambda ev: self.wiggle.add_packet(ev.states))
        dev.on_step(self._step)

    def started(self) -> None:
        """The magnetometer stream runs: tell the wearer what to do."""
        self.messages.say("calibrating the magnetometers: wiggle the shoe in one place for about 30 s — toe "
                          "down and up, the sole to either side, all round — then walk off (a step longer "
                          f"than {self.wiggle.stop_step_m:g} m ends it)")

    def _step(self, ev: Any) -> None:
        serial = self.dev.session.mcu_serial
        with self._lock:
            ended = self.wiggle.add_step(ev.step.dx, serial_text(serial) if serial else "")
            if ended and self.aids is not None:
                with self.dev.session_lock:
                    self.wiggle.release(self.aids.tracker)

    def ended(self) -> bool:
        """Whether the wiggle ended (fitted or refused; a fit under way is waited for)."""
        with self._lock:
            return self.wiggle.done

    def report(self) -> None:
        """The wiggle ended: save the calibration, say what came of it (once)."""
        self.reported = True
        source = keep_in_situ(self.wiggle, self.directory, self.messages)
        self.messages.note(self.wiggle.summary())
        if self.aids is not None:
            self.aids.calibration_source = source
        elif self.wiggle.calibration is not None:
            self.messages.note(f"magnetometer calibration: {source}")

    def unfinished(self) -> None:
        """The walk ended before the wiggle did: say so (to the summary, or to *messages*)."""
        if self.aids is not None:
            self.aids.calibration_source = "the wiggle did not end"
        else:
            self.messages.note(f"{self.wiggle.summary()}; nothing saved")
