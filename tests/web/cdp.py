"""A real browser for the live pages' tests: Debian's headless Chromium driven over the DevTools
protocol (CDP) by a small client on aiohttp's WebSocket.

:func:`chromium` finds the browser (None: none here). :class:`Browser` starts it headless with a
fresh profile and ``--remote-debugging-port=0``, reads the DevTools address it prints, and opens
pages (:meth:`Browser.page`): each a target attached in flat mode, driven by commands on the one
WebSocket. A :class:`Page` loads a URL (waiting for its load event), evaluates JavaScript (awaiting
promises), waits for a condition re-tested after each render of a live page (``Live.when``: on
events, not on the clock), clicks an element with the mouse, and takes screenshots.
"""

from __future__ import annotations

import asyncio
import base64
import itertools
import json
import os
import re
import shutil
import tempfile
from pathlib import Path
from typing import Any

import aiohttp

#: Where Debian puts it, then what PATH has.
CANDIDATES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")
FLAGS = ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
         "--disable-component-update", "--no-first-run", "--no-default-browser-check", "--disable-sync",
         "--disable-extensions", "--mute-audio", "--hide-scrollbars", "--remote-debugging-port=0")


def chromium() -> str | None:
    """The browser's executable (``$CHROMIUM`` first), or None."""
    given = os.environ.get("CHROMIUM")
    if given:
        return shutil.which(given) or (given if Path(given).is_file() else None)
    for name in CANDIDATES:
        found = shutil.which(name)
        if found:
            return found
    return None


class CdpError(RuntimeError):
    """A CDP command failed, or the page's JavaScript threw."""


class Browser:
    """Headless Chromium with a fresh profile (module docstring); ``async with Browser() as b``."""

    def __init__(self, executable: str | None = None, *, width: int = 1440, height: int = 1000,
                 start_timeout: float = 30.0):
        self.executable = executable or chromium()
        if self.executable is None:
            raise FileNotFoundError("no chromium on this machine")
        self.size = (width, height)
        self.start_timeout = start_timeout
        self.proc: asyncio.subprocess.Process | None = None
        self._profile = tempfile.mkdtemp(prefix="live-page-chromium-")
        self._http: aiohttp.ClientSession | None = None
        self._ws: aiohttp.ClientWebSocketResponse | None = None
        self._ids = itertools.count(1)
        self._pending: dict[int, asyncio.Future] = {}
        self._events: dict[str, list[tuple[str | None, asyncio.Future]]] = {}
        self._reader: asyncio.Task | None = None
        self._stderr: asyncio.Task | None = None

    async def __aenter__(self) -> Browser:
        self.proc = await asyncio.create_subprocess_exec(
            self.executable, *FLAGS, f"--user-data-dir={self._profile}",
            f"--window-size={self.size[0]},{self.size[1]}", "about:blank",
            stdin=asyncio.subprocess.DEVNULL, stdout=asyncio.subprocess.DEVNULL,
            stderr=asyncio.subprocess.PIPE)
        url = await asyncio.wait_for(self._devtools_url(), self.start_timeout)
        self._stderr = asyncio.create_task(self._drain_stderr())
        self._http = aiohttp.ClientSession()
        self._ws = await self._http.ws_connect(url, max_msg_size=0)
        self._reader = asyncio.create_task(self._read())
        return self

    async def _devtools_url(self) -> str:
        assert self.proc is not None and self.proc.stderr is not None
        while True:
            line = await self.proc.stderr.readline()
            if not line:
                raise CdpError(f"chromium exited ({await self.proc.wait()}) before it listened")
            found = re.search(rb"DevTools listening on (ws://\S+)", line)
            if found:
                return found.group(1).decode()

    async def _drain_stderr(self) -> None:
        assert self.proc is not None and self.proc.stderr is not None
        while await self.proc.stderr.readline():
            pass

    async def __aexit__(self, *exc: object) -> None:
        if self._ws is not None:
            try:
                await asyncio.wait_for(self.send("Browser.close"), 5.0)
            except (CdpError, asyncio.TimeoutError, ConnectionError):
                pass
            await self._ws.close()
        if self._reader is not None:
            self._reader.cancel()
        if self._http is not None:
            await self._http.close()
        if self.proc is not None:
            try:
                await asyncio.wait_for(self.proc.wait(), 10.0)
            except asyncio.TimeoutError:
                self.proc.kill()
                await self.proc.wait()
        if self._stderr is not None:
            self._stderr.cancel()
        shutil.rmtree(self._profile, ignore_errors=True)

    async def _read(self) -> None:
        assert self._ws is not None
        async for msg in self._ws:
            if msg.type != aiohttp.WSMsgType.TEXT:
                continue
            data = json.loads(msg.data)
            if "id" in data:
                fut = self._pending.pop(data["id"], None)
                if fut is not None and not fut.done():
                    if "error" in data:
                        fut.set_exception(CdpError(f"{data['error']}"))
                    else:
                        fut.set_result(data.get("result", {}))
            else:
                waiters = self._events.get(data.get("method", ""), [])
                for entry in list(waiters):
                    session, fut = entry
                    if fut.done():
                        waiters.remove(entry)
                    elif session in (None, data.get("sessionId")):
                        fut.set_result(data.get("params", {}))
                        waiters.remove(entry)
        for fut in self._pending.values():
            if not fut.done():
                fut.set_exception(CdpError("the browser closed its DevTools connection"))

    async def send(self, method: str, params: dict[str, Any] | None = None,
                   session: str | None = None) -> dict:
        """One CDP command (in a page's *session*, or the browser's); its result."""
        assert self._ws is not None
        n = next(self._ids)
        fut = asyncio.get_running_loop().create_future()
        self._pending[n] = fut
        message: dict[str, Any] = {"id": n, "method": method, "params": params or {}}
        if session is not None:
            message["sessionId"] = session
        await self._ws.send_str(json.dumps(message))
        return await fut

    def event(self, method: str, session: str | None = None) -> asyncio.Future:
        """A future of the next event *method* (in *session*)."""
        fut = asyncio.get_running_loop().create_future()
        self._events.setdefault(method, []).append((session, fut))
        return fut

    async def page(self, url: str | None = None) -> Page:
        """A new page (tab), loaded with *url* if given."""
        target = await self.send("Target.createTarget", {"url": "about:blank"})
        attached = await self.send("Target.attachToTarget", {"targetId": target["targetId"], "flatten": True})
        page = Page(self, attached["sessionId"])
        await page.send("Page.enable")
        await page.send("Runtime.enable")
        await page.send("Emulation.setDeviceMetricsOverride",
                        {"width": self.size[0], "height": self.size[1], "deviceScaleFactor": 1,
                         "mobile": False})
        if url is not None:
            await page.goto(url)
        return page


