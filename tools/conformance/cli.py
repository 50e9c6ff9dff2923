"""`openshoe-conformance URL`: does this device speak the OpenShoe protocol exactly?

URL is anything pyserial opens: a device path (/dev/rfcomm0, /dev/ttyACM0,
COM5), a pty of the emulator, ``socket://HOST:PORT``, ``rfc2217://HOST:PORT``,
or ``openshoe://`` (an in-process emulator). Exit status 0 when every check
passes (skips are fine, and so is ABSENT: an emulator extension the device lacks, as a real
module does), 1 when any fails, 2 on bad usage or an unopenable URL.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence

import serial

from hostlib.link.connection import open_port
from protocol.commands import command_set

from .checks import CHECKS, run, select
from .driver import DeviceDriver, device_clock

#: The largest --time-scale: every wait a thousand times as long is a link no check could run on.
MAX_TIME_SCALE = 1000.0


def _time_scale(text: str) -> float:
    """The argparse type of ``--time-scale``: a factor > 0 (0 would wait for nothing, and never end)."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not 0.0 < value <= MAX_TIME_SCALE:
        raise argparse.ArgumentTypeError(f"a factor > 0 and <= {MAX_TIME_SCALE:g}, not {text!r}")
    return value


def _baud_rate(text: str) -> int:
    """The argparse type of ``--baudrate``: a whole number of bits per second > 0."""
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value <= 0:
        raise argparse.ArgumentTypeError(f"a whole number of bits per second > 0, not {text!r}")
    return value


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="openshoe-conformance",
        description="Run the OpenShoe wire-protocol conformance checks against a device "
        "(a real module or an emulator). Each check prints PASS/FAIL with the bytes that prove it.",
    )
    p.add_argument("url", nargs="?", help="serial port or pyserial URL (path, socket://, rfc2217://, openshoe://)")
    p.add_argument("--command-set", default="2015", choices=["2014", "2015"],
                   help="command numbering the device speaks (default 2015)")
    p.add_argument("--only", nargs="+", metavar="NAME", help="run only these checks (see --list)")
    p.add_argument("--list", action="store_true", help="list the checks and exit")
    p.add_argument("--baudrate", type=_baud_rate, default=115200,
                   help="for real serial ports (default 115200)")
    p.add_argument("--time-scale", type=_time_scale, default=1.0,
                   help="multiply every wait (for slow links or loaded hosts; a number > 0, at most "
                        f"{MAX_TIME_SCALE:g}; default 1)")
    p.add_argument("-q", "--quiet", action="store_true", help="print the bytes only for failures")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.list:
        width = max(len(n) for n in CHECKS)
        for chk in CHECKS.values():
            needs = f" (needs {', '.join(m.name for m in chk.needs)})" if chk.needs else ""
            group = "" if chk.group == "protocol" else f"({chk.group}) "
            print(f"{chk.name:<{width}}  [{chk.duration}] {group}{chk.description}{needs}")
        return 0
    if not args.url:
        print("openshoe-conformance: a URL is required (or --list)", file=sys.stderr)
        return 2
    try:
        select(args.only)
    except ValueError as exc:
        print(f"openshoe-conformance: {exc}", file=sys.stderr)
        return 2
    try:
        port = open_port(args.url, baudrate=args.baudrate, read_timeout=0.005)
    except (serial.SerialException, ValueError, OSError) as exc:
        print(f"openshoe-conformance: cannot open {args.url}: {exc}", file=sys.stderr)
        return 2
    cs = command_set(args.command_set)
    print(f"openshoe-conformance: {args.url}, command set {cs.name}", flush=True)
    try:
        driver = DeviceDriver(port, cs, time_scale=args.time_scale, clock=device_clock(port))
        report = run(driver, args.only, url=args.url,
                     on_result=lambda r: print(r.render(verbose=not args.quiet), flush=True))
    finally:
        port.close()
    print(report.summary())
    return 0 if report.ok else 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
