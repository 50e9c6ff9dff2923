"""Screenshots of both live pages in the middle of a two-feet walk with GPS, from headless Chromium::

    python -m tests.web.screenshots [HOST.png EMU.png]

(default ``/tmp/live-host.png`` and ``/tmp/live-emu.png``). ``openshoe-emu serve --feet 2
--gps-pty …`` walks; ``openshoe-host track LEFT RIGHT --fusion --compass --gps …`` tracks it; once
the walker has turned and walked back a little, both pages are taken.
"""

from __future__ import annotations

import asyncio
import sys
import tempfile
from pathlib import Path

from tests.web.cdp import Browser
from tests.web.walks import module_urls, page, served, tracking

STEPS = 70  # fused steps before the pictures: round the second arc


async def take(host_png: Path, emu_png: Path) -> None:
    with tempfile.TemporaryDirectory() as tmp, served(Path(tmp), speed=3.0) as srv, \
            tracking(module_urls(srv), gps=srv.ready["gps-pty"], duration=60) as host:
        async with Browser() as browser:
            walk = await browser.page(host.url)
            panel = await browser.page(page(srv.ready["web"]))
            try:
                await walk.wait(f"(liveMirror.values.body || {{}}).steps >= {STEPS}", 120)
                await panel.wait("(liveMirror.values.modules || []).every(m => m.walker.steps > 10)", 30)
            except asyncio.TimeoutError:
                print("openshoe-host track said:", *host.said[-20:], sep="\n  ", file=sys.stderr)
                raise
            for tab, png, what in ((walk, host_png, "host page"), (panel, emu_png, "emulator panel")):
                await tab.send("Page.bringToFront")
                await tab.wait(f"liveMirror.renders > {await tab.evaluate('liveMirror.renders')}")
                print(f"{what}:", await tab.screenshot(png))


def main(argv: list[str]) -> int:
    host_png, emu_png = (Path(a) for a in (argv or ["/tmp/live-host.png", "/tmp/live-emu.png"]))
    asyncio.run(take(host_png, emu_png))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
