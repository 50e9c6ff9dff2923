"""``openshoe-host info``: ping the module and read its MCU serial number."""

from __future__ import annotations

import argparse
import time
from typing import TextIO

from protocol.ids import OutputMode, StateId

from ..run.tracking_run import remaining
from .options import open_device

__all__ = ["cmd_info"]


def cmd_info(args: argparse.Namespace, out: TextIO) -> int:
    with open_device(args, args.url) as dev:
        t0 = time.monotonic()
        dev.ping()
        rtt = time.monotonic() - t0
        print(f"port      {dev.name}", file=out)
        print(f"commands  {args.command_set} numbering; ping answered in {rtt * 1000:.1f} ms", file=out)
        got = None
        dev.request_mcu_id()  # 0x04 in both numberings
        deadline = time.monotonic() + 2.0
        while got is None and time.monotonic() < deadline:
            pkt = dev.recv_packet(timeout=remaining(deadline))
            if pkt is not None and pkt.states and StateId.MCU_ID in pkt.states:
                got = bytes(pkt.states[StateId.MCU_ID].astype("u1"))
        print("mcu id    " + (got.hex(" ").upper() if got else "(no answer)"), file=out)
        print(f"lossless  {dev.session.lossless} (mode bit 0x{int(OutputMode.LOSSLESS):02X})", file=out)
    return 0
