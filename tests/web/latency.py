"""How late a step appears on the walk's live page: from the moment its step packet reached the host
(the device's step callback, in ``openshoe-host track``) to the render that drew it in the browser::

    python -m tests.web.latency [--speed 1] [--seconds 40] [--feet 2] [--recipe RECIPE]

A served walk (with GPS, two feet by default) is tracked with ``--web``; headless Chromium keeps the
page open; the page notes, after each render, how long ago each step packet it drew arrived
(``liveMirror.latencies``: the host stamps arrivals with the epoch clock the browser's ``Date.now``
reads). Prints the count, median, 95th percentile and largest delay. A measurement to read, not a
test: it depends on the machine's load.
"""

from __future__ import annotations

import argparse
import asyncio
import statistics
import sys
import tempfile
from pathlib import Path

from tests.web.cdp import Browser
from tests.web.walks import module_urls, served, tracking

RECIPE = "stand:3+walk:30+arc:4:90+walk:20+arc:4:90+walk:30+stand:3"


async def measure(url: str, seconds: float) -> list[float]:
    async with Browser() as browser:
        walk = await browser.page(url)
        await walk.wait("liveMirror.latencies.length > 0", 120)
        start = await walk.evaluate("liveMirror.latencies.length")
        await walk.evaluate(f"new Promise(r => setTimeout(r, {seconds * 1000:.0f}))", seconds + 30)
        return (await walk.evaluate("liveMirror.latencies"))[start:]


def main(argv: list[str]) -> int:
    p = argparse.ArgumentParser(prog="python -m tests.web.latency", description=__doc__.split("\n\n")[0])
    p.add_argument("--speed", type=float, default=1.0, help="module time per wall time (default 1)")
    p.add_argument("--seconds", type=float, default=40.0, help="wall seconds measured (default 40)")
    p.add_argument("--feet", type=int, choices=(1, 2), default=2)
    p.add_argument("--recipe", default=RECIPE, help=f"the walk (default {RECIPE}; a 10-minute one: "
                   "stand:3+track400:2+stand:3)")
    args = p.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp, \
            served(Path(tmp), feet=args.feet, speed=args.speed, recipe=args.recipe) as srv, \
            tracking(module_urls(srv), gps=srv.ready["gps-pty"], duration=args.seconds + 120) as host:
        delays = asyncio.run(measure(host.url, args.seconds))
        host.stop()
    if not delays:
        print("no step was drawn")
        return 1
    ms = sorted(1000.0 * d for d in delays)
    p95 = ms[min(len(ms) - 1, round(0.95 * (len(ms) - 1)))]
    print(f"{len(ms)} step packets drawn at --speed {args.speed:g} with {args.feet} module(s): delay from "
          f"arrival at the host to the page's render: median {statistics.median(ms):.1f} ms, "
          f"p95 {p95:.1f} ms, max {ms[-1]:.1f} ms")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
