"""The package queue of one interface: lossy and lossless transmission (protocol.md §6).

A ring of 2048 bytes holding at most 512 frames (state packets and command
acks). Rules, as the module's package queue implements them:

* **Adding** a frame: it is stored whole if the queue is empty or the free
  bytes (2048 − bytes queued) are at least its length; otherwise it is dropped
  whole and counted in :attr:`PackageQueue.dropped` (a full queue is reported,
  never silent). Frames carry a *single-transmit* flag: command acks always,
  and data packets queued while the interface was lossy.
* **Lossy** (:meth:`PackageQueue.push_lossy`): push as many queued bytes as the link's
  transmit ring takes; fully sent frames are removed, a partly sent frame keeps
  its unsent rest at the head and is finished later.
* **Lossless** (:meth:`PackageQueue.send_lossless`, once per loop cycle): only the oldest
  frame is sent, whole (it waits while the transmit ring cannot take all of
  it). A resend delay counter runs 0..127: a frame goes out when it is 0 (or
  the frame is single-transmit), and every call otherwise advances it, so an
  unacknowledged packet is sent again every 128 loop cycles. A single-transmit
  frame (a command ack) is removed once sent, so it waits behind unacknowledged
  data but is never resent.
* **ACK** (:meth:`PackageQueue.ack`): removes the oldest frame only, and only if its number
  matches; any other number is ignored. Removing a frame resets the delay
  counter, so the next frame goes out at the next transmission — in the same
  loop cycle as the ACK, since commands are received before data is transmitted.
* :meth:`PackageQueue.clear` (OUTPUT_ALL_OFF) empties the queue.
"""

from __future__ import annotations

from collections import deque
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # pragma: no cover
    from .port import Port

#: Bytes in a package queue (ring buffer).
QUEUE_BYTES = 2048
#: Frames a package queue can index.
QUEUE_ENTRIES = 512
#: Loop cycles between resends of an unacknowledged lossless packet.
RESEND_CYCLES = 128


class QueuedFrame:
    """One frame in the queue: its bytes, number, flags and how much is already sent."""

    __slots__ = ("data", "number", "single", "offset", "is_ack", "sends")

    def __init__(self, data: bytes, number: int, single: bool, is_ack: bool):
        self.data = data
        self.number = number
        self.single = single
        self.is_ack = is_ack
        self.offset = 0  # bytes already pushed to the link (lossy partial sends)
        self.sends = 0

    @property
    def remaining(self) -> int:
        return len(self.data) - self.offset

    def __repr__(self) -> str:
        kind = "ack" if self.is_ack else f"packet {self.number}"
        return f"QueuedFrame({kind}, {self.remaining}/{len(self.data)} B, {self.data[:6].hex(' ').upper()}…)"


class PackageQueue:
    """The interface's frame queue (see the module doc for the rules)."""

    def __init__(self, capacity: int = QUEUE_BYTES, max_entries: int = QUEUE_ENTRIES,
                 resend_cycles: int = RESEND_CYCLES):
        self.capacity = capacity
        self.max_entries = max_entries
        self.resend_cycles = resend_cycles
        self.frames: deque[QueuedFrame] = deque()
        self.used = 0  # bytes held (unsent rests)
        self.delay_counter = 0
        # counters
        self.dropped = 0  #: frames dropped because the queue was full
        self.dropped_bytes = 0
        self.sent_frames = 0  #: frames completely handed to the link (resends included)
        self.resends = 0  #: lossless packets sent again because no ACK came
        self.acked = 0  #: frames removed by a matching ACK
        self.acks_ignored = 0  #: ACKs whose number was not the oldest frame's
        self.cleared = 0  #: frames discarded by clear()
        #: Called with (frame bytes, is_resend) whenever a whole frame starts going out.
        self.on_send = None

    def __len__(self) -> int:
        return len(self.frames)

    @property
    def free(self) -> int:
        return self.capacity - self.used

    def add(self, data: bytes, number: int, *, single: bool, is_ack: bool = False) -> bool:
        """Queue a frame; False (and counted) if it does not fit."""
        n = len(data)
        if not n:
            return False
        if self.frames and (self.used + n > self.capacity or len(self.frames) >= self.max_entries):
            self.dropped += 1
            self.dropped_bytes += n
            return False
        self.frames.append(QueuedFrame(data, number, single, is_ack))
        self.used += n
        return True

    def _remove_oldest(self) -> QueuedFrame:
        f = self.frames.popleft()
        self.used -= f.remaining
        self.delay_counter = 0
        return f

    def push_lossy(self, port: Port) -> int:
        """Push queued bytes into the link as far as it takes them; returns bytes written."""
        frames = self.frames
        if not frames:
            return 0
        free = port.tx_free()
        written = 0
        while frames and free > 0:
            f = frames[0]
            rest = f.remaining
            if f.offset == 0 and self.on_send is not None:
                self.on_send(f.data, False)
            if rest <= free:
                port.tx_write(f.data[f.offset:] if f.offset else f.data)
                free -= rest
                written += rest
                frames.popleft()
                self.used -= rest
                self.delay_counter = 0
                self.sent_frames += 1
            else:
                port.tx_write(f.data[f.offset:f.offset + free])
                f.offset += free
                self.used -= free
                written += free
                free = 0
        return written

    def send_lossless(self, port: Port) -> int:
        """One lossless transmission opportunity (call once per loop cycle); returns bytes written."""
        frames = self.frames
        if not frames:
            return 0
        f = frames[0]
        if self.delay_counter == 0 or f.single:
            rest = f.remaining
            if rest <= port.tx_free():
                if self.on_send is not None:
                    self.on_send(f.data, f.sends > 0)
                port.tx_write(f.data[f.offset:] if f.offset else f.data)
                if f.sends:
                    self.resends += 1
                f.sends += 1
                self.sent_frames += 1
                self.delay_counter = (self.delay_counter + 1) % self.resend_cycles
                if f.single:
                    self._remove_oldest()
                return rest
            return 0
        self.delay_counter = (self.delay_counter + 1) % self.resend_cycles
        return 0

    def ack(self, number: int) -> bool:
        """A packet ACK: remove the oldest frame if its number matches."""
        if self.frames and self.frames[0].number == number:
            self._remove_oldest()
            self.acked += 1
            return True
        self.acks_ignored += 1
        return False

    def clear(self) -> None:
        """Empty the queue (OUTPUT_ALL_OFF)."""
        self.cleared += len(self.frames)
        self.frames.clear()
        self.used = 0
        self.delay_counter = 0

    def __repr__(self) -> str:
        return (f"PackageQueue({len(self.frames)} frames, {self.used}/{self.capacity} B, "
                f"dropped {self.dropped}, resends {self.resends})")
