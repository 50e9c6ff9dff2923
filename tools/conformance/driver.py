"""A small device driver for the conformance checks: a pyserial port, frames in, deadlines.

It knows the protocol only through :mod:`protocol` (frames, command tables,
stream decoder) and talks to anything pyserial opens: a device path, a pty,
``socket://HOST:PORT``, ``rfc2217://``, or our ``openshoe://`` URL. It keeps
every byte it sent and received, so a check can prove its verdict with hex.

Time: the device's own clock is the measure (INTERRUPT_COUNTER, one count per
1 kHz timer tick, read with a pulled output); wall-clock deadlines only bound
how long the driver waits for bytes, so a real module, a real-time emulator and
a fast emulator all give the same verdicts.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from protocol.commands import CommandSet
from protocol.frames import CommandAck, StatePacket, build_command, build_packet_ack, hexdump
from protocol.ids import Command, OutputMode, StateId
from protocol.stream import StreamDecoder

Frame = CommandAck | StatePacket

#: Mode byte of a lossy pulled output (pull, lossless bit clear → lossy).
PULL = int(OutputMode.PULL)
#: Mode byte of a lossless pulled output.
PULL_LOSSLESS = int(OutputMode.PULL | OutputMode.LOSSLESS)


class CheckFailed(AssertionError):
    """A check found the device not doing what protocol.md says."""


class CheckSkipped(Exception):
    """A check does not apply (e.g. the command set lacks the commands it needs)."""


class ExtensionAbsent(Exception):
    """The device lacks an emulator extension the check looks for (a real module lacks them all:
    not a failure of the protocol)."""


@dataclass(frozen=True)
class Received:
    """One frame the device sent, its bytes on the wire, and when the driver saw it."""

    frame: Frame
    raw: bytes
    at: float

    @property
    def is_ack(self) -> bool:
        return isinstance(self.frame, CommandAck)

    @property
    def is_packet(self) -> bool:
        return isinstance(self.frame, StatePacket)

    def __repr__(self) -> str:
        return f"Received({hexdump(self.raw, 24)})"


def device_clock(port: Any) -> Callable[[], float]:
    """The clock deadlines are measured in: an in-process emulator running in virtual time
    (``openshoe://`` with speed 0, or a ``VirtualPipe``; both expose ``.module``) gives its
    module's virtual seconds, anything else the wall clock."""
    module = getattr(port, "module", None)
    speed = getattr(getattr(port, "settings", None), "speed", 0)
    if module is not None and speed == 0:
        clock = module.clock
        return lambda: clock.now_cycles / clock.cpu_hz
    return time.monotonic


class DeviceDriver:
    """Talk to one interface of one module through a pyserial-like port.

    *port* needs ``read(n)``, ``write(data)``, ``in_waiting`` and a settable
    ``timeout``. *clock* returns seconds (wall clock by default); *poll_s* is
    the read timeout of one poll.
    """

    def __init__(self, port: Any, command_set: CommandSet, *, poll_s: float = 0.005,
                 clock: Callable[[], float] = time.monotonic, time_scale: float = 1.0):
        self.port = port
        self.cs = command_set
        self.poll_s = poll_s
        self.clock = clock
        #: multiplies every wall-clock wait (use > 1 for slow links or loaded machines)
        self.time_scale = time_scale
        self.decoder = StreamDecoder()
        #: every frame received, in order
        self.frames: list[Received] = []
        #: index into :attr:`frames` of the first frame not yet consumed by expect()
        self.cursor = 0
        self.sent_log = bytearray()
        self.received_log = bytearray()
        try:
            self.port.timeout = poll_s
        except Exception:  # noqa: BLE001 - some ports have fixed timeouts
            pass

    # ------------------------------------------------------------------ raw I/O
    def write(self, data: bytes) -> bytes:
        """Send raw bytes; returns them (for proofs)."""
        data = bytes(data)
        self.port.write(data)
        flush = getattr(self.port, "flush", None)
        if flush is not None:
            flush()
        self.sent_log += data
        return data

    def send(self, meaning: Command, **fields: Any) -> bytes:
        """Build a command of this numbering and send it; returns its bytes."""
        if not self.cs.supports(meaning):
            raise CheckSkipped(f"the {self.cs.name} numbering has no {meaning.name}")
        return self.write(build_command(meaning, command_set=self.cs, **fields))

    def wire_id(self, meaning: Command) -> int:
        return self.cs.spec(meaning).wire_id

    def supports(self, *meanings: Command) -> bool:
        return all(self.cs.supports(m) for m in meanings)

    def require(self, *meanings: Command) -> None:
        """Skip the calling check unless the numbering has all these commands."""
        for m in meanings:
            if not self.cs.supports(m):
                raise CheckSkipped(f"the {self.cs.name} numbering has no {m.name}")

    def pump(self) -> int:
        """Read once (at most one poll timeout); decode; returns bytes read."""
        n = getattr(self.port, "in_waiting", 0) or 1
        data = self.port.read(n)
        if not data:
            return 0
        self.received_log += data
        now = self.clock()
        for frame in self.decoder.feed(data):
            self.frames.append(Received(frame, frame.to_bytes(), now))
        return len(data)

    def read_raw(self, n: int, timeout: float) -> bytes:
        """Exactly the next *n* received bytes (fewer if the deadline passes), not decoded by expect().

        Frames in them are still decoded and appended to :attr:`frames`.
        """
        start = len(self.received_log)
        deadline = self.clock() + timeout * self.time_scale
        while len(self.received_log) - start < n and self.clock() < deadline:
            self.pump()
        return bytes(self.received_log[start:start + n])

    # ------------------------------------------------------------------ frames
    def mark(self) -> int:
        """Consume everything received so far; returns the index of the next frame."""
        self.cursor = len(self.frames)
        return self.cursor

    def since(self, index: int) -> list[Received]:
        return self.frames[index:]

    def expect(self, pred: Callable[[Received], bool], timeout: float = 1.0) -> Received | None:
        """The next unconsumed frame matching *pred* (consuming up to it), or None at the deadline."""
        deadline = self.clock() + timeout * self.time_scale
        while True:
            while self.cursor < len(self.frames):
                r = self.frames[self.cursor]
                self.cursor += 1
                if pred(r):
                    return r
            if self.clock() >= deadline:
                return None
            self.pump()

    def collect(self, timeout: float,
                until: Callable[[list[Received]], bool] | None = None) -> list[Received]:
        """Frames arriving from now on, until ``until(frames)`` holds or the deadline passes."""
        first = len(self.frames)
        deadline = self.clock() + timeout * self.time_scale
        while self.clock() < deadline:
            if until is not None and until(self.frames[first:]):
                break
            self.pump()
        self.cursor = len(self.frames)
        return self.frames[first:]

    def drain(self, quiet_s: float = 0.05, timeout: float = 2.0) -> bytes:
        """Read until nothing arrives for *quiet_s*; returns the bytes read."""
        start = len(self.received_log)
        deadline = self.clock() + timeout * self.time_scale
        last = self.clock()
        while self.clock() < deadline:
            if self.pump():
                last = self.clock()
            elif self.clock() - last >= quiet_s * self.time_scale:
                break
        self.mark()
        return bytes(self.received_log[start:])

    # ------------------------------------------------------------------ commands
    def ack_of(self, meaning: Command) -> Callable[[Received], bool]:
        wid = self.wire_id(meaning)
        return lambda r: r.is_ack and r.frame.command_id == wid

    def command(self, meaning: Command, timeout: float = 1.0, **fields: Any) -> tuple[bytes, Received]:
        """Send a command and wait for its ack; CheckFailed if none comes."""
        sent = self.send(meaning, **fields)
        ack = self.expect(self.ack_of(meaning), timeout)
        if ack is None:
            raise CheckFailed(
                f"no ack for {meaning.name} within {timeout * self.time_scale:.1f} s: sent {hexdump(sent)}, "
                f"received {hexdump(self.received_log[-64:]) or 'nothing'}"
            )
        return sent, ack

    def next_packet(self, timeout: float = 1.0) -> Received | None:
        return self.expect(lambda r: r.is_packet, timeout)

    def pull(self, state_id: int, timeout: float = 1.0) -> tuple[bytes, Received]:
        """Output one state once, lossy (OUTPUT_STATE mode 0x20); returns (sent, its packet).

        The packet that follows the command's ack is the pulled one: the ack is
        queued while the command runs, the packet at the same cycle's assembly.
        """
        sent, _ = self.command(Command.OUTPUT_STATE, timeout, state_id=state_id, mode=PULL)
        pkt = self.next_packet(timeout)
        if pkt is None:
            raise CheckFailed(f"pulled state 0x{state_id:02X} but no packet came: sent {hexdump(sent)}")
        return sent, pkt

    def ticks(self) -> int:
        """The device's INTERRUPT_COUNTER (1 kHz timer ticks since boot), read with a pull."""
        return self._ticks()[0]

    def _ticks(self) -> tuple[int, Received]:
        _, pkt = self.pull(StateId.INTERRUPT_COUNTER)
        payload = pkt.frame.payload
        if len(payload) != 4:
            raise CheckFailed(f"pulled INTERRUPT_COUNTER (4 bytes) but got payload {hexdump(payload)}")
        return int.from_bytes(payload, "big"), pkt

    def wait_ticks(self, n: int, timeout: float = 5.0) -> tuple[int, int, list[Received]]:
        """Let at least *n* device ticks pass, measured with pulls of INTERRUPT_COUNTER.

        Returns (first count, last count, packets that were not replies to those pulls).
        """
        first_index = self.cursor
        t0, reply = self._ticks()
        replies = {id(reply)}
        t = t0
        deadline = self.clock() + (timeout + n / 1000.0) * self.time_scale
        while (t - t0) % (1 << 32) < n:
            if self.clock() > deadline:
                raise CheckFailed(f"device clock advanced only {t - t0} of {n} ticks within {timeout} s")
            self.collect(min(0.02, n / 2000.0))
            t, reply = self._ticks()
            replies.add(id(reply))
        strays = [r for r in self.frames[first_index:] if r.is_packet and id(r) not in replies]
        return t0, t, strays

    def ack_packet(self, number: int) -> bytes:
        """Acknowledge lossless packet *number* (command 0x01, never acked back)."""
        return self.write(build_packet_ack(number))

    # ------------------------------------------------------------------ state
    def sync(self, attempts: int = 2) -> None:
        """Bring the interface to a known quiet state: outputs off, queue empty, processing off, lossy.

        A partial frame left in the device's parser can swallow the first
        command, so OUTPUT_ALL_OFF is retried (after the 3 s parser timeout).
        """
        for attempt in range(attempts):
            self.send(Command.OUTPUT_ALL_OFF)
            if self.expect(self.ack_of(Command.OUTPUT_ALL_OFF), 0.5 if attempt == 0 else 1.0) is not None:
                break
            self.collect(3.3)  # the parser drops a stale partial frame after ~3 s
        else:
            raise CheckFailed(
                f"device does not acknowledge OUTPUT_ALL_OFF: received {hexdump(self.received_log[-64:])}"
            )
        if self.cs.supports(Command.ALL_PROC_OFF):
            self.command(Command.ALL_PROC_OFF)
        self.pull(StateId.INTERRUPT_COUNTER)  # mode 0x20: lossless flag off
        self.drain()
