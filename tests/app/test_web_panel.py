"""The served modules' live panel (firmware_sim.app.web.panel) without a browser: its buttons run the
control channel's own lines, the steps a module sends are summed as a host sums them, ``serve``
refuses the buttons without the panel; and ``serve --web --web-control`` as a subprocess, its panel
named in READY, a fault pressed on the panel and undone on the control channel, the panel showing
both."""

from __future__ import annotations

import json
import math
import socket
import sys
import urllib.request
from contextlib import ExitStack
from types import SimpleNamespace

import numpy as np
import pytest
import serial

from firmware_sim.transports.factory import SettingsError
from protocol.ids import StateId

from .serve_args import serve_args

pytest.importorskip("aiohttp", reason="the live panel's server needs aiohttp (the web extra)")

from firmware_sim.app.serve import settings_from_args, spawn  # noqa: E402
from firmware_sim.app.web.panel import EmulatorPanel, StepWatch  # noqa: E402


class _Control:
    """The control channel as the panel uses it: a line in, a reply out."""

    def __init__(self):
        self.lines: list[str] = []

    def execute(self, line: str) -> str:
        self.lines.append(line)
        return f"OK {line.split(' ', 1)[1]}"


def _served(index: int, pacer=None) -> SimpleNamespace:
    return SimpleNamespace(index=index, label="", module=SimpleNamespace(sensors=None), links={}, pacer=pacer)


def test_the_buttons_run_the_control_channels_lines_and_nothing_else():
    control = _Control()
    panel = EmulatorPanel([_served(0), _served(1)], ("127.0.0.1", 0), control=control)
    assert panel.act({"module": 1, "command": "disconnect"}) == {"ok": True, "reply": "OK disconnect",
                                                                 "line": "@1 disconnect"}
    assert panel.act({"module": 0, "command": "stall", "arg": 1.5})["line"] == "@0 stall 1.5"
    assert panel.act({"module": 0, "command": "corrupt", "arg": 20})["line"] == "@0 corrupt 20"
    assert panel.act({"module": 0, "command": "drop", "arg": "7"})["line"] == "@0 drop 7"
    assert panel.act({"module": 0, "command": "reconnect"})["ok"]
    for bad in ({"module": 0, "command": "quit"}, {"module": 0, "command": "status"},
                {"module": 2, "command": "disconnect"}, {"module": True, "command": "disconnect"},
                {"module": 0, "command": "stall", "arg": "long"}, {"command": "disconnect"},
                {"module": 0, "command": "corrupt", "arg": float("inf")},  # int(inf) was an OverflowError
                {"module": 0, "command": "drop", "arg": [1]}):
        answer = panel.act(bad)
        assert not answer["ok"] and answer["reply"].startswith("ERR"), bad
    assert control.lines == ["@1 disconnect", "@0 stall 1.5", "@0 corrupt 20", "@0 drop 7", "@0 reconnect"]
    assert [a["line"] for a in panel.actions] == control.lines, "the panel shows the faults asked for"
    off = EmulatorPanel([_served(0)], ("127.0.0.1", 0))
    assert off.server.actions is None and off.act({"module": 0, "command": "disconnect"})["ok"] is False


class _ScriptedPacer:
    """A pacer whose loop shows the module's memory as *script* says, one run of ticks after another."""

    def __init__(self, script: list[tuple[int, list[float]]]):
        self.script = script

    def wait_until(self, predicate, timeout=None) -> bool:
        for counter, dx in self.script:
            memory = {StateId.STEP_COUNTER: np.array(counter, dtype=np.uint16),
                      StateId.DX: np.array(dx, dtype=np.float32)}
            if predicate(SimpleNamespace(memory=memory)):
                return True
        return False


