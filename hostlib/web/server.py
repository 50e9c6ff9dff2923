"""A small HTTP server for a live page: :class:`LiveServer`, in a thread of its own beside the program
it shows.

It serves

* ``/`` — the page (an HTML file shipped in a package's ``static`` folder) and ``/static/NAME``, its
  scripts and styles, from the same folders: nothing is loaded from the network;
* ``/events`` — server-sent events: first the whole :class:`~hostlib.web.model.LiveModel` (a
  ``reset``), then each of its messages as it is made. A page that falls too far behind (its queue
  holds :data:`CLIENT_QUEUE` messages) is disconnected; its browser reconnects by itself and is
  given the whole model again, so a slow page costs bounded memory;
* ``/state`` — the whole model as JSON, once;
* ``POST /control`` — an action the page asks for (a JSON object handed to *actions*, whose JSON
  answer is returned), only when the server was given *actions*; else 403. A request must carry the
  header ``X-Live-Control: 1`` (which a page of another site cannot send without the browser asking
  first, and this server never agrees) and, if it names an ``Origin``, this server's own.

Why aiohttp: it is one library with no server of its own to pick and run (Starlette needs an ASGI
server, uvicorn, beside it), it streams server-sent events with a plain ``StreamResponse``, runs in a
thread of its own with its own event loop, and its client speaks WebSocket, which the tests use to
drive a browser over the DevTools protocol.
"""

from __future__ import annotations

import asyncio
import re
import threading
from collections.abc import Callable, Sequence
from importlib.resources import files
from importlib.resources.abc import Traversable
from typing import Any

from .address import LOOPBACK, page_url
from .model import LiveModel

__all__ = ["CLIENT_QUEUE", "LiveServer", "MissingWebLibrary", "require_aiohttp", "static_dir"]

#: Messages a page may have waiting before it is disconnected (it reconnects and starts afresh).
CLIENT_QUEUE = 256
#: Seconds between the comments that keep an idle event stream open.
KEEPALIVE_S = 15.0

_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.-]*$")
_TYPES = {".html": "text/html", ".js": "text/javascript", ".css": "text/css", ".svg": "image/svg+xml",
          ".json": "application/json", ".png": "image/png"}
_CLOSE = object()


class MissingWebLibrary(RuntimeError):
    """aiohttp, which the live pages need, is not installed."""


def require_aiohttp() -> None:
    """Raise :class:`MissingWebLibrary` (saying how to install it) if aiohttp is missing."""
    try:
        import aiohttp  # noqa: F401
    except ImportError:
        raise MissingWebLibrary("the live page needs aiohttp: pip install 'openshoe-emulator[web]'") from None


def static_dir(package: str) -> Traversable:
    """The ``static`` folder shipped inside *package*."""
    return files(package).joinpath("static")


