"""`openshoe-emu serve`: emulated modules in real time on a pty and/or TCP, for any host app.

One module (or ``--modules N``) runs paced to the wall clock (× ``--speed``):
each is a :class:`~firmware_sim.transports.pacer.Pacer`, and all of a process's
modules run in one loop and one thread (a :class:`~firmware_sim.transports.pacer.MultiPacer`,
so they do not fight over the GIL). Its Bluetooth interface (or
USB, ``--interface usb``) is reachable on a pty with a stable path (``--pty``)
and/or a TCP port (``--tcp``); ``--usb-pty``/``--usb-tcp`` also expose the
other interface. A pty and a TCP port on the same interface share its link
(:class:`~firmware_sim.transports.hub.HostHub`): the module's bytes go to every connected host.

When everything listens, exactly one line goes to stdout::

    READY bt-pty=/tmp/openshoe0 bt-tcp=127.0.0.1:40123 control=127.0.0.1:40124

(with ``--modules N`` every key gets the module's index: ``m0.bt-pty=…``).
Then a status line is kept up to date on stderr. ``--control`` opens a line
protocol on TCP to drive faults at run time (:data:`~firmware_sim.app.control.CONTROL_HELP`). SIGINT and
SIGTERM stop the loop, close the endpoints (removing the pty symlinks) and
exit with status 0.
"""

from __future__ import annotations

import argparse
import gc
import os
import selectors
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any, TextIO

from firmware_sim.links.link import Link, LinkFaults, make_link
from firmware_sim.mcu.module import ModuleConfig
from firmware_sim.mcu.port import IdealPort, Port
from firmware_sim.nav.firmware import build_module
from firmware_sim.sensors.playback import served_source
from firmware_sim.transports.factory import make_sensors
from firmware_sim.transports.hub import HostHub
from firmware_sim.transports.pacer import MultiPacer, Pacer
from firmware_sim.transports.pty_endpoint import PtyEndpoint
from firmware_sim.transports.rfc2217 import Rfc2217Endpoint
from firmware_sim.transports.tcp import TcpEndpoint

from .control import ControlServer
from .frame_trace import TraceWriter
from .served_module import ServedModule

# --------------------------------------------------------------------------- options

def _host_port(text: str, what: str) -> tuple[str, int]:
    """``PORT`` or ``HOST:PORT`` (127.0.0.1 by default; port 0 = pick a free one)."""
    host, _, port = text.rpartition(":")
    try:
        number = int(port)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{what}: expected [HOST:]PORT, got {text!r}") from None
    if not 0 <= number <= 65535:
        raise argparse.ArgumentTypeError(f"{what}: port {number} out of range")
    return (host or "127.0.0.1"), number


def tcp_address(text: str) -> tuple[str, int]:
    return _host_port(text, "--tcp")


