"""The module → host byte stream: split it into command acks and state packets.

A host reads the module's bytes in chunks of any size (USB bulk transfers,
Bluetooth RFCOMM segments, ``serial.read`` timeouts). A frame may be cut
anywhere, a link may lose or corrupt bytes, and a host may connect in the middle
of a packet. :class:`StreamDecoder` turns those chunks back into the frames the
module sent, in order, and never hands out a frame whose checksum is wrong.

Resynchronisation rule
----------------------
The decoder looks at the first buffered byte:

* not ``A0``/``AA`` → it is garbage: skipped and counted;
* ``A0`` (command ack) → a candidate of 4 bytes. It is a frame if its checksum
  matches **and** its command byte is a command the module acknowledges (by
  default any acked id of either numbering: < 0x50 and never 0x01). That
  check costs nothing on a real stream and rejects most random ``A0 xx``
  candidates; since an ack's command byte is never ``A0``/``AA``, a real ack
  is never cut short by a frame "starting" at its second byte;
* ``AA`` (state packet) → the length byte *L* is the payload length mod 256, so
  the candidates are payloads of *L* and *L* + 256 bytes (the latter only while
  ≤ *max_payload*, 506). The shorter one whose checksum matches is the frame.

If a candidate is not complete yet, the decoder **waits** for more bytes. If every
complete candidate fails, the header byte is counted as a bad frame and only
**that one byte** is skipped; scanning restarts at the next byte, so a valid
frame that began inside the bad one is still found.

Waiting has a cost: a stray ``AA`` with *L* ≤ 250 makes the decoder wait for up
to 262 bytes, and the frames behind it are held back until then. A host that
saw its link go quiet calls :meth:`StreamDecoder.flush`, which gives up on an
incomplete candidate **only if a valid frame follows it** in the buffer (a
partly received real frame at the end of the buffer is kept). Call it after a
pause in reception, not after every read: while it scans past an incomplete
candidate it could, with odds of about 2^-16 per header byte, accept a false
frame inside a real frame still arriving. :meth:`StreamDecoder.finish`
(end of a recording, port closed) gives up on everything incomplete. A host that
never asks for payloads over 255 bytes can pass ``max_payload=255`` and never
waits on the long candidate.

Memory is bounded: after :meth:`~StreamDecoder.feed` returns, the buffer holds
only an incomplete candidate, fewer than :data:`~protocol.frames.MAX_PACKET`
bytes. Every byte fed is accounted for: ``bytes_in == frame_bytes +
skipped_bytes + pending``.
"""

from __future__ import annotations

import re
from collections.abc import Iterable

import numpy as np

from .commands import CURRENT, LEGACY_2014, CommandSet
from .frames import ACK_FRAME_LEN, MAX_PAYLOAD, PACKET_OVERHEAD, CommandAck, StatePacket
from .ids import ACK_HEADER, PACKET_HEADER

__all__ = ["DEFAULT_ACK_IDS", "Frame", "StreamDecoder", "acked_ids", "decode_all", "frame_len"]

#: What the module sends to the host.
Frame = CommandAck | StatePacket

_HEADER = re.compile(bytes([ord("["), ACK_HEADER, PACKET_HEADER, ord("]")]))


def acked_ids(*command_sets: CommandSet) -> frozenset[int]:
    """Command ids the module acknowledges under the given numberings."""
    return frozenset(wid for cs in command_sets for wid, spec in cs.items() if spec.acked)


#: Default: acks of either numbering are accepted (a host may not know which firmware it talks to).
DEFAULT_ACK_IDS: frozenset[int] = acked_ids(CURRENT, LEGACY_2014)


def frame_len(frame: Frame) -> int:
    """Bytes the frame took on the wire."""
    if isinstance(frame, CommandAck):
        return ACK_FRAME_LEN
    return PACKET_OVERHEAD + len(frame.payload)


class _Wait(Exception):
    """Internal: the candidate is incomplete until *need* bytes are buffered.

    *failed*: a shorter candidate at the same place was complete and failed.
    """

    def __init__(self, need: int, failed: bool) -> None:
        super().__init__(need)
        self.need = need
        self.failed = failed


_FEED, _FLUSH, _EOF = 0, 1, 2


