"""``openshoe-host track --web [HOST:]PORT``: the walk's live page (:class:`WalkPage`), served from
before the modules start until the walk ended.

The page (``static/host.html``) shows the plan view — the track with its 1σ ellipses, each foot's
rests, the GPS fixes, the compass readings used and rejected —, the height profile, the heading and
each link's counters, updated as the steps come (:class:`~hostlib.web.feed.WalkFeed`); a page
opened late is given the whole walk so far. The terminal's status line goes on as without it.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager, nullcontext
from typing import TYPE_CHECKING

from ..errors import HostError
from .address import bind_refusal, is_loopback

if TYPE_CHECKING:
    from ..run.status import Messages
    from ..run.tracking_run import TrackingRun
    from .feed import WalkFeed

__all__ = ["WalkPage", "following", "walk_page"]


class WalkPage:
    """The live page of one walk on *address* (host, port), titled *title*; *messages* hears its URL."""

    def __init__(self, address: tuple[str, int], title: str, messages: Messages):
        self.title = title
        self.messages = messages
        from .feed import walk_model  # the web stack only for a page
        from .server import LiveServer, MissingWebLibrary, static_dir

        self.model = walk_model()
        self.model.update(values={"title": title, "state": "starting"})
        try:
            self.server = LiveServer(self.model, "host.html", [static_dir("hostlib.web")], host=address[0],
                                     port=address[1])
        except MissingWebLibrary as exc:
            raise HostError(str(exc)) from None
        self.feed: WalkFeed | None = None

    def open(self) -> str:
        """Listen; returns the URL (said on the messages). An address that cannot be had is a
        :class:`~hostlib.errors.HostError`."""
        try:
            url = self.server.start()
        except OSError as exc:
            raise HostError(bind_refusal("--web", (self.server.host, self.server.port), exc)) from None
        self.messages.note(f"live page at {url}")
        if not is_loopback(self.server.host):
            self.messages.note(f"the live page listens on {self.server.host}, not only on this machine: "
                               "whoever reaches it can watch the walk")
        return url

    def close(self) -> None:
        if self.feed is not None:
            self.feed.close()
        self.server.close()

    @contextmanager
    def following(self, run: TrackingRun) -> Iterator[WalkFeed]:
        """The page follows *run* (started) until the block ends (the walk ended)."""
        from .feed import WalkFeed

        self.feed = WalkFeed(run, self.model, title=self.title)
        with self.feed:
            yield self.feed


@contextmanager
def walk_page(address: tuple[str, int] | None, title: str, messages: Messages) -> Iterator[WalkPage | None]:
    """A :class:`WalkPage` on *address*, open for the block (None: no page, None given)."""
    if address is None:
        yield None
        return
    page = WalkPage(address, title, messages)
    page.open()
    try:
        yield page
    finally:
        page.close()


def following(page: WalkPage | None, run: TrackingRun):
    """*page* follows *run* for the block (no page: nothing)."""
    return nullcontext() if page is None else page.following(run)
