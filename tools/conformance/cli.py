"""`openshoe-conformance URL`: does this device speak the OpenShoe protocol exactly?

URL is anything pyserial opens: a device path (/dev/rfcomm0, /dev/ttyACM0,
COM5), a pty of the emulator, ``socket://HOST:PORT``, ``rfc2217://HOST:PORT``,
or ``openshoe://`` (an in-process emulator). Exit status 0 when every check
passes (skips are fine, and so is ABSENT: an emulator extension the device lacks, as a real
module does), 1 when any fails, 2 on bad usage or an unopenable URL.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

import serial

from protocol.commands import command_set

from .checks import CHECKS, run, select
from .driver import DeviceDriver, device_clock


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
    p.add_argument("--baudrate", type=int, default=115200, help="for real serial ports (default 115200)")
    p.add_argument("--time-scale", type=float, default=1.0,
                   help="multiply every wait (for slow links or loaded hosts; default 1)")
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
    if args.url.lower().startswith("openshoe://"):
        import firmware_sim.transports  # noqa: F401  (registers the in-process emulator's URL scheme)
    try:
        port = serial.serial_for_url(args.url, baudrate=args.baudrate, timeout=0.005)
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