def test_the_steps_a_module_sends_are_summed_as_a_host_sums_them():
    quarter = math.pi / 2
    script = [(0, [0, 0, 0, 0]), (0, [0, 0, 0, 0]), (1, [1, 0, 0, quarter]), (1, [1, 0, 0, quarter]),
              (2, [2, 0, 0, 0]), (4, [1, 0, 0.5, 0])]
    watch = StepWatch(_served(0, _ScriptedPacer(script))).start()
    watch._thread.join(5)
    assert watch.take() == [pytest.approx((1.0, 0.0, 0.0)), pytest.approx((1.0, 2.0, 0.0)),
                            pytest.approx((1.0, 3.0, 0.5))], "each step in the frame the one before left"
    assert (watch.steps, watch.counter, watch.missed) == (3, 4, 1)
    assert watch.take() == []


def test_serve_refuses_the_panels_buttons_without_the_panel():
    with pytest.raises(SettingsError, match="web_control"):
        settings_from_args(serve_args("--pty", "/tmp/x", "--web-control"))
    settings = settings_from_args(serve_args("--pty", "/tmp/x", "--web", "0", "--web-control"))
    assert settings.web == ("127.0.0.1", 0) and settings.web_control
    assert settings_from_args(serve_args("--pty", "/tmp/x", "--web", "0.0.0.0:8000")).web == ("0.0.0.0", 8000)


def _panel_states(url: str):
    """The panel's model after each of its messages (a mirror of what a page holds)."""
    values: dict = {}
    with urllib.request.urlopen(url + "events", timeout=20) as stream:
        for line in stream:
            if line.startswith(b"data: "):
                message = json.loads(line[6:])
                changed = message.get("values", {})
                values = changed if message.get("reset") else {**values, **changed}
                yield values


def _post(url: str, body: dict) -> dict:
    req = urllib.request.Request(url + "control", data=json.dumps(body).encode(), method="POST",
                                 headers={"Content-Type": "application/json", "X-Live-Control": "1"})
    with urllib.request.urlopen(req, timeout=20) as r:
        return json.loads(r.read())


def _control(address: str, line: str) -> str:
    host, port = address.rsplit(":", 1)
    with socket.create_connection((host, int(port)), timeout=10) as c:
        f = c.makefile("rw", encoding="utf-8", newline="\n")
        f.write(line + "\n")
        f.flush()
        return f.readline().strip()


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="ptys are tested on Linux")
def test_a_fault_pressed_on_the_panel_shows_on_the_control_channel_and_back(tmp_path):
    with ExitStack() as stack:
        srv = stack.enter_context(spawn("--scenario", "stand:3+walk:10+stand:2", "--pty",
                                        str(tmp_path / "shoe"), "--status-interval", "0", "--web", "0",
                                        "--web-control", timeout=120))
        assert srv.ready["web"].startswith("127.0.0.1:") and srv.ready["control"].startswith("127.0.0.1:"), \
            "the buttons' control channel is opened and named"
        url = f"http://{srv.ready['web']}/"
        states = _panel_states(url)
        first = next(states)
        assert first["control"] is True and first["labels"] == ["m0"]
        module = next(s for s in states if s.get("modules") and s["modules"][0].get("links"))["modules"][0]
        assert module["running"] and not module["links"][0]["connected"], "no host yet"
        assert module["walker"]["truth"] is not None, "the scenario's truth, at its start before a host came"
        host = stack.enter_context(serial.Serial(srv.ready["bt-pty"], timeout=1))
        attached = next(s for s in states if s["modules"][0]["links"][0]["connected"])
        disconnects = attached["modules"][0]["links"][0]["disconnects"]
        assert _post(url, {"module": 0, "command": "disconnect"}) == {
            "ok": True, "reply": "OK disconnect", "line": "@0 disconnect"}
        next(s for s in states if not s["modules"][0]["links"][0]["connected"])
        assert _control(srv.ready["control"], "reconnect") == "OK reconnect"
        back = next(s for s in states if s["modules"][0]["links"][0]["connected"])
        assert back["modules"][0]["links"][0]["disconnects"] == disconnects + 1
        assert [a["line"] for a in back["actions"]] == ["@0 disconnect"]
        host.close()
        assert srv.stop() == 0
