"""Both live pages in a real browser: headless Chromium driven over the DevTools protocol
(tests/web/cdp.py).

A two-feet walk with GPS is served (``openshoe-emu serve --feet 2 --gps-pty … --web 0 --web-control``)
and tracked (``openshoe-host track LEFT RIGHT --fusion --compass --gps … --web 0``), a few seconds of
walk at five times real time. The panel shows each module's steps beside the walker's truth; the
walk's page, opened late, shows the whole walk so far, then each step as it comes; "disconnect"
pressed on the panel takes the left foot's link down while its module walks on, and once it is
pressed "reconnect" the walk's page reports the steps lost as a gap. Without ``--web-control`` the
panel's buttons are off. A long walk's page holds a bounded number of elements.

Every wait is on what the page shows after a render (``Live.when``), never a fixed sleep; no
assertion is on how long anything took. Without Chromium the tests are skipped.
"""

from __future__ import annotations

import asyncio
import sys

import pytest

pytest.importorskip("aiohttp", reason="the live pages' server and the browser's client need aiohttp "
                                      "(the web extra)")

from firmware_sim.app.serve import spawn  # noqa: E402
from hostlib.web.feed import SERIES_CAPS, walk_model  # noqa: E402
from hostlib.web.server import LiveServer, static_dir  # noqa: E402
from tests.web.cdp import Browser, chromium  # noqa: E402
from tests.web.walks import module_urls, page, served, tracking  # noqa: E402

pytestmark = [
    pytest.mark.skipif(chromium() is None, reason="no Chromium on this machine (Debian: apt-get install -y "
                                                  "chromium): the live pages are tested in a real browser"),
    pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the served modules' ptys are Linux's"),
]

#: Long enough for the slowest start on a busy machine (the compiled path, the first fix).
WAIT_S = 90.0


#: How many points the walk's page draws its track with.
TRACK_POINTS = "document.getElementById('track').points.numberOfItems"


def _text(element_id: str) -> str:
    return f"document.getElementById('{element_id}').textContent"


def _path(element_id: str) -> str:
    return f"document.getElementById('{element_id}').getAttribute('d')"


def _steps_sent(i: int) -> str:
    """The steps module *i* sent, as the panel shows them."""
    return f"Number(document.getElementById('steps-{i}').dataset.steps || 0)"


def _connected(i: int) -> str:
    """Whether module *i*'s link is up, as the panel shows it ('1' or '0')."""
    return f"document.getElementById('link-{i}').dataset.connected"


def _gaps(i: int) -> str:
    """Link *i*'s gaps cell on the walk's page."""
    return f"document.querySelector('#link-{i} [data-field=gaps]')"


async def _walk_and_disconnect(srv, host) -> None:
    async with Browser() as browser:
        panel = await browser.page(page(srv.ready["web"]))
        await panel.wait(f"{_steps_sent(0)} >= 6 && {_steps_sent(1)} >= 6", WAIT_S)
        assert await panel.evaluate("liveMirror.series['truth.0'].length > 3 && "
                                    "liveMirror.series['sent.1'].length >= 6")
        assert "/" in await panel.evaluate(_text("true-1")), "the walker's true position"
        assert "ZUPT_UPDATE" in await panel.evaluate(_text("slots-0")), "the running process functions"

        walk = await browser.page(host.url)  # opened late: the whole walk so far
        # the body and the track as drawn by one render (the mirror may hold news not yet drawn)
        first = await walk.wait("liveMirror.drawnSeq === liveMirror.seq && liveMirror.values.body && "
                                f"{{steps: liveMirror.values.body.steps, points: {TRACK_POINTS}}}")
        points = first["points"]
        assert points == first["steps"] + 1 or points == SERIES_CAPS["track"], ("every step since the start",
                                                                                first)
        assert await walk.evaluate("liveMirror.series.track[0][0]") == 0
        await walk.wait(f"{TRACK_POINTS} > {points} && {_path('foot-left')}.length > 0", WAIT_S)
        counters = await walk.wait("[...document.querySelectorAll('#links tbody tr')].length === 2 && "
                                   "[...document.querySelectorAll('#links [data-field=steps]')]"
                                   ".map(c => Number(c.textContent))", WAIT_S)
        assert all(n > 0 for n in counters), counters
        await walk.wait(f"(liveMirror.series.fixes || []).length > 0 && {_path('compass-used')}.length > 0",
                        WAIT_S)
        assert await walk.evaluate("document.querySelectorAll('#plan *').length") < 400, "a bounded drawing"

        before_down = await panel.evaluate(_steps_sent(0))
        await panel.click("#btn-0-disconnect")
        await panel.wait(f"{_text('reply-0')} === 'OK disconnect' && {_connected(0)} === '0'", WAIT_S)
        down_at = await panel.evaluate(_steps_sent(0))
        await panel.wait(f"{_steps_sent(0)} >= {down_at + 2}", WAIT_S)  # it walks on, unheard
        before_up = await panel.evaluate(_steps_sent(0))
        await panel.click("#btn-0-reconnect")
        await panel.wait(f"{_connected(0)} === '1'", WAIT_S)
        up_at = await panel.evaluate(_steps_sent(0))
        gaps = await walk.wait(f"Number({_gaps(0)}.dataset.gaps) > 0 && {_gaps(0)}.textContent", WAIT_S)
        assert gaps.startswith("1 (") and not gaps.endswith("(0)"), gaps
        # the gap is the disconnect's length: the steps the module sent unheard — at least those the
        # panel counted while the link was down, at most those from before the press that took it
        # down to after the one that brought it back (give or take the one in flight)
        missing = int(gaps[3:-1])
        assert before_up - down_at - 1 <= missing <= up_at - before_down + 1, \
            (gaps, before_down, down_at, before_up, up_at)
        print(f"\ngap of {missing} steps; the panel counted {before_up - down_at} sent while down, "
              f"{up_at - before_down} from press to press")
        assert await walk.evaluate(f"{_gaps(1)}.dataset.gaps") == "0", "the right foot walked on, heard"
        assert await panel.evaluate("liveMirror.values.actions.map(a => a.line).join(',')") == \
            "@0 disconnect,@0 reconnect"


