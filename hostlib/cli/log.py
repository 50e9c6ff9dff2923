"""``openshoe-host log``: capture the module's byte stream to a file, its packets still acked; with
``--start`` 0x34 first, with the set-up the options ask for (:class:`~hostlib.run.host_setup.HostSetup`:
by default the fusion set-up, which a module that does not acknowledge it goes without, said once), and
with ``--calibrate-mag`` the in-situ calibration's stream recorded (and its fit saved)."""

from __future__ import annotations

import argparse
import threading
import time
from contextlib import closing
from typing import BinaryIO, TextIO

from ..errors import HostError
from ..run.host_setup import HostSetup
from ..run.in_situ import InSituCalibration
from ..run.status import LiveLine, Messages
from ..run.tracking_run import DeviceSetup, remaining
from .options import open_device

__all__ = ["LOG_LINE_EVERY_S", "CaptureFile", "cmd_log"]

#: `log` to a file or pipe: one status line this often [s] (on a terminal the line is live).
LOG_LINE_EVERY_S = 5.0


class CaptureFile:
    """The file ``log --raw`` writes, opened once the module's port is open: what the reader thread
    reads before it is open is kept, and written first. So a port that does not open leaves no
    file, and does not empty an earlier capture of the same name."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._early = bytearray()
        self._file: BinaryIO | None = None

    def write(self, data: bytes) -> int:
        with self._lock:
            if self._file is None:
                self._early += data
            else:
                self._file.write(data)
        return len(data)

    def open(self, path: str) -> None:
        """Open *path* and write what came before; a file that cannot be written is a
        :class:`~hostlib.errors.HostError` naming it."""
        try:
            file = open(path, "wb")  # noqa: SIM115 - closed in close()
        except OSError as exc:
            raise HostError(f"cannot write the capture {path}: {exc.strerror or exc}") from None
        with self._lock:
            file.write(self._early)
            self._early.clear()
            self._file = file

    def close(self) -> None:
        with self._lock:
            if self._file is not None:
                self._file.close()


def cmd_log(args: argparse.Namespace, out: TextIO) -> int:
    capture = CaptureFile()
    with closing(capture), open_device(args, args.url, raw_log=capture) as dev:
        capture.open(args.raw)
        messages = Messages("openshoe-host log")
        in_situ = InSituCalibration(dev, args.mag_cal_dir, messages) if args.calibrate_mag else None
        setup = DeviceSetup(dev, HostSetup(fusion=args.fusion, height_compensation=args.height_compensation,
                                           wiggle=None if in_situ is None else in_situ.wiggle), in_situ,
                            messages=messages)
        if args.start:
            dev.start_stepwise_dead_reckoning()
        setup.after_start()
        deadline = None if args.duration is None else time.monotonic() + args.duration
        live = LiveLine(out, every_s=LOG_LINE_EVERY_S)
        try:
            while deadline is None or time.monotonic() < deadline:
                dev.recv_packet(timeout=remaining(deadline))
                setup.poll()
                st = dev.stats
                live.show(f"bytes {st['bytes_received']:9d} | packets {st['packets']:7d} | "
                          f"step packets {st['steps']:5d} | garbage {st['garbage_bytes']}")
                if args.steps is not None and dev.session.stats.steps >= args.steps and setup.sent:
                    break
        except KeyboardInterrupt:
            pass
        live.close()
        setup.close(leave_running=True)  # log leaves the module's outputs on: the stream is stopped
    return 0