class StreamDecoder:
    """Incremental decoder of the module → host stream (acks and state packets).

    ``feed(chunk)`` returns the frames completed by *chunk*, in stream order.
    Counters: ``skipped_bytes`` (bytes discarded as not part of any frame),
    ``bad_frames`` (header bytes whose complete candidate failed its checksum),
    ``acks``, ``packets``, ``bytes_in``; ``pending`` is the buffered byte count.

    *command_set* restricts which command acks are accepted to that numbering's
    acknowledged ids (default: either numbering); *ack_ids* gives them
    explicitly. *max_payload* is the largest payload considered (506).
    """

    def __init__(
        self,
        command_set: CommandSet | None = None,
        *,
        ack_ids: Iterable[int] | None = None,
        max_payload: int = MAX_PAYLOAD,
    ) -> None:
        if not 0 <= max_payload <= MAX_PAYLOAD:
            raise ValueError(f"max_payload must be 0..{MAX_PAYLOAD}, got {max_payload}")
        if ack_ids is not None:
            self.ack_ids = frozenset(int(i) for i in ack_ids)
        elif command_set is not None:
            self.ack_ids = acked_ids(command_set)
        else:
            self.ack_ids = DEFAULT_ACK_IDS
        self.max_payload = max_payload
        self._buf = bytearray()
        self._need = 0  # nothing to do until the buffer holds this many bytes
        self._prefix: list[int] | None = None  # prefix sums of the buffer during one scan
        self.skipped_bytes = 0
        self.bad_frames = 0
        self.acks = 0
        self.packets = 0
        self.bytes_in = 0

    # ------------------------------------------------------------------ public

    @property
    def pending(self) -> int:
        """Bytes buffered, waiting for the rest of a candidate frame."""
        return len(self._buf)

    @property
    def frame_bytes(self) -> int:
        """Bytes of all frames yielded so far."""
        return self.bytes_in - self.skipped_bytes - len(self._buf)

    def feed(self, chunk: bytes | bytearray | memoryview) -> list[Frame]:
        """Add received bytes; return the frames they complete, in order."""
        chunk = bytes(chunk)
        self.bytes_in += len(chunk)
        self._buf += chunk
        if len(self._buf) < self._need:
            return []
        return self._run(_FEED)

    def flush(self) -> list[Frame]:
        """The link went quiet: give up on incomplete candidates that a valid frame follows.

        Returns the frames that decides. Incomplete candidates with no valid
        frame after them stay buffered (they may be a real frame still arriving).
        """
        return self._run(_FLUSH)

    def finish(self) -> list[Frame]:
        """End of the stream (a recording's end, a closed port): decode what is complete, drop the rest.

        The dropped bytes count as skipped; the decoder is empty afterwards.
        """
        return self._run(_EOF)

    def reset(self) -> None:
        """Forget buffered bytes (e.g. after reopening the port); counters are kept."""
        self.skipped_bytes += len(self._buf)
        self._buf.clear()
        self._need = 0

    def __repr__(self) -> str:
        return (
            f"StreamDecoder(acks={self.acks}, packets={self.packets}, skipped_bytes={self.skipped_bytes}, "
            f"bad_frames={self.bad_frames}, pending={self.pending})"
        )

    # ------------------------------------------------------------------ scanning

    def _run(self, mode: int) -> list[Frame]:
        buf = self._buf
        n = len(buf)
        out: list[Frame] = []
        pos = 0
        skipped = 0
        bad = 0
        need = 0
        # flush: where to roll back to if no valid frame follows an incomplete candidate
        keep: tuple[int, int, int, int] | None = None  # (pos, skipped, bad, len(out))
        self._prefix = None
        while pos < n:
            m = _HEADER.search(buf, pos)
            if m is None:
                skipped += n - pos
                pos = n
                break
            skipped += m.start() - pos
            pos = m.start()
            try:
                frame, length, was_bad = self._candidate(buf, pos, n)
            except _Wait as w:
                if mode == _FEED:
                    need = w.need
                    break
                if mode == _FLUSH and keep is None:
                    keep = (pos, skipped, bad, len(out))
                frame, length, was_bad = None, 0, w.failed
            if frame is None:
                bad += was_bad
                skipped += 1
                pos += 1
                continue
            out.append(frame)
            keep = None
            pos += length
        if keep is not None:
            pos, skipped, bad, n_out = keep
            del out[n_out:]
        self._prefix = None
        del buf[:pos]
        self._need = need - pos if need else 0
        self.skipped_bytes += skipped
        self.bad_frames += bad
        for f in out:
            if isinstance(f, CommandAck):
                self.acks += 1
            else:
                self.packets += 1
        return out

    def _candidate(self, buf: bytearray, pos: int, n: int) -> tuple[Frame | None, int, bool]:
        """Decide the candidate at *pos*: (frame, length, False) or (None, 0, True) for a bad one.

        Raises :class:`_Wait` when it cannot be decided with the *n* bytes buffered.
        """
        if buf[pos] == ACK_HEADER:
            end = pos + ACK_FRAME_LEN
            if end > n:
                raise _Wait(end, False)
            cmd = buf[pos + 1]
            ok = (ACK_HEADER + cmd) & 0xFFFF == (buf[pos + 2] << 8 | buf[pos + 3]) and cmd in self.ack_ids
            return (CommandAck(cmd), ACK_FRAME_LEN, False) if ok else (None, 0, True)
        # state packet: AA number(2) L payload(L or L+256) ck(2)
        if pos + 4 > n:
            raise _Wait(pos + 4, False)
        length_byte = buf[pos + 3]
        head_sum = buf[pos] + buf[pos + 1] + buf[pos + 2] + length_byte
        failed = False
        for plen in (length_byte, length_byte + 256):
            if plen > self.max_payload:
                break
            end = pos + PACKET_OVERHEAD + plen
            if end > n:
                raise _Wait(end, failed)
            ck = (head_sum + self._sum(buf, pos + 4, end - 2)) & 0xFFFF
            if ck == (buf[end - 2] << 8 | buf[end - 1]):
                number = buf[pos + 1] << 8 | buf[pos + 2]
                return StatePacket(number, bytes(buf[pos + 4 : end - 2]), length_byte), end - pos, False
            failed = True
        return None, 0, True

    def _sum(self, buf: bytearray, start: int, stop: int) -> int:
        """Sum of buf[start:stop]; prefix sums (built once per scan) keep an AA flood linear."""
        if stop - start <= 64:
            return sum(buf[start:stop])
        if self._prefix is None:
            cum = np.frombuffer(bytes(buf), np.uint8).cumsum(dtype=np.int64)
            self._prefix = [0, *cum.tolist()]
        return self._prefix[stop] - self._prefix[start]


def decode_all(data: bytes, **kwargs) -> list[Frame]:
    """All frames in a complete recording of module output (a convenience over StreamDecoder)."""
    dec = StreamDecoder(**kwargs)
    return dec.feed(data) + dec.finish()
