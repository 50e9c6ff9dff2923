"""The live pages' server (hostlib.web.server) over HTTP, without a browser: the page and its scripts
from the package, the model's events (the whole model first, then each change), a page too slow to
keep up sent away to start afresh, and the control endpoint off unless given, refusing requests
that do not come from the page."""

from __future__ import annotations

import json
import urllib.error
import urllib.request

import pytest

pytest.importorskip("aiohttp", reason="the live pages' server needs aiohttp (the web extra)")

from hostlib.web import server as server_module  # noqa: E402
from hostlib.web.model import LiveModel  # noqa: E402
from hostlib.web.server import LiveServer, static_dir  # noqa: E402


def _get(url: str) -> tuple[int, str, str]:
    try:
        with urllib.request.urlopen(url, timeout=10) as r:
            return r.status, r.headers.get("Content-Type", ""), r.read().decode()
    except urllib.error.HTTPError as exc:
        return exc.code, "", exc.read().decode()


def _post(url: str, body: object, headers: dict[str, str]) -> tuple[int, str]:
    req = urllib.request.Request(url, data=json.dumps(body).encode(), method="POST",
                                 headers={"Content-Type": "application/json", **headers})
    try:
        with urllib.request.urlopen(req, timeout=10) as r:
            return r.status, r.read().decode()
    except urllib.error.HTTPError as exc:
        return exc.code, exc.read().decode()


def _events(stream) -> dict:
    """The next event's data from an open event stream."""
    while True:
        line = stream.readline().decode()
        assert line, "the stream ended"
        if line.startswith("data: "):
            return json.loads(line[6:])


@pytest.fixture
def served():
    model = LiveModel("walk", {"track": 100})
    model.update(append={"track": [[0, 0.0, 0.0]]}, values={"title": "a walk"})
    with LiveServer(model, "host.html", [static_dir("hostlib.web")]) as srv:
        yield srv, model


def test_the_page_and_its_scripts_come_from_the_package_and_nothing_else(served):
    srv, _model = served
    assert srv.url.startswith("http://127.0.0.1:") and srv.port > 0
    status, kind, page = _get(srv.url)
    assert status == 200 and kind.startswith("text/html") and "static/live.js" in page
    assert "http" not in page.replace(srv.url, ""), "the page loads nothing from elsewhere"
    status, kind, script = _get(srv.url + "static/live.js")
    assert status == 200 and "javascript" in kind and "EventSource" in script
    for name in ("nothing.js", "..%2Fserver.py", ".hidden"):
        assert _get(srv.url + "static/" + name)[0] == 404


def test_the_pages_load_nothing_from_the_network():
    for package in ("hostlib.web", "firmware_sim.app.web"):
        for f in static_dir(package).iterdir():
            text = f.read_text().replace("http://www.w3.org/2000/svg", "")  # a name, not an address
            for address in ("http:", "https:", 'src="//', 'href="//', "url(", "@import"):
                assert address not in text, f"{package}: {f.name} has {address}"


def test_a_page_gets_the_whole_model_then_each_change(served):
    srv, model = served
    with urllib.request.urlopen(srv.url + "events", timeout=10) as stream:
        first = _events(stream)
        assert first["reset"] and first["series"]["track"] == [[0, 0.0, 0.0]]
        assert first["values"]["title"] == "a walk"
        model.update(append={"track": [[1, 1.0, 0.5]]}, values={"title": "a walk"})
        assert _events(stream) == {"seq": 2, "append": {"track": [[1, 1.0, 0.5]]}}
    status, _kind, state = _get(srv.url + "state")
    assert status == 200 and json.loads(state)["series"]["track"][-1] == [1, 1.0, 0.5]


def test_a_page_that_falls_behind_is_sent_away_and_starts_afresh(served, monkeypatch):
    srv, model = served
    monkeypatch.setattr(server_module, "CLIENT_QUEUE", 3)
    with urllib.request.urlopen(srv.url + "events", timeout=10) as stream:
        _events(stream)
        for k in range(1, 60):  # far more than the page reads meanwhile
            model.update(append={"track": [[k, float(k), 0.0]]})
        seen = []
        while line := stream.readline():
            if line.startswith(b"data: "):
                seen.append(json.loads(line[6:]))
    assert len(seen) < 59, "the stream ended early"
    with urllib.request.urlopen(srv.url + "events", timeout=10) as again:
        fresh = _events(again)
    assert fresh["reset"] and fresh["series"]["track"][-1] == [59, 59.0, 0.0]


def test_the_controls_are_off_unless_given_and_answer_only_the_page(served):
    srv, _model = served
    assert _post(srv.url + "control", {"command": "disconnect"}, {"X-Live-Control": "1"})[0] == 403
    asked = []
    model = LiveModel("emulator")
    with LiveServer(model, "host.html", [static_dir("hostlib.web")],
                    actions=lambda body: asked.append(body) or {"ok": True, "reply": "OK"}) as on:
        body = {"module": 0, "command": "disconnect"}
        page = {"X-Live-Control": "1", "Origin": on.url.rstrip("/")}
        assert _post(on.url + "control", body, {})[0] == 403, "without the page's header"
        assert _post(on.url + "control", body, {**page, "Origin": "http://elsewhere.example"})[0] == 403
        status, answer = _post(on.url + "control", body, page)
        assert status == 200 and json.loads(answer) == {"ok": True, "reply": "OK"}
        assert _post(on.url + "control", [1, 2], {"X-Live-Control": "1"})[0] == 400
    assert asked == [body]


def test_a_port_in_use_is_named_with_the_option_and_its_address():
    """``openshoe-host track --web PORT`` and ``openshoe-emu serve --web PORT`` on a port something
    else listens on: one line naming the option and the address, before any walk is tracked."""
    import io
    import socket

    from hostlib.errors import HostError
    from hostlib.run.status import Messages
    from hostlib.web.walk_page import WalkPage

    with socket.create_server(("127.0.0.1", 0)) as busy:
        port = busy.getsockname()[1]
        page = WalkPage(("127.0.0.1", port), "a walk", Messages(stream=io.StringIO()))
        with pytest.raises(HostError) as caught:
            page.open()
        page.close()
    assert str(caught.value) == f"--web 127.0.0.1:{port}: Address already in use"
