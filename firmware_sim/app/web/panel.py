"""The served modules' live panel: :class:`EmulatorPanel`, what ``openshoe-emu serve --web
[HOST:]PORT`` shows in a browser while it serves.

For each module:

* its **state**: the process functions in its running sequence, the outputs on at each interface
  (the states, their rate divider, lossless or not; the conditional output: which states go out
  when its flag is set, e.g. a step's at FILTER_RESET_FLAG), the packets it assembled and the frames in
  its queue; its real-time **loop** (mean and longest tick, overruns, lateness, bytes late at a
  host: :class:`~firmware_sim.transports.pacer.PacerStatus`); its **link** (up, stalled, what it
  lost, corrupted, disconnects) and whether a host holds each endpoint;
* the **walker**: where the simulated foot truly is (the scenario's truth at the module's clock,
  the walk starting when a host started the module) beside what the module has sent — its steps
  (DX at each step counter), summed as a host sums them, placed at the foot's true start and
  heading (the module's frame starts there: its alignment knows no heading). A recording has no
  truth: only the steps are shown;
* **buttons** for the control channel's faults — disconnect, reconnect, stall S, corrupt N, drop
  N — which run the very line the control channel runs (:meth:`ControlServer.execute
  <firmware_sim.app.control.ControlServer.execute>`, ``@I command``): a test drives a fault either
  way and sees the same. They are off unless the panel is given the control channel
  (``--web-control``).

The steps are watched in the pacer's own thread, after each run of the module's ticks
(:meth:`~firmware_sim.transports.pacer.PacedModule.wait_until` with a test that notes a new step
counter and never holds): a step reset comes at most every 0.75 s of module time, far more seldom
than a run of ticks ends, so none is missed. Everything else is read every
:attr:`EmulatorPanel.refresh_s` in the panel's thread (the module's tables through
:meth:`~firmware_sim.transports.pacer.PacedModule.call`, between two ticks). The series are bounded
(:data:`PANEL_CAPS`): the truth is drawn every :data:`TRUTH_STEP_S` of walk time, and thinned as a
long walk goes on.
"""

from __future__ import annotations

import math
import threading
import time
from collections import deque
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, TextIO

import numpy as np

from hostlib.web.address import is_loopback
from hostlib.web.model import LiveModel
from hostlib.web.server import LiveServer, static_dir
from protocol.ids import ProcId, StateId
from protocol.states import exists, state_spec

if TYPE_CHECKING:
    from firmware_sim.mcu.module import Module

    from ..control import ControlServer
    from ..served_gps import GpsPtyEndpoint
    from ..served_module import ServedModule

__all__ = ["FAULTS", "PANEL_CAPS", "TRUTH_STEP_S", "EmulatorPanel", "StepWatch", "WalkerTruth", "open_panel"]

#: The most points each module's series hold: the true path (``truth.I``) and the summed steps
#: (``sent.I``).
PANEL_CAPS = {"truth": 1500, "sent": 1000}
#: Walk time [s] between two points of the true path.
TRUTH_STEP_S = 0.25
#: The faults a button may ask for, and the kind of number each takes (None: none).
FAULTS: dict[str, type | None] = {"disconnect": None, "reconnect": None, "stall": float, "corrupt": int,
                                  "drop": int}


class WalkerTruth:
    """Where a served module's foot truly is: its scenario's truth (``None`` attributes for a
    recording), from the module's first sensor read on."""

    def __init__(self, module: Module):
        self.module = module
        self.played = getattr(module.sensors, "source", None)
        self.truth = getattr(getattr(self.played, "source", None), "truth", None)

    @property
    def known(self) -> bool:
        return self.truth is not None and hasattr(self.played, "start")

    def index(self) -> int | None:
        """The truth's sample at the module's clock now (None: no truth; 0 before the walk)."""
        if not self.known:
            return None
        start = self.played.start
        if start is None:
            return 0
        clock = self.module.clock
        walked = max(0.0, clock.now_cycles / clock.cpu_hz - (start + 1) / clock.rate_hz)
        t = self.truth.t
        return min(int(np.searchsorted(t, t[0] + walked)), len(t) - 1)

    def start_pose(self) -> tuple[np.ndarray, float]:
        """The foot's true position (NED) and heading [rad] when its walk began."""
        return np.asarray(self.truth.pos[0], dtype=float), float(self.truth.euler[0, 2])