def _probability(text: str) -> float:
    v = float(text)
    if not 0.0 <= v <= 1.0:
        raise argparse.ArgumentTypeError(f"expected a probability 0..1, got {text}")
    return v


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The options of ``openshoe-emu serve``."""
    g = p.add_argument_group("where hosts connect")
    g.add_argument("--interface", choices=["bt", "usb"], default="bt",
                   help="the interface --pty/--tcp expose (default bt, the one vendor apps use)")
    g.add_argument("--pty", metavar="PATH",
                   help="a pty with this stable path (a symlink), e.g. /tmp/openshoe0")
    g.add_argument("--tcp", metavar="[HOST:]PORT", type=tcp_address,
                   help="a TCP port (127.0.0.1 unless HOST given; 0 = pick a free port)")
    g.add_argument("--rfc2217", metavar="[HOST:]PORT", type=tcp_address,
                   help="an RFC 2217 port (pyserial rfc2217://HOST:PORT; 0 = pick a free port)")
    g.add_argument("--usb-pty", metavar="PATH", help="also expose the USB interface on this pty")
    g.add_argument("--usb-tcp", metavar="[HOST:]PORT", type=tcp_address,
                   help="also expose the USB interface on this TCP port")
    g.add_argument("--control", metavar="[HOST:]PORT", type=tcp_address,
                   help="runtime control channel (line commands: disconnect, reconnect, stall S, corrupt N)")
    g.add_argument("--modules", type=int, default=1, metavar="N",
                   help="run N modules, each on its own port(s): PATH0, PATH1 …; TCP PORT, PORT+1 … "
                   "(default 1)")
    m = p.add_argument_group("the module")
    src = m.add_mutually_exclusive_group()
    src.add_argument("--scenario", default="default",
                     help="motion scenario or recipe (default: the built-in route 'default'); it starts "
                     "when the module first reads its sensors (a host starts tracking), then stands still")
    src.add_argument("--replay", metavar="FILE", help="replay a recording (OpenShoe text or CSV) instead")
    m.add_argument("--seed", type=int, default=0, help="seed of the sensors and the link (default 0)")
    m.add_argument("--command-set", choices=["2014", "2015"], default="2015",
                   help="command numbering (default 2015; 2014 for old vendor apps)")
    m.add_argument("--speed", type=float, default=1.0,
                   help="module time per wall time (default 1 = real time; 0 = as fast as possible)")
    m.add_argument("--trace", metavar="FILE", help="write every frame in and out to FILE")
    f = p.add_argument_group("the link and its faults")
    f.add_argument("--link", choices=["bt", "usb", "ideal"],
                   help="link model of the exposed interface (default: bt for --interface bt, usb for usb)")
    f.add_argument("--loss", type=_probability, default=0.0,
                   help="per-byte loss probability, both directions")
    f.add_argument("--corrupt", type=_probability, default=0.0,
                   help="per-byte corruption probability, both directions")
    f.add_argument("--stall-rate", type=float, default=0.0, metavar="HZ",
                   help="random stalls per second (each 0.1–2 s)")
    f.add_argument("--disconnect-rate", type=float, default=0.0, metavar="HZ",
                   help="random disconnects per second (back after 0.5–2 s)")
    o = p.add_argument_group("running")
    o.add_argument("--duration", type=float, metavar="S", help="stop after S wall-clock seconds")
    o.add_argument("--status-interval", type=float, default=1.0, metavar="S",
                   help="seconds between status lines on stderr (0 = none; default 1)")
    o.add_argument("--frame-ms", type=float, metavar="MS",
                   help="module time each module runs per wake-up, back to back (default: one tick "
                        f"for one module, {MANY_MODULES_FRAME_MS:g} ms for several); output leaves "
                        "at most one frame later, commands are answered at once")
    o.add_argument("--overrun-ms", type=float, metavar="MS",
                   help="a frame starting later than this counts an overrun (default: so late that a "
                        "host could see it: the link's lookahead + latency - one frame, 35 ms on "
                        "Bluetooth with 4-ms frames; one frame on USB or an ideal link)")


#: The default frame of a process with several modules (see --frame-ms, docs/design.md).
MANY_MODULES_FRAME_MS = 4.0


def frame_ticks(args: argparse.Namespace, rate_hz: float) -> int:
    """Ticks per frame from ``--frame-ms`` (at least one tick)."""
    ms = args.frame_ms
    if ms is None:
        ms = MANY_MODULES_FRAME_MS if args.modules > 1 else 0.0
    return max(1, round(ms * rate_hz / 1000.0))


# --------------------------------------------------------------------------- building


def _faults(args: argparse.Namespace) -> LinkFaults | None:
    if not (args.loss or args.corrupt or args.stall_rate or args.disconnect_rate):
        return None
    return LinkFaults.both(byte_loss=args.loss, corrupt=args.corrupt, stall_rate_hz=args.stall_rate,
                           disconnect_rate_hz=args.disconnect_rate)


def _indexed_path(path: str, index: int, n: int) -> str:
    return path if n == 1 else f"{path}{index}"


def _indexed_port(addr: tuple[str, int] | None, index: int) -> tuple[str, int] | None:
    if addr is None:
        return None
    host, port = addr
    return host, (port + index if port else 0)


def build_served_module(args: argparse.Namespace, index: int) -> ServedModule:
    """Module *index* of ``serve``: sensors, links, endpoints on its interfaces, and a pacer."""
    seed = args.seed + index
    rate_hz = 1000.0
    if args.replay:
        from firmware_sim.sensors.replay import ReplaySource

        recording = ReplaySource.from_file(args.replay)
        rate_hz = recording.rate_hz
        sensors = served_source(recording)
    else:
        sensors = make_sensors(args.scenario, seed, rate_hz)
    config = ModuleConfig(rate_hz=rate_hz, command_set=args.command_set, trace=bool(args.trace))
    main_kind = args.interface
    other = "usb" if main_kind == "bt" else "bt"
    links: dict[str, Link] = {main_kind: make_link(args.link or main_kind, seed=seed, faults=_faults(args))}
    n = args.modules
    wants = {main_kind: (args.pty, args.tcp, args.rfc2217), other: (None, None, None)}
    if args.usb_pty or args.usb_tcp:
        if main_kind == "usb":
            raise SystemExit("openshoe-emu serve: --usb-pty/--usb-tcp need --interface bt")
        links["usb"] = make_link("usb", seed=seed)
        wants["usb"] = (args.usb_pty, args.usb_tcp, None)
    ports: dict[str, Port] = {k: links.get(k) or IdealPort(connected=False) for k in ("bt", "usb")}
    module = build_module(config, sensors, usb_port=ports["usb"], bt_port=ports["bt"])
    endpoints: list[Any] = []
    ready: list[tuple[str, str]] = []
    prefix = "" if n == 1 else f"m{index}."
    try:
        for kind, (pty_path, tcp_addr, rfc_addr) in wants.items():
            if kind not in links:
                continue
            shared = sum(x is not None and x != "" for x in (pty_path, tcp_addr, rfc_addr)) > 1
            hub = HostHub(links[kind]) if shared else None
            if pty_path:
                path = _indexed_path(pty_path, index, n)
                ep = PtyEndpoint(hub.tap("pty") if hub else links[kind], path)
                endpoints.append(ep)
                ready.append((f"{prefix}{kind}-pty", str(Path(path))))
            if tcp_addr:
                host, port = _indexed_port(tcp_addr, index)
                ep = TcpEndpoint(hub.tap("tcp") if hub else links[kind], host, port)
                endpoints.append(ep)
                ready.append((f"{prefix}{kind}-tcp", f"{ep.address[0]}:{ep.address[1]}"))
            if rfc_addr:
                host, port = _indexed_port(rfc_addr, index)
                ep = Rfc2217Endpoint(hub.tap("rfc2217") if hub else links[kind], host, port)
                endpoints.append(ep)
                ready.append((f"{prefix}{kind}-rfc2217", f"{ep.address[0]}:{ep.address[1]}"))
    except BaseException:
        for ep in endpoints:
            ep.close()
        raise
    pacer = Pacer(module, endpoints, speed=args.speed)
    return ServedModule(index, module, links, endpoints, pacer, ready)


# --------------------------------------------------------------------------- running


def serve(args: argparse.Namespace, out: TextIO = sys.stdout, err: TextIO = sys.stderr,
          stop: threading.Event | None = None) -> int:
    """Run ``serve`` until *stop* is set, SIGINT/SIGTERM, or ``--duration``; returns the exit status."""
    if not (args.pty or args.tcp or args.rfc2217 or args.usb_pty or args.usb_tcp):
        print("openshoe-emu serve: say where hosts connect: --pty PATH and/or --tcp [HOST:]PORT", file=err)
        return 2
    if args.modules < 1:
        print("openshoe-emu serve: --modules must be >= 1", file=err)
        return 2
    if args.speed < 0:
        print("openshoe-emu serve: --speed must be >= 0", file=err)
        return 2
    for name in ("frame_ms", "overrun_ms"):
        value = getattr(args, name)
        if value is not None and not value >= 0:
            print(f"openshoe-emu serve: --{name.replace('_', '-')} must be >= 0", file=err)
            return 2
    stop = stop if stop is not None else threading.Event()
    modules: list[ServedModule] = []
    loop: MultiPacer | None = None
    control: ControlServer | None = None
    trace: TraceWriter | None = None
    old_handlers = {}
    if threading.current_thread() is threading.main_thread():
        for sig in (signal.SIGINT, signal.SIGTERM):
            old_handlers[sig] = signal.signal(sig, lambda *_: stop.set())
    sel = selectors.DefaultSelector()
    status = 0
    try:
        try:
            for i in range(args.modules):
                modules.append(build_served_module(args, i))
            if args.control:
                control = ControlServer(modules, *args.control)
                control.register(sel)
            if args.trace:
                trace = TraceWriter(args.trace, modules)
        except (OSError, ValueError) as exc:
            print(f"openshoe-emu serve: {exc}", file=err)
            return 1
        rate_hz = modules[0].module.clock.rate_hz
        loop = MultiPacer([m.pacer for m in modules], frame_ticks=frame_ticks(args, rate_hz),
                          overrun_s=None if args.overrun_ms is None else args.overrun_ms / 1000.0)
        loop.prepare(announce=lambda text: print(text, file=err, flush=True))
        gc.collect()
        gc.freeze()  # what exists now is never scanned again: no long collections in the loop
        # the status line and the control channel run in this thread: hand the interpreter
        # back to the loop within 0.2 ms, not the default 5 ms (a dozen missed ticks)
        sys.setswitchinterval(2e-4)
        loop.start()
        fields = [f"{k}={v}" for m in modules for k, v in m.ready]
        if control is not None:
            fields.append(f"control={control.address[0]}:{control.address[1]}")
        print("READY " + " ".join(fields), file=out, flush=True)
        t_end = None if args.duration is None else time.monotonic() + args.duration
        next_status = time.monotonic() + args.status_interval if args.status_interval > 0 else None
        is_tty = getattr(err, "isatty", lambda: False)()
        while not stop.is_set():
            now = time.monotonic()
            if t_end is not None and now >= t_end:
                break
            broken = [m for m in modules if m.pacer.error is not None]
            if broken:
                for m in broken:
                    print(f"\nopenshoe-emu serve: module {m.index} stopped: {m.pacer.error!r}", file=err)
                status = 1
                break
            for key, _ in sel.select(timeout=0.1) if sel.get_map() else []:
                key.data.handle(sel, key.fileobj)
            if not sel.get_map():
                stop.wait(0.1)
            if next_status is not None and time.monotonic() >= next_status:
                next_status += args.status_interval
                text = " || ".join(f"m{m.index} {m.status_line()}" if len(modules) > 1 else m.status_line()
                                   for m in modules)
                print(("\r" + text) if is_tty else text, end="" if is_tty else "\n", file=err, flush=True)
            if trace is not None:
                trace.flush()
    finally:
        if loop is not None:
            try:
                loop.stop()
            except RuntimeError as exc:
                print(f"openshoe-emu serve: {exc}", file=err)
                status = 1
        for m in modules:
            for ep in m.endpoints:  # the pacer closes them when its loop ends; never started → here
                ep.close()
        if control is not None:
            control.close()
        if trace is not None:
            trace.flush(stopped=True)
            trace.close()
        sel.close()
        for sig, h in old_handlers.items():
            signal.signal(sig, h)
    print("\nSTOPPED" if getattr(err, "isatty", lambda: False)() else "STOPPED", file=err, flush=True)
    return status


def main(args: argparse.Namespace) -> int:
    """Entry point of the ``serve`` subcommand (argparse namespace from :func:`add_arguments`)."""
    return serve(args)


# --------------------------------------------------------------------------- for host-app tests


class ServeProcess:
    """``openshoe-emu serve`` as a subprocess, ready to use (see :func:`spawn`).

    ``ready`` maps the READY line's keys to values (``{"bt-pty": "/tmp/x", …}``).
    Use as a context manager; :meth:`stop` sends SIGTERM and returns the exit status.
    """

    def __init__(self, proc: subprocess.Popen, ready: dict[str, str]):
        self.proc = proc
        self.ready = ready

    def stop(self, timeout: float = 10.0) -> int:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        if self.proc.stdout is not None:
            self.proc.stdout.close()
        return self.proc.returncode

    def __enter__(self) -> ServeProcess:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def __repr__(self) -> str:
        return f"ServeProcess(pid {self.proc.pid}, {self.ready})"


def parse_ready(line: str) -> dict[str, str]:
    """``READY k=v k=v`` → {k: v}; ValueError for anything else."""
    words = line.split()
    if not words or words[0] != "READY":
        raise ValueError(f"not a READY line: {line!r}")
    return dict(w.split("=", 1) for w in words[1:])


def spawn(*serve_args: str, timeout: float = 20.0, stderr: Any = subprocess.DEVNULL,
          python: str = sys.executable, env: dict[str, str] | None = None) -> ServeProcess:
    """Start ``openshoe-emu serve *serve_args*`` and wait (at most *timeout* s) for its READY line.

    *env*: the process's environment (default: this one's)."""
    proc = subprocess.Popen([python, "-m", "firmware_sim.app.cli", "serve", *serve_args],
                            stdout=subprocess.PIPE, stderr=stderr, stdin=subprocess.DEVNULL, env=env)
    assert proc.stdout is not None
    fd = proc.stdout.fileno()
    os.set_blocking(fd, False)
    buf = b""
    deadline = time.monotonic() + timeout
    with selectors.DefaultSelector() as sel:
        sel.register(fd, selectors.EVENT_READ)
        while b"\n" not in buf:
            left = deadline - time.monotonic()
            if left <= 0 or proc.poll() is not None:
                proc.kill()
                proc.wait()
                why = f"exited with {proc.returncode}" if left > 0 else f"no READY line within {timeout} s"
                raise RuntimeError(f"openshoe-emu serve {' '.join(serve_args)}: {why}; stdout {buf!r}")
            if sel.select(min(left, 0.2)):
                chunk = os.read(fd, 4096)
                buf += chunk
    os.set_blocking(fd, True)
    return ServeProcess(proc, parse_ready(buf.split(b"\n", 1)[0].decode()))
