"""A walk carried out with live modules: :class:`TrackingRun`, what ``openshoe-host track`` does, for
any program that holds :class:`~hostlib.link.device.Device`\\ s.

One module, or a module on each foot (:class:`~hostlib.fusion.feet.TwoFeetTracker`: both streams
acked and gap-checked on their own, fused into one body track; a lost link on one foot degrades
the fusion to the other foot, it never stops it). A run goes through four stages:

1. **prepare** (:meth:`TrackingRun.prepare`, or entering it as a context manager): a GPS receiver
   read live is opened (:mod:`hostlib.run.gps_stream`) and its first fix waited for, up to
   :attr:`TrackingRun.first_fix_wait_s`, to place the walk; the tracker is made — the fusion
   tracker :func:`~hostlib.run.aid_setup.prepare_aids` sets up (by default it holds the module's
   errors, with an aid or without), or with every aid and the module's errors off a plain
   :class:`~hostlib.track.steps.StepTracker` (:func:`~hostlib.run.aid_setup.prepare_feet_aids`
   for two feet). Open each module's device with its tracker (:meth:`TrackingRun.tracker_for`).
2. **start** (:meth:`TrackingRun.start`): the receiver's fixes are wired to the devices' steps; the
   compass waits for an in-situ calibration (:class:`~hostlib.run.in_situ.InSituCalibration`), or
   each module names itself and gets its saved calibration; then each module gets 0x34 (unless
   attaching) and the set-up the options ask for (:class:`~hostlib.run.host_setup.HostSetup`): by
   default the fusion set-up, which a module that does not acknowledge it goes without (tracked on
   plain 0x34 step packets, said once; :class:`DeviceSetup`).
3. **follow** (:meth:`TrackingRun.follow`): first each module's drift and magnetometer calibration is
   checked against the module (once it named itself); then the steps are read until the duration
   is over, the number of step packets came, or Ctrl-C, with a status line (:meth:`TrackingRun.status`)
   kept up to date; height compensation goes on at the first step, the wiggle's stream stops when it
   ended. A module whose walk fails is reported and left while another goes on; the failure of the
   last one is raised. At the end the outputs go off, unless left running.
4. **close**: the receiver is closed (after the devices, which the caller closes).

Typical use::

    run = TrackingRun(RunOptions(steps=200), AidOptions(compass=True, saved_calibration=True))
    with run, Device("/dev/rfcomm0", tracker=run.tracker) as dev:
        run.start(dev)
        run.follow(LiveLine(sys.stdout))
        print(run.aids.describe(), dev.track)
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from contextlib import ExitStack, suppress
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

from protocol.board import FOOT_SIDES
from protocol.ids import StateId

from ..calibration.drift import DriftCalibration
from ..errors import AckTimeout, HostError, NotSupportedByCommandSet
from ..events import LinkEvent, PacketEvent
from ..fusion.feet import FeetSettings, TwoFeetTracker
from ..track.steps import StepTracker
from .aid_setup import AidSetup, feet_tracker, prepare_aids
from .calibrations import (
    await_serial,
    check_feet_modules,
    check_module,
    serial_wait_s,
    use_saved_calibrations,
)
from .gps_stream import GpsStream, LiveFixes
from .host_setup import HostCommand, HostSetup
from .in_situ import InSituCalibration
from .options import AidOptions, RunOptions
from .status import LiveLine, Messages, aids_status, feet_summary_line, summary_line

if TYPE_CHECKING:
    from ..aids.gps import GpsFix
    from ..link.device import Device

__all__ = ["FIRST_FIX_WAIT_S", "DeviceSetup", "TrackedModule", "TrackingRun", "module_label", "open_receiver",
           "remaining"]

#: How long a run with a GPS receiver read live waits for its first fix before the walk starts [s]:
#: the first fix places the walk on the globe (and gives the declination there).
FIRST_FIX_WAIT_S = 10.0


def open_receiver(url: str, messages: Messages) -> GpsStream:
    """The GPS receiver at *url* (a device or pyserial URL), read in its own thread
    (:class:`~hostlib.run.gps_stream.GpsStream`); *messages* hears if it goes away. A receiver that
    cannot be opened is a :class:`~hostlib.errors.HostError`."""
    try:
        return GpsStream(url, LiveFixes(), report=messages.note)
    except (OSError, ValueError) as exc:  # pyserial's SerialException is an OSError
        raise HostError(f"cannot open the GPS receiver {url}: {exc}") from None


class DeviceSetup:
    """A :class:`~hostlib.run.host_setup.HostSetup` carried out on a device: each command sent and
    its ack waited for, in the thread that drives the walk; with the in-situ calibration *in_situ*
    (whose wiggle the set-up's is), its stream started and stopped, and its end reported.

    The fusion set-up is the one part a module may go without: one that does not acknowledge it (a
    firmware without STATE_IF_SETUP, the 2014 numbering) is tracked on plain 0x34 step packets, and
    one whose step packets come without a swing time (a real OpenShoe module: state 0x34 SWING_TIME
    is the emulator's) on what they carry; each is said once to *messages* (default: stderr) about
    the module *label* (default: its port), never a failure."""

    def __init__(self, dev: Device, setup: HostSetup, in_situ: InSituCalibration | None = None, *,
                 messages: Messages | None = None, label: str | None = None):
        self.dev, self.setup, self.in_situ = dev, setup, in_situ
        self.messages = messages or Messages()
        self.label = dev.name if label is None else label
        #: why the step packets are plain although the fusion set-up was asked for (None: they are not)
        self.plain_packets: str | None = None
        #: whether the set-up's step packets come without a swing time (None: none of them came yet)
        self.swing_time_missing: bool | None = None
        self._watching = False  # the reader thread looks at the packets for the first set-up step's
        self._swing_said = False

    def _send(self, commands: list[HostCommand]) -> None:
        for meaning, fields in commands:
            self.dev.command(meaning, **fields)

    def after_start(self) -> None:
        """Right after 0x34 (or, attaching, at once): the fusion set-up, the stream's start."""
        self._fusion_setup(self.setup.fusion_setup())
        self._send(self.setup.stream_start())
        if self.in_situ is not None:
            self.in_situ.started()

    def _fusion_setup(self, commands: list[HostCommand]) -> None:
        """The fusion set-up's *commands*, each after the ack of the one before; the first one the
        module does not take ends it, said once: the module is tracked on plain packets."""
        if not commands:
            return
        self._watching = True
        self.dev.on_packet(self._watch_swing_time)
        for meaning, fields in commands:
            try:
                self.dev.command(meaning, **fields)
            except (AckTimeout, NotSupportedByCommandSet) as exc:
                self._stop_watching()
                self.plain_packets = _not_taken(exc)
                self.messages.note(f"{self.label}: {self.plain_packets}; tracked on plain 0x34 step "
                                   "packets (no module time, attitude or magnetometers: the module's warm-up "
                                   "is not counted, and the compass, GPS and drift correction get nothing "
                                   "from them)")
                return

    def _watch_swing_time(self, event: PacketEvent) -> None:
        """In the reader thread: the first step packet of the set-up's (it carries the attitude) says
        whether the module fills SWING_TIME."""
        states = event.states
        if states is None or not {StateId.STEP_COUNTER, StateId.QUATERNION} <= states.keys():
            return
        self.swing_time_missing = StateId.SWING_TIME not in states
        self._stop_watching()

    def _stop_watching(self) -> None:
        """No more looking at the packets (from the reader thread or the walk's: removed once)."""
        watching, self._watching = self._watching, False
        if watching:
            with suppress(ValueError):  # the other thread removed it meanwhile
                self.dev.remove_callback(self._watch_swing_time)

    def _say_swing_time(self) -> None:
        """Once the set-up's step packets came without a swing time: say so, once."""
        if self.swing_time_missing and not self._swing_said:
            self._swing_said = True
            self.messages.note(f"{self.label}: its step packets carry no swing time (state 0x34 SWING_TIME, "
                               "an emulator extension a real OpenShoe module leaves out): the steps are "
                               "tracked on what they carry, the module's time among it; a drift correction "
                               "cannot use them")

    @property
    def sent(self) -> bool:
        """Whether every command of the set-up went out (height compensation waits for a step)."""
        return self.setup.sent

    def poll(self) -> None:
        """Between reads: height compensation once the first step packet came; the stream stopped
        and the calibration reported once the wiggle ended."""
        if self.dev.session.stats.steps > 0:
            self._send(self.setup.stepped())
        self._say_swing_time()
        in_situ = self.in_situ
        if in_situ is not None and not in_situ.reported and in_situ.ended():
            self._send(self.setup.stop_stream())
            in_situ.report()

    def close(self, leave_running: bool) -> None:
        """The walk or capture ended (the module's outputs off unless *leave_running*): a calibration
        that ended in the last moments is reported; one that did not end says so. The stream is
        stopped if the outputs stay on."""
        self._stop_watching()
        self._say_swing_time()
        in_situ = self.in_situ
        if in_situ is None or in_situ.reported:
            return
        if leave_running:
            self._send(self.setup.stop_stream())
        if in_situ.ended():
            in_situ.report()
        else:
            in_situ.unfinished()


@dataclass
class TrackedModule:
    """One module being tracked: which foot it is on (None: the only module), its device and host
    set-up, the error that ended its walk (None while it goes on), and, once its link was lost, how
    many step packets it had then (None: its link was never lost)."""

    side: str | None
    dev: Device
    setup: DeviceSetup
    failure: HostError | None = None
    steps_at_link_loss: int | None = None

    @property
    def quiet_since_link_loss(self) -> bool:
        """Its link was lost and no step packet came since (it came back silent, or not yet)."""
        return self.steps_at_link_loss is not None and self.dev.session.stats.steps <= self.steps_at_link_loss

    @property
    def label(self) -> str:
        """How messages name it: its port, and with two feet its foot."""
        return module_label(self.side, self.dev)


def module_label(side: str | None, dev: Device) -> str:
    """How messages name the module on *side* (None: the only one) at *dev*: its port, and with two
    feet its foot."""
    return dev.name if side is None else f"the {side} foot ({dev.name})"


def _not_taken(exc: AckTimeout | NotSupportedByCommandSet) -> str:
    """Why the module did not take a command of the fusion set-up, in words."""
    if isinstance(exc, NotSupportedByCommandSet):
        return (f"the fusion set-up's {exc.command} does not exist in the {exc.command_set} command "
                "numbering")
    return (f"the module did not acknowledge the fusion set-up's {exc.command} (0x{exc.wire_id:02X}; "
            f"{exc.attempts} attempt(s) of {exc.timeout:g} s)")


#: A drift calibration, or its file.
Drift = DriftCalibration | str | Path


def _loaded(drift: Drift) -> DriftCalibration:
    return drift if isinstance(drift, DriftCalibration) else DriftCalibration.load(drift)


class TrackingRun:
    """One walk with live modules (module docstring): how they are driven and when the walk ends
    (*options*, :class:`~hostlib.run.options.RunOptions`), its aids and calibrations (*aids*,
    :class:`~hostlib.run.options.AidOptions`), and with a module on each foot the feet's fusion
    (*feet*, :class:`~hostlib.fusion.feet.FeetSettings`; None: one module). *drift*: the module's
    drift calibration (its status line and end are corrected), or with two feet side → that foot's
    module's (the fusion corrects each step); a calibration or its file. *messages*: where what
    happens is said (default: stderr).
    """

    #: How long :meth:`prepare` waits for a live receiver's first fix [s].
    first_fix_wait_s = FIRST_FIX_WAIT_S

    def __init__(self, options: RunOptions | None = None, aids: AidOptions | None = None, *,
                 feet: FeetSettings | None = None, drift: Drift | Mapping[str, Drift] | None = None,
                 messages: Messages | None = None):
        self.options = options or RunOptions()
        self.aid_options = aids or AidOptions()
        self.feet_settings = feet
        if feet is not None and self.aid_options.calibrate_mag:
            raise ValueError("the in-situ calibration calibrates one module: calibrate each foot's module on "
                             "its own")
        self.drift = drift
        self.messages = messages or Messages()
        #: the tracker the steps are summed by: a StepTracker, a fusion tracker, or the two feet's
        self.tracker: StepTracker | TwoFeetTracker | None = None
        #: the aids and what setting them up found (None without aids)
        self.aids: AidSetup | None = None
        #: the GPS receiver read live (None without one)
        self.receiver: GpsStream | None = None
        #: the in-situ magnetometer calibration (None without one)
        self.in_situ: InSituCalibration | None = None
        #: the modules being tracked, once started
        self.modules: list[TrackedModule] = []
        self._stack = ExitStack()
        self._tracking_line: str | None = None

    # -- stage 1: prepare -------------------------------------------------------------

    @property
    def sides(self) -> tuple[str | None, ...]:
        """The modules' sides: ``(None,)`` for one module, the two feet's otherwise."""
        return (None,) if self.feet_settings is None else tuple(FOOT_SIDES)

    def prepare(self) -> None:
        """Open the receiver read live, wait for its first fix (with the aids) and make the tracker."""
        heading = math.radians(self.options.heading_deg)
        last_counter = None if self.options.attach else 0
        if self.aid_options.gps_receiver is not None:
            self.receiver = self._stack.enter_context(open_receiver(self.aid_options.gps_receiver,
                                                                    self.messages))
        if self.feet_settings is not None:
            self._prepare_feet(heading, last_counter)
        elif not self.aid_options.uses_aids:
            self.tracker = StepTracker(heading=heading, last_counter=last_counter)
        else:
            first, aid_options = self._first_fix()
            self.aids = prepare_aids(aid_options, last_counter=last_counter, heading=heading, first_fix=first)
            self.tracker = self.aids.tracker

    def _prepare_feet(self, heading: float, last_counter: int | None) -> None:
        first, aid_options = self._first_fix()
        drift = {side: _loaded(cal) for side, cal in (self.drift or {}).items()}
        self.tracker, self.aids = feet_tracker(aid_options, self.feet_settings, drift=drift,
                                               last_counter=last_counter, defer=False, heading=heading,
                                               first_fix=first)

    def _first_fix(self) -> tuple[GpsFix | None, AidOptions]:
        """The live receiver's first fix, waited for, and the aid options with its day (nothing
        without a receiver)."""
        receiver, options = self.receiver, self.aid_options
        if receiver is None:
            return None, options
        self.messages.say(f"waiting up to {self.first_fix_wait_s:g} s for the first fix of the GPS receiver "
                          f"{receiver.url}")
        first = receiver.wait_first_fix(self.first_fix_wait_s)
        if first is None and receiver.lost is None:
            self.messages.say("no GPS fix yet: the declination is taken without it (--declination, or the "
                              "World Magnetic Model at --origin); the fixes still to come are fused")
        when = None if first is None else first.date or receiver.fixes.reader.date
        return first, replace(options, date=options.date or when)

    def tracker_for(self, side: str | None = None) -> StepTracker:
        """The tracker to open the module on *side*'s device with (None: the only module)."""
        if self.tracker is None:
            raise RuntimeError("prepare the run first")
        if isinstance(self.tracker, TwoFeetTracker):
            return self.tracker.foot(side)
        return self.tracker

    def __enter__(self) -> TrackingRun:
        try:
            self.prepare()
        except BaseException:
            self.close()
            raise
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Close the receiver read live (close the devices first). Idempotent."""
        self._stack.close()

    # -- stage 2: start ---------------------------------------------------------------

    def start(self, devices: Device | Mapping[str | None, Device]) -> list[TrackedModule]:
        """Start tracking on *devices* (the only module's device, or side → device, each opened
        with :meth:`tracker_for` its side): the receiver's fixes wired to their steps, the in-situ
        calibration or each module's saved one, then 0x34 (unless attaching) and the set-up."""
        if not isinstance(devices, Mapping):
            devices = {None: devices}
        if set(devices) != set(self.sides):
            raise ValueError(f"a device for each of {self.sides}, not {tuple(devices)}")
        devices = {side: devices[side] for side in self.sides}  # the left foot's first
        if self.receiver is not None:
            self._feed_receiver(devices)
        if self.aid_options.calibrate_mag:
            self.in_situ = InSituCalibration(devices[None], self.aid_options.mag_cal_dir, self.messages,
                                             self.aids)
        elif self.aids is not None and self.aid_options.wants_saved_calibration:
            self._use_saved_calibrations(devices)
        wiggle = None if self.in_situ is None else self.in_situ.wiggle
        self.modules = [TrackedModule(side, dev, DeviceSetup(dev, HostSetup(
            fusion=self.options.fusion, height_compensation=self.options.height_compensation, wiggle=wiggle),
            self.in_situ, messages=self.messages, label=module_label(side, dev)))
            for side, dev in devices.items()]
        for m in self.modules:
            if m.side is not None:
                m.dev.on_link(lambda ev, m=m: self._report_link(m, ev))
            if not self.options.attach:
                m.dev.start_stepwise_dead_reckoning()
            m.setup.after_start()
        self._note_plain_packets()
        names = " and ".join(m.label for m in self.modules)
        numbering = "/".join(dict.fromkeys(m.dev.session.command_set.name for m in self.modules))
        # said when the walk is followed, where Ctrl-C is caught (a Ctrl-C just after the line ends it)
        self._tracking_line = f"tracking on {names} ({numbering} commands); Ctrl-C to stop"
        return self.modules

    def _note_plain_packets(self) -> None:
        """Tell the ``aids:`` line why the steps may carry no module time: the fusion set-up not
        sent, or not taken by a module."""
        if self.aids is None:
            return
        if not self.options.fusion:
            self.aids.plain_packets = "the fusion set-up, whose packets do, was not sent: --no-fusion"
            return
        for m in self.modules:
            if m.setup.plain_packets is not None:
                self.aids.plain_packets = m.setup.plain_packets
                return

    def _feed_receiver(self, devices: Mapping[str | None, Device]) -> None:
        """Queue the receiver's fixes on the tracker (the module's, or the two feet's) between two
        steps: under the session lock of every module whose steps it sums, taken in the modules'
        order; each module's step renews that module's clock (:mod:`hostlib.run.gps_stream`)."""
        fixes = self.receiver.fixes
        fixes.attach(self.tracker, *(dev.session_lock for dev in devices.values()))
        for side, dev in devices.items():
            dev.on_step(lambda _ev, side=side: fixes.stepped(module=side))

    def _use_saved_calibrations(self, devices: Mapping[str | None, Device]) -> None:
        """Before tracking starts: ask each module its serial number (MCU_ID) and give its compass
        the module's saved magnetometer calibration, if there is one."""
        for dev in devices.values():
            dev.request_mcu_id()
        for dev in devices.values():
            await_serial(dev, serial_wait_s(dev))
        use_saved_calibrations(self.aid_options, self.aids,
                               {side: dev.session.mcu_serial for side, dev in devices.items()})

    def _report_link(self, m: TrackedModule, ev: LinkEvent) -> None:
        """A foot's link went down or came back (the device reconnects by itself): say so; a foot
        whose link went down holds back the end of the walk no longer, until its next step packet."""
        if not ev.up:
            m.steps_at_link_loss = m.dev.session.stats.steps
        what = "link back" if ev.up else f"link lost ({ev.error}); the other foot goes on"
        self.messages.note(f"{m.label}: {what}")

    # -- stage 3: follow --------------------------------------------------------------

    def follow(self, line: LiveLine | None = None) -> None:
        """Read the modules' steps until the duration is over, the number of step packets came or
        Ctrl-C, keeping *line* up to date with :meth:`status` (module docstring); then the outputs go
        off unless left running, the in-situ calibration is closed, and the receiver's fix counts and
        the walk's origin (its first fix) go to :attr:`aids`."""
        try:
            self._follow(line)
        finally:
            for m in self.modules:
                m.setup.close(self.options.leave_running)
        if self.aids is not None and self.receiver is not None:
            self.aids.gps_stats = self.receiver.fixes.stats
            self.aids.origin = self.receiver.fixes.origin or self.aids.origin

    def _follow(self, line: LiveLine | None) -> None:
        show = (lambda _text, _key: None) if line is None else line.show
        duration = self.options.duration_s
        deadline = None if duration is None else time.monotonic() + duration
        try:
            if self._tracking_line is not None:
                self.messages.say(self._tracking_line)
                self._tracking_line = None
            self._check_calibrations()
            show(*self.status())
            while deadline is None or time.monotonic() < deadline:
                going = [m for m in self.modules if m.failure is None]
                for m in going:
                    try:
                        m.dev.recv_step(timeout=remaining(deadline, 0.5 / len(going)))
                        m.setup.poll()
                    except HostError as exc:
                        m.failure = exc
                        if all(other.failure is not None for other in self.modules):
                            raise
                        self.messages.note(f"{m.label}: {exc}; tracking goes on without it")
                show(*self.status())
                if self._enough_steps():
                    break
        except KeyboardInterrupt:
            pass
        finally:
            if not self.options.leave_running:
                self._outputs_off()
        # the last line counts every step, also those that came while the outputs went off
        show(*self.status())
        if line is not None:
            line.close()

    def _outputs_off(self) -> None:
        for m in self.modules:
            try:
                m.dev.output_all_off()
            except HostError as exc:
                self.messages.say(f"warning: could not switch the outputs of {m.label} off: {exc}")

    def _check_calibrations(self) -> None:
        """Refuse another module's drift or magnetometer calibration before the walk starts, once
        the modules named themselves (or did not in time: unknown, accepted)."""
        if isinstance(self.tracker, TwoFeetTracker):
            feet = self.tracker
            if not (feet.drift or any(feet.foot(side).settings.mag_calibration is not None
                                      for side in FOOT_SIDES)):
                return
            for m in self.modules:
                await_serial(m.dev, serial_wait_s(m.dev))
            check_feet_modules(feet, {m.side: m.dev.session.mcu_serial for m in self.modules},
                               {m.side: m.dev.name for m in self.modules})
            return
        drift = self.module_drift
        cal = None if self.aids is None else self.aids.tracker.settings.mag_calibration
        if drift is None and cal is None:
            return
        (m,) = self.modules
        await_serial(m.dev, serial_wait_s(m.dev))
        check_module(m.dev.session.mcu_serial, drift, cal)

    @property
    def module_drift(self) -> DriftCalibration | None:
        """The one module's drift calibration (None: none, or two feet)."""
        if self.feet_settings is not None or self.drift is None:
            return None
        if not isinstance(self.drift, DriftCalibration):
            self.drift = _loaded(self.drift)
        return self.drift

    def _enough_steps(self) -> bool:
        """Whether every module still going has had the step packets asked for and has nothing of
        its set-up left to send (never without a number of steps). A foot whose link was lost and
        that sent no step packet since is not waited for, while another foot walks: the other foot
        goes on and ends the walk at its count."""
        steps = self.options.steps
        if steps is None:
            return False
        walking = [m for m in self.modules if m.failure is None and not m.quiet_since_link_loss]
        return bool(walking) and all(m.dev.session.stats.steps >= steps and m.setup.sent for m in walking)

    def status(self) -> tuple[str, object]:
        """The status line (:func:`~hostlib.run.status.summary_line`, with two feet
        :func:`~hostlib.run.status.feet_summary_line`; with the aids, what they did so far) and what
        makes it news: a step, a link going up or down, a walk failing."""
        aids = aids_status(self.aids, self.receiver)
        if not isinstance(self.tracker, TwoFeetTracker):
            dev = self.modules[0].dev
            return summary_line(dev, self.module_drift) + aids, len(dev.tracker)
        failed = [m.side for m in self.modules if m.failure is not None]
        devices = {m.side: m.dev for m in self.modules}
        return (feet_summary_line(self.tracker, devices, failed) + aids,
                (len(self.tracker), tuple(dev.link_up for dev in devices.values()), tuple(failed)))


def remaining(deadline: float | None, cap: float = 0.5) -> float:
    """How long to wait for the next packet or step: *cap* seconds, or what is left before
    *deadline* (a :func:`time.monotonic` time; None: none), if less."""
    return cap if deadline is None else max(0.0, min(cap, deadline - time.monotonic()))