class StepWatch:
    """The steps *served* module sends (DX at each new step counter), noted in its pacer's thread and
    summed here as a host sums them (a counter back to 0 starts a new walk)."""

    def __init__(self, served: ServedModule):
        self.served = served
        self._last: int | None = None
        self._noted: deque[tuple[int, np.ndarray]] = deque(maxlen=4096)
        self._closed = False
        self.pose = np.zeros(4)  #: x, y, z [m], χ [rad] in the module's frame
        self.counter = 0  #: the last step counter
        self.steps = 0  #: steps summed
        self.missed = 0  #: counters skipped between two noted steps
        self.restarts = 0
        self._thread = threading.Thread(target=self._watch, name=f"panel-steps[{served.index}]", daemon=True)

    def start(self) -> StepWatch:
        self._thread.start()
        return self

    def close(self) -> None:
        self._closed = True

    def _watch(self) -> None:
        try:
            self.served.pacer.wait_until(self._check, timeout=None)
        except Exception:  # noqa: BLE001 - a module whose memory cannot be read: no steps shown
            return

    def _check(self, module: Module) -> bool:
        """In the pacer's thread, after a run of ticks: note a new step counter and its DX."""
        counter = int(module.memory[StateId.STEP_COUNTER])
        if counter != self._last:
            if self._last is not None or counter:
                self._noted.append((counter, np.array(module.memory[StateId.DX], dtype=float)))
            self._last = counter
        return self._closed

    def take(self) -> list[tuple[float, float, float]]:
        """Sum the steps noted since the last call; the module-frame positions after each."""
        out = []
        while self._noted:
            counter, dx = self._noted.popleft()
            if counter == 0:
                self.pose[:] = 0.0
                self.restarts += 1
            else:
                self.missed += max(0, (counter - self.counter - 1) % 65536)
                c, s = math.cos(self.pose[3]), math.sin(self.pose[3])
                self.pose[:3] += (c * dx[0] - s * dx[1], s * dx[0] + c * dx[1], dx[2])
                self.pose[3] += dx[3]
                self.steps += 1
            self.counter = counter
            out.append((float(self.pose[0]), float(self.pose[1]), float(self.pose[2])))
        return out


def _proc_name(pid: int) -> str:
    try:
        return ProcId(pid).name
    except ValueError:
        return f"0x{pid:02X}"


def _state_name(sid: int) -> str:
    try:
        return state_spec(sid).name
    except KeyError:
        return f"0x{sid:02X}"


def module_tables(served: ServedModule) -> dict[str, Any]:
    """What *served*'s module runs and sends, and its links' state (read between two ticks)."""
    module = served.module
    outputs = [{"iface": i.name, "lossless": i.lossless, "packets": i.packets_assembled,
                "queue": len(i.queue), "connected": bool(i.port.connected),
                "served": any(i.port is link for link in served.links.values()),
                "states": [[sid, _state_name(sid), d] for sid, d in i.periodic_outputs.items()]}
               for i in module.interface_list]
    links = []
    for name, link in served.links.items():
        c = link.counters
        links.append({"name": name, "connected": bool(link.connected),
                      "stalled": bool(link.stalled("to_host")), "disconnects": c.disconnects,
                      "stalls": c.stalls, "lost": c.to_host.lost,
                      "corrupted": c.to_host.corrupted, "delivered": c.to_host.delivered})
    cond = module.cond_output
    conditional = None
    if cond.flag_id:
        conditional = {"flag": _state_name(cond.flag_id),
                       "ifaces": [i.name for i in module.interface_list if cond.from_mask & i.mask],
                       "states": [_state_name(sid) for sid in cond.state_ids if sid and exists(sid)]}
    return {"slots": [_proc_name(p) for p in module.sequence.slots if p], "outputs": outputs, "links": links,
            "conditional": conditional}


