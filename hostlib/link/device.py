"""A connected OpenShoe module: typed commands with acks, a reader thread, steps and packets.

Why a thread and not asyncio: pyserial's reads block (and on a Bluetooth SPP port or a pty there
is no portable non-blocking API), so one daemon reader thread per device does the reading with a
short port timeout, runs the pure :class:`hostlib.link.session.HostSession` on every chunk, writes
the packet acks it produces immediately (a lossless module waits for them), and hands events to
bounded queues and callbacks. User calls (commands, iterators) run in the caller's thread and wait
on condition variables with deadlines — never sleeps. How it talks to the module (ack timeouts,
reconnecting, queue sizes …) is a :class:`DeviceOptions`.

Typical use::

    with Device("/dev/rfcomm0") as dev:          # or "socket://localhost:5000", a port object …
        dev.start_stepwise_dead_reckoning()
        for ev in dev.steps(timeout=30):
            print(ev.index, ev.pose[:3])
        print(dev.track)
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any, BinaryIO

import serial

from protocol.ids import Command

from ..errors import AckTimeout, DeviceClosed, LinkLost
from ..events import CommandAckEvent, Event, GapEvent, LinkEvent, PacketEvent, StepEvent, StreamEvent
from ..track.steps import StepTracker, Track
from .commands import CommandMethods
from .connection import PortFactory, port_name
from .connection import port_factory as _port_factory
from .device_options import DeviceOptions, device_options
from .event_queue import CLOSED, BoundedQueue
from .outputs import OutputPlan
from .session import HostSession

__all__ = ["Device"]

log = logging.getLogger(__name__)

_READ_ERRORS = (serial.SerialException, OSError, TypeError, AttributeError, ValueError)


def _as_bytes(data: Any, method: str) -> bytes:
    """*data* as bytes (bytes, a bytearray or a memoryview); TypeError for text or anything else."""
    if isinstance(data, str) or not isinstance(data, (bytes, bytearray, memoryview)):
        raise TypeError(f"{method} takes bytes, got {type(data).__name__}")
    return bytes(data)


#: The clock of ack deadlines (a module attribute so tests can drive it).
_now = time.monotonic

class Device(CommandMethods):
    """One OpenShoe module over one serial link (USB CDC or Bluetooth SPP, real or emulated).

    *target*: a device path or pyserial URL (``/dev/rfcomm0``, ``socket://host:port``,
    ``loop://``, the emulator's ``openshoe://``), or an already-open pyserial port.
    *options*: how it talks to the module (:class:`DeviceOptions`: command numbering, ack
    timeout and retries, reconnecting, queue sizes, baud rate …); any of their fields may also
    be given as a keyword (``Device(url, ack_timeout=2.0)``), which wins over *options*.
    *tracker*: where steps are summed (default: origin, counting from 0x34).
    *raw_log*: a binary file that receives every byte read.
    *port_factory*: overrides how the link is opened (tests, custom links).
    *start*: False leaves the reader thread off (bytes are then processed only
    by calling :meth:`feed`, e.g. to replay a capture).

    Callbacks: one method per kind of event — :meth:`on_packet`, :meth:`on_step`, :meth:`on_gap`,
    :meth:`on_ack`, :meth:`on_link` — each taking *fn(event)* (and returning it, so it also
    decorates); :meth:`remove_callback` undoes them. One method per kind, not one keyed by a string:
    each signature names the event the callback gets, and a misspelt kind fails where it is written
    (AttributeError) instead of never firing. Callbacks run in the reader thread, after the acks of
    the bytes that produced their event were sent; keep them short, since the reader reads (and
    acks) nothing more until they return. Their exceptions are logged and counted (``callback_errors``).

    Reading: every kind of event that is queued has one pair of names. ``recv_<kind>(timeout)``
    returns the next one, or None when *timeout* s pass (:meth:`recv_packet`, :meth:`recv_step`);
    ``<kind>s(timeout)`` iterates over them until *timeout* s have passed in total (:meth:`packets`,
    :meth:`steps`). Both take from the same bounded queue, so an event is read once, by either.
    After :meth:`close` the queued events are still handed out; then ``recv_*`` raises
    :class:`DeviceClosed` and the iterators end.
    """

    def __init__(self, target: Any = None, options: DeviceOptions | None = None, *,
                 tracker: StepTracker | None = None, raw_log: BinaryIO | None = None,
                 port_factory: PortFactory | None = None, start: bool = True, **settings: Any):
        options = device_options(options, settings)
        if raw_log is not None and not callable(getattr(raw_log, "write", None)):
            raise TypeError(f"raw_log must be a binary file open for writing, got {raw_log!r}")
        if tracker is not None and not callable(getattr(tracker, "add", None)):
            raise TypeError(f"tracker must be a StepTracker (or of its kind), got {type(tracker).__name__}")
        if port_factory is None:
            if target is None:
                raise ValueError("Device needs a port path/URL, a port object, or a port_factory")
            port_factory = _port_factory(target, baudrate=options.baudrate,
                                         read_timeout=options.read_timeout)
        self._factory = port_factory
        #: how it talks to the module (:class:`DeviceOptions`, with the keywords given)
        self.options = options
        self.session = HostSession(options.command_set, ack_policy=options.ack_policy, tracker=tracker,
                                   plan=OutputPlan())
        self.ack_timeout = float(options.ack_timeout)
        self.retries = int(options.retries)
        self.reconnect = options.reconnect
        self.reconnect_interval = float(options.reconnect_interval)
        self.raw_log = raw_log

        self._lock = threading.RLock()  # session state
        self._write_lock = threading.Lock()
        serialize_io = options.serialize_io
        if serialize_io is None:
            serialize_io = isinstance(target, str) and target.lower().startswith("openshoe://")
        self.serialize_io = bool(serialize_io)
        self._outbox = bytearray()  # serialize_io: bytes the reader writes before its next read
        self._cond = threading.Condition(self._lock)  # acks, link state
        self._ack_counts: dict[int, int] = {}
        self._packet_seq = 0
        self._stop = threading.Event()
        self._closed = False
        self._link_up = False
        self.link_drops = 0
        self.reconnects = 0
        self.callback_errors = 0
        self.reader_errors = 0
        self._packets = BoundedQueue("packets", options.queue_size)
        self._steps = BoundedQueue("steps", options.queue_size)
        self._callbacks: dict[type, list[Callable[[Any], object]]] = {
            kind: [] for kind in (PacketEvent, StepEvent, GapEvent, CommandAckEvent, LinkEvent)
        }
        self.gap_events: list[GapEvent] = []
        self._port = self._factory()
        self._link_up = True
        self.name = port_name(self._port)
        self._thread = threading.Thread(
            target=self._reader, name=f"openshoe-reader[{self.name}]", daemon=True
        )
        if start:
            self._thread.start()

    # -- lifecycle ------------------------------------------------------------------

    def __enter__(self) -> Device:
        if self._closed:
            raise DeviceClosed(f"{self.name} is closed: open a new Device")
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Stop the reader, close the port, wake every waiter with :class:`DeviceClosed`. Idempotent."""
        with self._cond:
            if self._closed:
                return
            self._closed = True
            self._stop.set()
            self._cond.notify_all()
        if self._thread.is_alive() and threading.current_thread() is not self._thread:
            self._thread.join(timeout=5.0)
        try:
            self._port.close()
        except _READ_ERRORS:  # pragma: no cover - closing a broken port
            pass
        self._packets.close()
        self._steps.close()

    @property
    def closed(self) -> bool:
        return self._closed

    @property
    def link_up(self) -> bool:
        """True while the serial link is open (False between a drop and the reconnect)."""
        return self._link_up

    def __repr__(self) -> str:
        state = "closed" if self._closed else ("up" if self._link_up else "down")
        return f"Device({self.name!r}, {self.session.command_set.name}, link {state}, {self.session!r})"

    # -- commands ------------------------------------------------------------------

    def command(self, meaning: Command, *, timeout: float | None = None, retries: int | None = None,
                **fields: Any) -> CommandAckEvent:
        """Send a command in the device's numbering and wait for its ack ``A0 cmd ck ck``; returns the ack.

        Each attempt waits *timeout* s (default :attr:`DeviceOptions.ack_timeout`); while a
        lossless module keeps delivering data (the ack waits behind it) the wait
        is extended, up to 10 × *timeout*. After *retries* extra attempts
        :class:`AckTimeout`. ACK (0x01) gets no ack: send it with :meth:`ack_packet`.
        """
        if meaning is Command.ACK:
            raise ValueError("the module does not acknowledge ACK (0x01): send it with ack_packet()")
        if self._closed:
            raise DeviceClosed(f"{self.name} is closed")
        timeout = self.ack_timeout if timeout is None else float(timeout)
        retries = self.retries if retries is None else int(retries)
        if not (math.isfinite(timeout) and timeout > 0) or retries < 0:
            raise ValueError(f"a command waits a timeout > 0 s and retries >= 0 times, not {timeout:g} s and "
                             f"{retries}")
        frame, wire_id = self._encode(meaning, fields)
        for _attempt in range(retries + 1):
            with self._cond:
                seen = self._ack_counts.get(wire_id, 0)
            self._write(frame)
            if self._wait_ack(wire_id, seen, timeout):
                return CommandAckEvent(wire_id)
        raise AckTimeout(meaning.name, wire_id, retries + 1, timeout)

    def _send_command(self, meaning: Command, **fields: Any) -> None:
        """Send a command frame once without waiting: for ACK (0x01), which the module never acknowledges."""
        if self._closed:
            raise DeviceClosed(f"{self.name} is closed")
        self._write(self._encode(meaning, fields)[0])

    def _encode(self, meaning: Command, fields: dict[str, Any]) -> tuple[bytes, int]:
        with self._lock:
            return self.session.encode_command(meaning, **fields), self.session.wire_id(meaning)

    def _wait_ack(self, wire_id: int, seen: int, timeout: float) -> bool:
        now = _now()
        deadline, hard = now + timeout, now + 10 * timeout
        with self._cond:
            progress = self._packet_seq
            while self._ack_counts.get(wire_id, 0) == seen:
                if self._closed:
                    raise DeviceClosed(f"{self.name} closed while waiting for the ack of 0x{wire_id:02X}")
                now = _now()
                if self._packet_seq != progress and self.session.lossless:
                    progress = self._packet_seq  # data keeps flowing: the ack is queued behind it
                    deadline = min(hard, now + timeout)
                if now >= deadline:
                    return False
                self._cond.wait(deadline - now)
            return True

    def fusion_setup(self, *, timeout: float | None = None,
                     retries: int | None = None) -> list[CommandAckEvent]:
        """Send :data:`protocol.extensions.FUSION_SETUP`, each command once the one before was
        acked; returns their acks. Every step packet then carries the step's swing time
        (``StepEvent.swing_time``, ``track.swing_times``) and the module outputs its serial number
        once (``session.mcu_serial``). Send it right after 0x34 (:meth:`start_stepwise_dead_reckoning`)."""
        from protocol.extensions import FUSION_SETUP

        return [self.command(meaning, timeout=timeout, retries=retries, **fields)
                for meaning, fields in FUSION_SETUP]

    def send_raw(self, data: bytes) -> None:
        """Write bytes as they are (no framing, no ack wait): for tests and old host apps."""
        self._write(_as_bytes(data, "send_raw"))

    def _write(self, data: bytes) -> None:
        if self._closed:
            raise DeviceClosed(f"{self.name} is closed")
        if self.serialize_io and threading.current_thread() is not self._thread:
            with self._write_lock:
                self._outbox += data
            return
        self._port_write(data)

    def _flush_outbox(self) -> None:
        with self._write_lock:
            data = bytes(self._outbox)
            self._outbox.clear()
        if data:
            self._port_write(data)

    def _port_write(self, data: bytes) -> None:
        with self._write_lock:
            try:
                self._port.write(data)
                flush = getattr(self._port, "flush", None)
                if flush is not None:
                    flush()
            except _READ_ERRORS as exc:
                if not self.reconnect:
                    raise LinkLost(f"writing to {self.name} failed: {exc}") from exc
                log.warning("write to %s failed (%s); the reader will reconnect", self.name, exc)

    # -- receiving -----------------------------------------------------------------

    def _reader(self) -> None:
        while not self._stop.is_set():
            port = self._port
            try:
                if self.serialize_io:
                    self._flush_outbox()
                waiting = getattr(port, "in_waiting", 0) or 0
                data = port.read(max(1, min(int(waiting), 4096)))
            except _READ_ERRORS as exc:
                if self._stop.is_set():
                    break
                if not self._link_dropped(exc):
                    break
                continue
            try:
                if data:
                    self.feed(data)
                elif self.session.decoder.pending:
                    self._deliver(*self._locked(self.session.idle))
            except Exception:  # noqa: BLE001 - keep reading (and acking) whatever one chunk did
                self.reader_errors += 1
                log.exception("processing %d bytes from %s failed", len(data), self.name)
        log.debug("reader of %s stopped", self.name)

    def feed(self, data: bytes) -> list[StreamEvent]:
        """Process received bytes as the reader thread does (public for tests and replays)."""
        data = _as_bytes(data, "feed")
        if self.raw_log is not None:
            self.raw_log.write(data)
        return self._deliver(*self._locked(self.session.feed, data))

    def _locked(self, fn: Callable[..., Any], *args: Any) -> Any:
        with self._cond:
            return fn(*args)

    def _deliver(self, events: list[StreamEvent], to_send: bytes) -> list[StreamEvent]:
        """Send the session's packet acks, then hand its events to waiters, queues and callbacks."""
        if to_send:
            try:
                self._write(to_send)
            except (DeviceClosed, LinkLost):
                pass
        with self._cond:
            for ev in events:
                if isinstance(ev, CommandAckEvent):
                    self._ack_counts[ev.command_id] = self._ack_counts.get(ev.command_id, 0) + 1
                elif isinstance(ev, PacketEvent):
                    self._packet_seq += 1
            self._cond.notify_all()
        for ev in events:
            if isinstance(ev, PacketEvent):
                if self.options.queue_packets:
                    self._packets.put(ev)
            elif isinstance(ev, StepEvent):
                self._steps.put(ev)
            elif isinstance(ev, GapEvent):
                self.gap_events.append(ev)
                log.warning("%s: %s", self.name, ev)
            self._dispatch(ev)
        return events

    def _link_dropped(self, exc: BaseException) -> bool:
        """Handle a dropped link; True if the reader should go on (reconnected)."""
        with self._cond:
            self._link_up = False
            self.link_drops += 1
            self._cond.notify_all()
        log.warning("link to %s dropped: %s", self.name, exc)
        self._dispatch(LinkEvent(False, exc))
        try:
            self._port.close()
        except _READ_ERRORS:
            pass
        if not self.reconnect:
            self._close_on_drop()
            return False
        while not self._stop.is_set():
            try:
                port = self._factory()
            except _READ_ERRORS as err:
                log.debug("reconnect to %s failed: %s", self.name, err)
                if self._stop.wait(self.reconnect_interval):
                    return False
                continue
            with self._cond:
                self._port = port
                self.session.link_reset()
                self._link_up = True
                self.reconnects += 1
                self._cond.notify_all()
            log.info("link to %s is back", self.name)
            self._dispatch(LinkEvent(True))
            return True
        return False

    def _close_on_drop(self) -> None:
        """The link dropped and reconnecting is off: the device is closed for good."""
        with self._cond:
            self._closed = True
            self._stop.set()
            self._cond.notify_all()
        self._packets.close()
        self._steps.close()

    def wait_link(self, up: bool = True, timeout: float | None = None) -> bool:
        """Wait until the link is up (or down); False on timeout. A closed device's link is down."""
        deadline = None if timeout is None else time.monotonic() + timeout
        with self._cond:
            if self._closed:
                return not up
            while self._link_up != up:
                if self._closed:
                    return False
                remaining = None if deadline is None else deadline - time.monotonic()
                if remaining is not None and remaining <= 0:
                    return False
                self._cond.wait(remaining)
            return True

    # -- callbacks -----------------------------------------------------------------

    def on_packet(self, fn: Callable[[PacketEvent], object]) -> Callable[[PacketEvent], object]:
        """Call *fn(event)* for each new state packet (:class:`PacketEvent`); returns *fn*."""
        return self._subscribe(PacketEvent, fn)

    def on_step(self, fn: Callable[[StepEvent], object]) -> Callable[[StepEvent], object]:
        """Call *fn(event)* for each new step, once it is summed (:class:`StepEvent`); returns *fn*."""
        return self._subscribe(StepEvent, fn)

    def on_gap(self, fn: Callable[[GapEvent], object]) -> Callable[[GapEvent], object]:
        """Call *fn(event)* when step counters were skipped (:class:`GapEvent`); returns *fn*."""
        return self._subscribe(GapEvent, fn)

    def on_ack(self, fn: Callable[[CommandAckEvent], object]) -> Callable[[CommandAckEvent], object]:
        """Call *fn(event)* for each command ack from the module (:class:`CommandAckEvent`); returns *fn*."""
        return self._subscribe(CommandAckEvent, fn)

    def on_link(self, fn: Callable[[LinkEvent], object]) -> Callable[[LinkEvent], object]:
        """Call *fn(event)* when the link drops or comes back (:class:`LinkEvent`); returns *fn*."""
        return self._subscribe(LinkEvent, fn)

    def remove_callback(self, fn: Callable[..., object]) -> None:
        """Stop calling *fn*, for every kind it was registered for; ValueError if it was not."""
        found = False
        for fns in self._callbacks.values():
            while fn in fns:
                fns.remove(fn)
                found = True
        if not found:
            raise ValueError(f"{fn!r} is not a callback of {self.name}")

    def _subscribe(self, kind: type, fn: Callable[[Any], object]) -> Callable[[Any], object]:
        if not callable(fn):
            raise TypeError(f"a {kind.__name__} callback must be callable, got {fn!r}")
        self._callbacks[kind].append(fn)
        return fn

    def _dispatch(self, ev: Event) -> None:
        fns = self._callbacks.get(type(ev))
        if fns is None:
            raise TypeError(f"no callbacks are kept for {type(ev).__name__}")
        for fn in list(fns):
            try:
                fn(ev)
            except Exception:  # noqa: BLE001 - a user callback must not kill the reader
                self.callback_errors += 1
                log.exception("%s callback %r failed", type(ev).__name__, fn)

    # -- reading packets and steps ---------------------------------------------------

    def recv_packet(self, timeout: float | None = None) -> PacketEvent | None:
        """The next new state packet, or None after *timeout* s (None = wait forever).

        Raises :class:`DeviceClosed` once the device is closed and every packet was read.
        """
        return self._get(self._packets, timeout)

    def recv_step(self, timeout: float | None = None) -> StepEvent | None:
        """The next new step (summed into :attr:`track`), or None after *timeout* s (None = forever).

        Raises :class:`DeviceClosed` once the device is closed and every step was read.
        """
        return self._get(self._steps, timeout)

    def _get(self, q: BoundedQueue, timeout: float | None) -> Any:
        if self._closed and q.q.empty():
            raise DeviceClosed(f"{self.name} is closed")
        item = q.get(None if timeout is None else time.monotonic() + timeout)
        if item is CLOSED:
            q.close()  # wake the next reader too
            raise DeviceClosed(f"{self.name} is closed")
        return item

    def packets(self, timeout: float | None = None) -> Iterator[PacketEvent]:
        """Iterate over new state packets until *timeout* s have passed in total, or the device closed.

        The same packets, from the same queue, as :meth:`recv_packet`.
        """
        yield from self._iterate(self._packets, timeout)

    def steps(self, timeout: float | None = None) -> Iterator[StepEvent]:
        """Iterate over new steps until *timeout* s have passed in total, or the device closed.

        The same steps, from the same queue, as :meth:`recv_step`.
        """
        yield from self._iterate(self._steps, timeout)

    def _iterate(self, q: BoundedQueue, timeout: float | None) -> Iterator[Any]:
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            item = q.get(deadline)
            if item is None or item is CLOSED:
                if item is CLOSED:
                    q.close()
                return
            yield item

    # -- state ---------------------------------------------------------------------

    @property
    def track(self) -> Track:
        """The live track summed from every step so far (the reader thread appends to it).

        For a consistent view while steps arrive use :meth:`track_snapshot`.
        """
        return self.session.tracker.track

    def track_snapshot(self) -> Track:
        """A copy of the track taken between two chunks of the stream."""
        with self._lock:
            return self.session.tracker.track.copy()

    @property
    def tracker(self) -> StepTracker:
        return self.session.tracker

    @property
    def session_lock(self) -> threading.RLock:
        """The lock the reader thread holds while it feeds the session, and so while it sums a step
        into :attr:`tracker`. Hold it to touch the tracker from another thread without racing a
        step: e.g. to queue a GPS fix as it arrives (:mod:`hostlib.run.gps_stream`)."""
        return self._lock

    @property
    def stats(self) -> dict[str, int]:
        """Every counter: session (bytes, garbage, bad frames, packets, acks, steps, gaps) and device."""
        d = self.session.stats.as_dict()
        d.update(
            dropped_packets=self._packets.dropped,
            dropped_steps=self._steps.dropped,
            link_drops=self.link_drops,
            reconnects=self.reconnects,
            callback_errors=self.callback_errors,
            reader_errors=self.reader_errors,
        )
        return d
