"""An in-memory stand-in for a serial port with a scripted module behind it (no emulator)."""

from __future__ import annotations

import threading
import time

import serial

from protocol.commands import CURRENT, CommandSet
from protocol.frames import build_command_ack, checksum


class FakeModulePort:
    """A pyserial-like port: what the host writes is parsed as commands; replies are scripted.

    * every valid command except ACK gets its ``A0 cmd ck ck`` (unless ``mute``),
      queued behind ``hold_acks_behind`` bytes if set (lossless: acks wait behind data);
    * packet acks (``01 nn nn ck ck``) are recorded in ``packet_acks``;
    * ``inject(bytes)`` makes bytes arrive at the host; ``drop()`` breaks the link.
    """

    def __init__(self, command_set: CommandSet = CURRENT, *, mute: bool = False, name: str = "fake://module"):
        self.command_set = command_set
        self.mute = mute
        self.port = name
        self.timeout: float | None = 0.05
        self.is_open = True
        self.written = bytearray()
        self.commands: list[bytes] = []
        self.packet_acks: list[int] = []
        self.on_command = None  # callable(frame) -> bytes | None, replaces the ack
        self._rx = bytearray()
        self._parse = bytearray()
        self._cond = threading.Condition()
        self._broken = False
        self.acks_ready = threading.Event()

    # -- host side (pyserial API) -----------------------------------------------------

    @property
    def in_waiting(self) -> int:
        self._check()
        return len(self._rx)

    def read(self, n: int = 1) -> bytes:
        deadline = None if self.timeout is None else time.monotonic() + self.timeout
        with self._cond:
            while not self._rx:
                self._check()
                remaining = None if deadline is None else deadline - time.monotonic()
                if remaining is not None and remaining <= 0:
                    return b""
                self._cond.wait(remaining)
            self._check()
            out = bytes(self._rx[:n])
            del self._rx[:n]
            return out

    def write(self, data: bytes) -> int:
        self._check()
        with self._cond:
            self.written += data
            self._parse += data
            self._run_parser()
            self._cond.notify_all()
        return len(data)

    def flush(self) -> None:
        pass

    def close(self) -> None:
        with self._cond:
            self.is_open = False
            self._cond.notify_all()

    def open(self) -> None:
        """Re-open: a dropped link is usable again (the module kept running)."""
        with self._cond:
            self.is_open = True
            self._broken = False
            self.reopens = getattr(self, "reopens", 0) + 1

    # -- module side -------------------------------------------------------------------

    def inject(self, data: bytes) -> None:
        with self._cond:
            self._rx += data
            self._cond.notify_all()

    def drop(self) -> None:
        with self._cond:
            self._broken = True
            self._cond.notify_all()

    def wait_written(self, predicate, timeout: float = 5.0) -> bool:
        """Wait until predicate(self) holds (checked on every write)."""
        deadline = time.monotonic() + timeout
        with self._cond:
            while not predicate(self):
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    return False
                self._cond.wait(remaining)
            return True

    def _check(self) -> None:
        if self._broken:
            raise serial.SerialException("link dropped (fake)")
        if not self.is_open:
            raise serial.PortNotOpenError()

    def _run_parser(self) -> None:
        buf = self._parse
        while buf:
            if buf[0] not in self.command_set:
                del buf[0]
                continue
            spec = self.command_set[buf[0]]
            if len(buf) < spec.frame_len:
                return
            frame = bytes(buf[: spec.frame_len])
            del buf[: spec.frame_len]
            if checksum(frame[:-2]) != int.from_bytes(frame[-2:], "big"):
                continue
            if not spec.acked:
                self.packet_acks.append(int.from_bytes(frame[1:3], "big"))
                continue
            self.commands.append(frame)
            if self.on_command is not None:
                reply = self.on_command(frame)
                if reply:
                    self._rx += reply
            elif not self.mute:
                self._rx += build_command_ack(frame[0])
