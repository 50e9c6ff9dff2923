"""Whether the live page's server and the page itself stay flat in memory over a long walk::

    python -m tests.web.memory [--speed 8] [--minutes 30] [--feet 2]

A served walk of *minutes* module-minutes (with GPS, two feet by default) is tracked with
``openshoe-host track --web``; headless Chromium keeps the walk's page open. Every ``--every``
seconds of wall time it notes the resident memory of the host (which serves the page) and of the
served modules' process, and the page's JavaScript heap (after a collection) and element count; at
the end it prints them at a quarter, half and all of the walk, and the growth over the second half.
A measurement to read, not a test.
"""

from __future__ import annotations

import argparse
import asyncio
import sys
import tempfile
from pathlib import Path

from tests.web.cdp import Browser
from tests.web.walks import module_urls, served, tracking

#: The page's own figures: the JavaScript heap in use [B] and the document's elements.
PAGE_FIGURES = "[performance.memory.usedJSHeapSize, document.getElementsByTagName('*').length]"


def rss_mb(pid: int) -> float:
    """A process's resident memory [MB] (Linux)."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024.0
    return float("nan")


async def sample(url: str, pids: dict[str, int], seconds: float, every: float) -> list[dict[str, float]]:
    """Rows of (wall time, each process's RSS, the page's heap and elements) over *seconds*."""
    rows = []
    async with Browser() as browser:
        walk = await browser.page(url)
        await walk.wait("liveMirror.latencies.length > 0", 120)
        loop = asyncio.get_running_loop()
        start = loop.time()
        while loop.time() - start < seconds:
            await walk.send("HeapProfiler.collectGarbage")  # the heap in use, not what awaits collection
            heap, elements = await walk.evaluate(PAGE_FIGURES)
            row = {"t_s": loop.time() - start, "page_heap_mb": heap / 2 ** 20, "page_elements": elements}
            row.update({f"{name}_rss_mb": rss_mb(pid) for name, pid in pids.items()})
            rows.append(row)
            await walk.evaluate(f"new Promise(r => setTimeout(r, {every * 1000:.0f}))", every + 30)
    return rows


def report(rows: list[dict[str, float]]) -> str:
    """The figures at a quarter, half and the end of the walk, and the second half's growth."""
    pick = {"¼": rows[len(rows) // 4], "½": rows[len(rows) // 2], "end": rows[-1]}
    names = [k for k in rows[0] if k != "t_s"]
    lines = [f"{'':14s}" + "".join(f"{n:>18s}" for n in names)]
    for label, row in pick.items():
        lines.append(f"{label:4s}{row['t_s']:8.0f} s " + "".join(f"{row[n]:18.1f}" for n in names))
    half, end = pick["½"], pick["end"]
    lines.append("second half: " + ", ".join(f"{n} {100.0 * (end[n] / half[n] - 1.0):+.1f} %" for n in names))
    return "\n".join(lines)


def main(argv: list[str]) -> int:
    p = argparse.ArgumentParser(prog="python -m tests.web.memory", description=__doc__.split("\n\n")[0])
    p.add_argument("--speed", type=float, default=8.0, help="module time per wall time (default 8)")
    p.add_argument("--minutes", type=float, default=30.0, help="module-minutes walked (default 30)")
    p.add_argument("--every", type=float, default=5.0, help="wall seconds between samples (default 5)")
    p.add_argument("--feet", type=int, choices=(1, 2), default=2)
    args = p.parse_args(argv)
    laps = max(1, round(args.minutes * 60.0 * 1.4 / 400.0))  # a walker's 1.4 m/s round a 400 m track
    recipe = f"stand:3+track400:{laps}+stand:3"
    wall = args.minutes * 60.0 / args.speed
    with tempfile.TemporaryDirectory() as tmp, \
            served(Path(tmp), feet=args.feet, speed=args.speed, recipe=recipe, timeout=600.0) as srv, \
            tracking(module_urls(srv), gps=srv.ready["gps-pty"], duration=wall + 120) as host:
        rows = asyncio.run(sample(host.url, {"host": host.proc.pid, "serve": srv.proc.pid}, wall, args.every))
        host.stop()
    print(f"{recipe} at --speed {args.speed:g} with {args.feet} module(s), {len(rows)} samples:")
    print(report(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
