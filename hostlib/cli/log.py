"""``openshoe-host log``: capture the module's byte stream to a file, its packets still acked; with
``--start`` 0x34 first, with the set-up the options ask for (:class:`~hostlib.run.host_setup.HostSetup`),
and with ``--calibrate-mag`` the in-situ calibration's stream recorded (and its fit saved)."""

from __future__ import annotations

import argparse
import time
from typing import TextIO

from ..run.host_setup import HostSetup
from ..run.in_situ import InSituCalibration
from ..run.status import LiveLine, Messages
from ..run.tracking_run import DeviceSetup, remaining
from .options import open_device

__all__ = ["LOG_LINE_EVERY_S", "cmd_log"]

#: `log` to a file or pipe: one status line this often [s] (on a terminal the line is live).
LOG_LINE_EVERY_S = 5.0


def cmd_log(args: argparse.Namespace, out: TextIO) -> int:
    with open(args.raw, "wb") as raw, open_device(args, args.url, raw_log=raw) as dev:
        in_situ = (InSituCalibration(dev, args.mag_cal_dir, Messages("openshoe-host log"))
                   if args.calibrate_mag else None)
        setup = DeviceSetup(dev, HostSetup(fusion=args.fusion, height_compensation=args.height_compensation,
                                           wiggle=None if in_situ is None else in_situ.wiggle), in_situ)
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