class EmulatorPanel:
    """The live panel of *modules* (module docstring) on *address* (host, port). *control*: the
    control channel whose lines the buttons run (None: the buttons are off); *gps*: the served
    receiver, if any."""

    #: Seconds between two readings of the modules.
    refresh_s = 0.25

    def __init__(self, modules: Sequence[ServedModule], address: tuple[str, int], *,
                 control: ControlServer | None = None, gps: GpsPtyEndpoint | None = None):
        self.modules = list(modules)
        self.control = control
        self.gps = gps
        caps = {f"{kind}.{m.index}": cap for m in self.modules for kind, cap in PANEL_CAPS.items()}
        self.model = LiveModel("emulator", caps)
        self.server = LiveServer(self.model, "emu.html",
                                 [static_dir("firmware_sim.app.web"), static_dir("hostlib.web")],
                                 host=address[0], port=address[1],
                                 actions=None if control is None else self.act)
        self.truths = [WalkerTruth(m.module) for m in self.modules]
        self.watches = [StepWatch(m) for m in self.modules]
        self._truth_next = [0] * len(self.modules)  # the next truth sample to draw
        self._origin: list[tuple[np.ndarray, float] | None] = [None] * len(self.modules)
        self.actions: deque[dict[str, Any]] = deque(maxlen=12)  #: the last faults asked for
        self._poke = threading.Event()
        self._stop = threading.Event()
        self._update_lock = threading.Lock()
        self._thread = threading.Thread(target=self._run, name="emulator-panel", daemon=True)

    @property
    def address(self) -> str:
        """``HOST:PORT`` where the panel listens."""
        return f"{self.server.host}:{self.server.port}"

    def start(self) -> str:
        """Listen and start watching; returns the panel's URL (OSError: the address cannot be had)."""
        url = self.server.start()
        self.model.update(values={"control": self.control is not None, "started": time.time(),
                                  "loopback": is_loopback(self.server.host),
                                  "labels": [m.label or f"m{m.index}" for m in self.modules]})
        for w in self.watches:
            w.start()
        self.update()
        self._thread.start()
        return url

    def close(self) -> None:
        """Stop watching and serving. Idempotent."""
        self._stop.set()
        self._poke.set()
        for w in self.watches:
            w.close()
        if self._thread.is_alive():
            self._thread.join(5.0)
        self.server.close()

    def poke(self) -> None:
        """Read the modules now rather than at the next refresh."""
        self._poke.set()

    def _run(self) -> None:
        while not self._stop.is_set():
            self._poke.wait(self.refresh_s)
            self._poke.clear()
            if self._stop.is_set():
                return
            try:
                self.update()
            except Exception:  # noqa: BLE001 - the panel must not take serve down; next time, again
                continue

    # -- the buttons ------------------------------------------------------------------------

    def act(self, request: dict[str, Any]) -> dict[str, Any]:
        """A button: ``{"module": I, "command": NAME, "arg": N}`` (NAME one of :data:`FAULTS`) run as
        the control channel's line ``@I NAME [N]``; its reply (``OK …``/``ERR …``) comes back."""
        if self.control is None:
            return {"ok": False, "reply": "ERR the controls are off (--web-control)"}
        command, module, arg = request.get("command"), request.get("module"), request.get("arg")
        if command not in FAULTS:
            return {"ok": False, "reply": f"ERR not a fault: {command!r} (one of {', '.join(FAULTS)})"}
        if not isinstance(module, int) or isinstance(module, bool) or not 0 <= module < len(self.modules):
            return {"ok": False, "reply": f"ERR no module {module!r}"}
        kind = FAULTS[command]
        line = f"@{module} {command}"
        if kind is not None:
            try:
                value = kind(arg)
            except (TypeError, ValueError, OverflowError):  # int(Infinity) of a page's JSON too
                return {"ok": False, "reply": f"ERR {command} takes a number, not {arg!r}"}
            line += f" {value:g}" if kind is float else f" {value}"
        reply = self.control.execute(line) or ""
        self.actions.append({"at": time.time(), "module": module, "line": line, "reply": reply})
        self.poke()
        return {"ok": reply.startswith("OK"), "reply": reply, "line": line}

    # -- reading the modules ------------------------------------------------------------------

    def update(self) -> None:
        """Read every module and tell the model what changed."""
        with self._update_lock:
            append: dict[str, list] = {}
            modules = [self._module(i, m, append) for i, m in enumerate(self.modules)]
            values: dict[str, Any] = {"modules": modules, "actions": list(self.actions)}
            if self.gps is not None:
                values["gps"] = self.gps.status()
            self.model.update(append=append, values=values)

    def _module(self, i: int, served: ServedModule, append: dict[str, list]) -> dict[str, Any]:
        st = served.pacer.status()
        out: dict[str, Any] = {
            "index": served.index, "label": served.label or f"m{served.index}", "running": st.running,
            "error": None if served.pacer.error is None else repr(served.pacer.error),
            "t": st.virtual_s, "ratio": st.virtual_s / st.wall_s if st.wall_s > 0 else 0.0,
            "speed": st.speed, "loop_us_mean": st.loop_us_mean, "loop_us_max": st.loop_us_max,
            "overruns": st.overruns, "lag_ms": st.lag_ms, "lag_max_ms": st.lag_max_ms,
            "frame_ms": st.frame_ms, "late_bytes": st.late_bytes, "rebases": st.rebases,
            "nonfinite": st.nonfinite,
            "hosts": [{"kind": e.get("kind", "?"), "paired": bool(e.get("paired"))} for e in st.endpoints]}
        if st.running and served.pacer.error is None:
            try:
                out.update(served.pacer.call(lambda _module: module_tables(served)).result(timeout=1.0))
            except Exception:  # noqa: BLE001 - the loop ended meanwhile, or is far behind: next time
                pass
        out["walker"] = self._walker(i, append)
        return out

    def _walker(self, i: int, append: dict[str, list]) -> dict[str, Any]:
        truth, watch = self.truths[i], self.watches[i]
        sent = watch.take()
        walker: dict[str, Any] = {"steps": watch.steps, "counter": watch.counter, "missed": watch.missed,
                                  "truth": None, "sent": None, "apart": None}
        origin = self._origin[i]
        if origin is None and truth.known:
            origin = self._origin[i] = truth.start_pose()
        if sent:
            append[f"sent.{i}"] = [self._placed(origin, p)[:2] for p in sent]
        where = self._placed(origin, tuple(watch.pose[:3]))
        walker["sent"] = [where[0], where[1], -where[2]]
        k = truth.index()
        if k is not None:
            pos = truth.truth.pos
            stride = max(1, round(TRUTH_STEP_S * truth.truth.rate_hz))
            start = self._truth_next[i]
            if k >= start:
                ks = list(range(start, k + 1, stride))
                append[f"truth.{i}"] = [[float(pos[j, 0]), float(pos[j, 1])] for j in ks]
                self._truth_next[i] = ks[-1] + stride
            yaw = math.degrees(float(truth.truth.euler[k, 2])) % 360.0
            walker["truth"] = [float(pos[k, 0]), float(pos[k, 1]), -float(pos[k, 2]), yaw]
            walker["walking"] = truth.played.start is not None
            walker["apart"] = math.hypot(where[0] - pos[k, 0], where[1] - pos[k, 1])
        return walker

    @staticmethod
    def _placed(origin: tuple[np.ndarray, float] | None, p: tuple[float, float, float]) -> list[float]:
        """A module-frame position in the truth's frame (the foot's start and heading; none: as is)."""
        if origin is None:
            return [p[0], p[1], p[2]]
        start, yaw = origin
        c, s = math.cos(yaw), math.sin(yaw)
        return [float(start[0] + c * p[0] - s * p[1]), float(start[1] + s * p[0] + c * p[1]),
                float(start[2] + p[2])]


def open_panel(modules: Sequence[ServedModule], address: tuple[str, int], control: ControlServer | None,
               gps: GpsPtyEndpoint | None, with_control: bool, err: TextIO) -> EmulatorPanel:
    """``serve --web``: the panel of *modules* on *address*, started; its buttons run *control*'s
    lines if *with_control* (``--web-control``). Its URL, and a warning when it listens beyond this
    machine, go to *err*. OSError: the address cannot be had; RuntimeError: aiohttp is missing."""
    panel = EmulatorPanel(modules, address, control=control if with_control else None, gps=gps)
    url = panel.start()
    buttons = "" if with_control else " (fault buttons off: --web-control)"
    print(f"openshoe-emu serve: panel at {url}{buttons}", file=err, flush=True)
    if not is_loopback(address[0]):
        could = " and break the links" if with_control else ""
        print(f"openshoe-emu serve: the panel listens on {address[0]}, not only on this machine: whoever "
              f"reaches it can watch{could}", file=err, flush=True)
    return panel