def test_both_pages_follow_a_two_feet_walk_and_a_disconnect_on_the_panel_is_a_gap_on_the_walks(tmp_path):
    with served(tmp_path, speed=5.0) as srv, \
            tracking(module_urls(srv), gps=srv.ready["gps-pty"], duration=120) as host:
        asyncio.run(_walk_and_disconnect(srv, host))
        assert host.stop(timeout=60.0) == 0, "\n".join(host.said[-200:])  # its threads' stacks if it hung
        assert srv.stop() == 0


async def _buttons_off(url: str) -> None:
    async with Browser() as browser:
        panel = await browser.page(url)
        await panel.wait("document.getElementById('btn-0-disconnect') !== null")
        buttons = "[...document.querySelectorAll('.controls button')]"
        assert await panel.evaluate(f"{buttons}.length === 5 && {buttons}.every(b => b.disabled)")
        assert await panel.evaluate(_text("control-state")) == "fault buttons off"
        status = await panel.evaluate("fetch('control', {method: 'POST', headers: {'X-Live-Control': '1', "
                                      "'Content-Type': 'application/json'}, body: JSON.stringify({module: 0, "
                                      "command: 'disconnect'})}).then(r => r.status)")
        assert status == 403


def test_without_web_control_the_panels_buttons_are_off(tmp_path):
    args = ["--scenario", "stand:5", "--pty", str(tmp_path / "quiet"), "--status-interval", "0", "--web", "0"]
    with spawn(*args, timeout=120) as srv:
        assert "control" not in srv.ready
        asyncio.run(_buttons_off(page(srv.ready["web"])))


async def _long_walk(url: str, model) -> None:
    async with Browser() as browser:
        walk = await browser.page(url)
        await walk.wait(f"liveMirror.drawnSeq === liveMirror.seq && "
                        f"liveMirror.series.track.length === {len(model.points('track'))}")
        drawn = await walk.evaluate("({elements: document.querySelectorAll('#plan *').length, "
                                    f"points: {TRACK_POINTS}, "
                                    "ellipses: document.querySelectorAll('#plan ellipse').length})")
        assert drawn["points"] <= SERIES_CAPS["track"] and drawn["ellipses"] <= 24
        assert drawn["elements"] < 200
        seq = await walk.evaluate("liveMirror.seq")
        model.update(append={"track": [[k, k * 0.7, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0, k * 0.7]
                                       for k in range(3601, 3700)]})
        await walk.wait(f"liveMirror.drawnSeq === liveMirror.seq && liveMirror.seq > {seq} && "
                        "liveMirror.series.track.at(-1)[0] === 3699")
        assert await walk.evaluate(TRACK_POINTS) <= SERIES_CAPS["track"]


def test_a_long_walks_page_holds_a_bounded_drawing():
    """Half an hour at a step a second on each foot: the page draws what the bounded model holds."""
    model = walk_model()
    model.update(values={"state": "walking", "mode": "two feet", "links": [], "body": None},
                 append={"track": [[k, k * 0.7, 0.0, 0.0, 0.0, 1.0, 0.5, 10.0, k * 0.7] for k in range(3601)],
                         "left": [[k, k * 0.7, -0.1] for k in range(1, 3601, 2)],
                         "right": [[k, k * 0.7, 0.1] for k in range(2, 3601, 2)],
                         "fixes": [[k * 0.7, 0.5, 3, float(k)] for k in range(1800)],
                         "compass": [[k * 0.7, 0.0, 0.0, k % 7 != 0, k % 2, k] for k in range(3600)]})
    assert all(n <= SERIES_CAPS[name] for name, n in model.sizes().items())
    with LiveServer(model, "host.html", [static_dir("hostlib.web")]) as server:
        asyncio.run(_long_walk(server.url, model))