class Page:
    """One tab of a :class:`Browser`."""

    def __init__(self, browser: Browser, session: str):
        self.browser = browser
        self.session = session

    async def send(self, method: str, params: dict[str, Any] | None = None) -> dict:
        return await self.browser.send(method, params, self.session)

    async def goto(self, url: str, timeout: float = 20.0) -> None:
        """Load *url* and wait for its load event."""
        loaded = self.browser.event("Page.loadEventFired", self.session)
        result = await self.send("Page.navigate", {"url": url})
        if result.get("errorText"):
            raise CdpError(f"cannot load {url}: {result['errorText']}")
        await asyncio.wait_for(loaded, timeout)

    async def evaluate(self, expression: str, timeout: float = 20.0) -> Any:
        """The value of a JavaScript *expression* (a promise is awaited), as JSON gives it."""
        result = await asyncio.wait_for(self.send("Runtime.evaluate", {
            "expression": expression, "awaitPromise": True, "returnByValue": True}), timeout)
        if "exceptionDetails" in result:
            raise CdpError(f"{expression[:80]!r} threw: {result['exceptionDetails']}")
        return result.get("result", {}).get("value")

    async def wait(self, condition: str, timeout: float = 30.0) -> Any:
        """Wait until the JavaScript *condition* holds, tested now and after each render of the live
        page (``Live.when``); its value. TimeoutError after *timeout* seconds, saying what the page
        showed."""
        try:
            return await self.evaluate(f"Live.when(() => ({condition}))", timeout)
        except asyncio.TimeoutError:
            shown = await self.evaluate("document.body.innerText.slice(0, 2000)", 5.0)
            raise asyncio.TimeoutError(f"not within {timeout:g} s: {condition}\nthe page shows:\n{shown}"
                                       ) from None

    async def click(self, selector: str) -> None:
        """Press and release the left mouse button over the middle of the element *selector*."""
        box = await self.evaluate(
            f"(() => {{ const e = document.querySelector({json.dumps(selector)}); e.scrollIntoView();"
            f" const r = e.getBoundingClientRect(); return [r.x + r.width / 2, r.y + r.height / 2]; }})()")
        x, y = box
        for kind in ("mousePressed", "mouseReleased"):
            await self.send("Input.dispatchMouseEvent",
                            {"type": kind, "x": x, "y": y, "button": "left", "clickCount": 1})

    async def screenshot(self, path: str | Path) -> Path:
        """A PNG of the whole page at *path*."""
        metrics = await self.send("Page.getLayoutMetrics")
        size = metrics.get("cssContentSize") or metrics["contentSize"]
        shot = await self.send("Page.captureScreenshot", {
            "format": "png", "captureBeyondViewport": True,
            "clip": {"x": 0, "y": 0, "width": size["width"], "height": size["height"], "scale": 1}})
        path = Path(path)
        path.write_bytes(base64.b64decode(shot["data"]))
        return path