class LiveServer:
    """The page *page* (a file in one of *assets*, folders searched in order) and *model*'s events
    (module docstring), on *host*:*port* (port 0: a free one). *actions*: what ``POST /control``
    runs (in a worker thread; None: the page's controls are off)."""

    def __init__(self, model: LiveModel, page: str, assets: Sequence[Traversable], *, host: str = LOOPBACK,
                 port: int = 0, actions: Callable[[dict[str, Any]], dict[str, Any]] | None = None):
        require_aiohttp()
        self.model = model
        self.page = page
        self.assets = list(assets)
        self.host, self.port = host, port
        self.actions = actions
        self._thread: threading.Thread | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._stop: asyncio.Future | None = None
        self._ready = threading.Event()
        self._error: BaseException | None = None
        self._clients: set[asyncio.Queue] = set()

    # -- running ------------------------------------------------------------------------

    def start(self, timeout: float = 10.0) -> str:
        """Listen, in a daemon thread; returns the page's URL. An address that cannot be had is an
        :class:`OSError`."""
        self._thread = threading.Thread(target=self._run, name=f"live-page[{self.page}]", daemon=True)
        self._thread.start()
        if not self._ready.wait(timeout):
            raise OSError(f"the live page did not start listening within {timeout:g} s")
        if self._error is not None:
            raise self._error
        return self.url

    @property
    def url(self) -> str:
        return page_url(self.host, self.port)

    def close(self, timeout: float = 5.0) -> None:
        """Stop serving: every page's event stream ends, the port closes. Idempotent."""
        loop, stop = self._loop, self._stop
        if loop is not None and stop is not None and not loop.is_closed():
            try:
                loop.call_soon_threadsafe(lambda: stop.done() or stop.set_result(None))
            except RuntimeError:
                pass  # the loop already ended
        if self._thread is not None:
            self._thread.join(timeout)

    def __enter__(self) -> LiveServer:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _run(self) -> None:
        loop = self._loop = asyncio.new_event_loop()
        try:
            loop.run_until_complete(self._serve())
        except BaseException as exc:  # noqa: BLE001 - handed to start()
            self._error = exc
        finally:
            self._ready.set()
            loop.close()

    async def _serve(self) -> None:
        from aiohttp import web

        app = web.Application()
        app.router.add_get("/", self._page)
        app.router.add_get("/static/{name}", self._static)
        app.router.add_get("/events", self._events)
        app.router.add_get("/state", self._state)
        app.router.add_post("/control", self._control)
        runner = web.AppRunner(app, access_log=None, handle_signals=False, shutdown_timeout=1.0)
        await runner.setup()
        try:
            site = web.TCPSite(runner, self.host, self.port)
            await site.start()
            address = runner.addresses[0]
            self.port = int(address[1])
            self._stop = asyncio.get_running_loop().create_future()
            self._ready.set()
            await self._stop
            for q in list(self._clients):
                q.put_nowait(_CLOSE)
        finally:
            await runner.cleanup()

    # -- handlers -----------------------------------------------------------------------

    def _asset(self, name: str) -> bytes | None:
        if not _NAME.match(name):
            return None
        for folder in self.assets:
            f = folder.joinpath(name)
            if f.is_file():
                return f.read_bytes()
        return None

    def _file_response(self, name: str):
        from aiohttp import web

        body = self._asset(name)
        if body is None:
            raise web.HTTPNotFound(text=f"no {name}")
        kind = _TYPES.get(name[name.rfind("."):], "application/octet-stream")
        charset = "utf-8" if kind.startswith("text") else None
        return web.Response(body=body, content_type=kind, charset=charset,
                            headers={"Cache-Control": "no-cache"})

    async def _page(self, request):
        return self._file_response(self.page)

    async def _static(self, request):
        return self._file_response(request.match_info["name"])

    async def _state(self, request):
        from aiohttp import web

        return web.Response(text=self.model.snapshot(), content_type="application/json")

    async def _events(self, request):
        from aiohttp import web

        resp = web.StreamResponse(headers={"Content-Type": "text/event-stream", "Cache-Control": "no-cache",
                                           "X-Accel-Buffering": "no"})
        await resp.prepare(request)
        loop = asyncio.get_running_loop()
        q: asyncio.Queue = asyncio.Queue()

        def push(text: str) -> None:
            if q.qsize() >= CLIENT_QUEUE:
                q.put_nowait(_CLOSE)  # too far behind: it reconnects and starts afresh
            else:
                q.put_nowait(text)

        def listener(text: str) -> None:
            try:
                loop.call_soon_threadsafe(push, text)
            except RuntimeError:
                pass  # the server's loop ended

        self._clients.add(q)
        snapshot = self.model.subscribe(listener)
        try:
            await resp.write(b"retry: 500\n\n" + _event(snapshot))
            while True:
                try:
                    text = await asyncio.wait_for(q.get(), KEEPALIVE_S)
                except asyncio.TimeoutError:
                    await resp.write(b": keep-alive\n\n")
                    continue
                if text is _CLOSE:
                    break
                await resp.write(_event(text))
        except (ConnectionError, asyncio.CancelledError):
            pass
        finally:
            self.model.unsubscribe(listener)
            self._clients.discard(q)
        return resp

    async def _control(self, request):
        from aiohttp import web

        if self.actions is None:
            raise web.HTTPForbidden(text="the controls are off (give --web-control to turn them on)")
        origin = request.headers.get("Origin")
        if request.headers.get("X-Live-Control") != "1" or (
                origin is not None and origin != f"{request.scheme}://{request.host}"):
            raise web.HTTPForbidden(text="a control request comes from this page only")
        try:
            body = await request.json()
        except (ValueError, UnicodeDecodeError):
            raise web.HTTPBadRequest(text="expected a JSON object") from None
        if not isinstance(body, dict):
            raise web.HTTPBadRequest(text="expected a JSON object")
        answer = await asyncio.get_running_loop().run_in_executor(None, self.actions, body)
        return web.json_response(answer)


def _event(text: str) -> bytes:
    return f"data: {text}\n\n".encode()

