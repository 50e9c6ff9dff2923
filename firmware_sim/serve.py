"""`openshoe-emu serve`: emulated modules in real time on a pty and/or TCP, for any host app.

One module (or ``--modules N``) runs paced to the wall clock (× ``--speed``)
by :class:`~firmware_sim.transports.pacer.Pacer`; its Bluetooth interface (or
USB, ``--interface usb``) is reachable on a pty with a stable path (``--pty``)
and/or a TCP port (``--tcp``); ``--usb-pty``/``--usb-tcp`` also expose the
other interface. A pty and a TCP port on the same interface share its link
(:class:`HostHub`): the module's bytes go to every connected host.

When everything listens, exactly one line goes to stdout::

    READY bt-pty=/tmp/openshoe0 bt-tcp=127.0.0.1:40123 control=127.0.0.1:40124

(with ``--modules N`` every key gets the module's index: ``m0.bt-pty=…``).
Then a status line is kept up to date on stderr. ``--control`` opens a line
protocol on TCP to drive faults at run time (:data:`CONTROL_HELP`). SIGINT and
SIGTERM stop the loop, close the endpoints (removing the pty symlinks) and
exit with status 0.
"""

from __future__ import annotations

import argparse
import os
import selectors
import signal
import socket
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

from .link import Link, LinkFaults, make_link
from .module import Module, ModuleConfig
from .port import IdealPort, Port
from .sensors.playback import served_source
from .transports.factory import make_sensors
from .transports.pacer import Pacer
from .transports.pty import PtyEndpoint
from .transports.tcp import TcpEndpoint

CONTROL_HELP = """\
commands (one per line; prefix with @I to address module I only, e.g. "@1 disconnect"):
  disconnect       the link goes down (bytes in flight are lost); the host stays attached
  reconnect        the link comes back
  stall S          deliver nothing for S seconds of module time, both directions
  corrupt N        corrupt the next N bytes sent to the host
  drop N           lose the next N bytes sent to the host
  status           one status line per module
  help             this text
  quit             close this control connection"""


# --------------------------------------------------------------------------- sharing one link


class HostTap:
    """One endpoint's view of a shared link: the host-facing half of :class:`Port`.

    The module's bytes are copied to every tap whose host is connected; host
    bytes from any tap go into the link. The link is connected while at least
    one tap is.
    """

    def __init__(self, hub: HostHub, name: str):
        self.hub = hub
        self.name = name
        self.connected = False
        self._buf = bytearray()

    def host_write(self, data: bytes) -> int:
        return self.hub.port.host_write(data)

    def host_read(self, max_n: int = -1) -> bytes:
        self.hub.distribute()
        if max_n < 0 or max_n >= len(self._buf):
            out = bytes(self._buf)
            self._buf.clear()
        else:
            out = bytes(self._buf[:max_n])
            del self._buf[:max_n]
        return out

    def connect(self) -> None:
        self.hub.distribute()  # bytes sent before this host came belong to the others
        self.connected = True
        self._buf.clear()
        self.hub.update()

    def disconnect(self) -> None:
        self.connected = False
        self._buf.clear()
        self.hub.update()

    def __repr__(self) -> str:
        return f"HostTap({self.name}, {'connected' if self.connected else 'no host'}, {len(self._buf)} B)"


class HostHub:
    """Fans one link's host side out to several endpoints (a pty and a TCP port)."""

    def __init__(self, port: Port):
        self.port = port
        self.taps: list[HostTap] = []
        if port.connected:
            port.disconnect()

    def tap(self, name: str) -> HostTap:
        t = HostTap(self, name)
        self.taps.append(t)
        return t

    def distribute(self) -> None:
        data = self.port.host_read()
        if data:
            for t in self.taps:
                if t.connected:
                    t._buf += data

    def update(self) -> None:
        want = any(t.connected for t in self.taps)
        if want and not self.port.connected:
            self.port.connect()
        elif not want and self.port.connected:
            self.port.disconnect()


# --------------------------------------------------------------------------- RFC 2217


class _EmulatedLineSettings:
    """What an RFC 2217 client may read or set on the "serial port": a UART at 115200 8N1.

    The emulated link ignores the settings (its rate is the link model's); CD
    is the link's connected line.
    """

    def __init__(self, port: Port):
        self._port = port
        self.baudrate = 115200
        self.bytesize = 8
        self.parity = "N"
        self.stopbits = 1
        self.xonxoff = False
        self.rtscts = False
        self.break_condition = False
        self.dtr = True
        self.rts = True
        self.cts = True
        self.dsr = True
        self.ri = False

    @property
    def cd(self) -> bool:
        return bool(self._port.connected)

    def reset_input_buffer(self) -> None:
        pass

    def reset_output_buffer(self) -> None:
        pass


class Rfc2217Endpoint:
    """Serve *port* over RFC 2217 (telnet COM-port control) to one TCP host at a time.

    Hosts open it with pyserial as ``rfc2217://HOST:PORT``. Telnet negotiation
    and escaping are pyserial's :class:`serial.rfc2217.PortManager`.
    """

    def __init__(self, port: Port, host: str = "127.0.0.1", tcp_port: int = 0):
        self.port = port
        self.server = socket.create_server((host, tcp_port), backlog=4)
        self.server.setblocking(False)
        self.address: tuple[str, int] = self.server.getsockname()[:2]
        self.client: socket.socket | None = None
        self.manager: Any = None
        self._out = bytearray()
        self.connects = 0
        self.closed = False
        if port.connected:
            port.disconnect()

    @property
    def paired(self) -> bool:
        return self.client is not None

    @property
    def fds(self) -> tuple[int, ...]:
        if self.closed:
            return ()
        return (self.server.fileno(),) + ((self.client.fileno(),) if self.client is not None else ())

    def write(self, data: bytes) -> None:
        """The PortManager's "connection": bytes for the network."""
        self._out += data

    def pump(self) -> None:
        if self.closed:
            return
        self._accept()
        c = self.client
        if c is None:
            return
        while True:
            try:
                data = c.recv(4096)
            except (BlockingIOError, InterruptedError):
                break
            except OSError:
                self._hangup()
                return
            if not data:
                self._hangup()
                return
            payload = b"".join(self.manager.filter(data))
            if payload:
                self.port.host_write(payload)
        out = self.port.host_read()
        if out:
            self._out += b"".join(self.manager.escape(out))
        if self._out:
            try:
                sent = c.send(self._out)
            except (BlockingIOError, InterruptedError):
                sent = 0
            except OSError:
                self._hangup()
                return
            del self._out[:sent]

    def _accept(self) -> None:
        from serial.rfc2217 import PortManager

        while True:
            try:
                sock, _ = self.server.accept()
            except (BlockingIOError, InterruptedError, OSError):
                return
            if self.client is not None:
                sock.close()
                continue
            sock.setblocking(False)
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            self.client = sock
            self._out.clear()
            self.port.host_read()
            self.port.connect()
            self.connects += 1
            self.manager = PortManager(_EmulatedLineSettings(self.port), self)

    def _hangup(self) -> None:
        if self.client is not None:
            self.client.close()
            self.client = None
        self._out.clear()
        self.port.disconnect()

    def close(self) -> None:
        if self.closed:
            return
        self._hangup()
        self.server.close()
        self.closed = True

    def status(self) -> dict[str, object]:
        return {"kind": "rfc2217", "address": f"{self.address[0]}:{self.address[1]}", "paired": self.paired,
                "connects": self.connects}

    def __repr__(self) -> str:
        return f"Rfc2217Endpoint({self.address[0]}:{self.address[1]}, {'host' if self.paired else 'no host'})"


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


# --------------------------------------------------------------------------- building


@dataclass
class ServedModule:
    """One running module with its links, endpoints and pacer."""

    index: int
    module: Module
    links: dict[str, Link]
    endpoints: list[Any]
    pacer: Pacer
    ready: list[tuple[str, str]] = field(default_factory=list)

    def status_line(self) -> str:
        return self.pacer.status().line()


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


def build_module(args: argparse.Namespace, index: int) -> ServedModule:
    """Module *index* of ``serve``: sensors, links, endpoints on its interfaces, and a pacer."""
    seed = args.seed + index
    rate_hz = 1000.0
    if args.replay:
        from .sensors.replay import ReplaySource

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
    module = Module(config, sensors, usb_port=ports["usb"], bt_port=ports["bt"])
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


# --------------------------------------------------------------------------- control channel


class ControlServer:
    """Line commands over TCP that change the running modules' links (:data:`CONTROL_HELP`)."""

    def __init__(self, modules: list[ServedModule], host: str, port: int):
        self.modules = modules
        self.server = socket.create_server((host, port), backlog=4)
        self.server.setblocking(False)
        self.address = self.server.getsockname()[:2]
        self.clients: dict[socket.socket, bytearray] = {}

    def register(self, sel: selectors.BaseSelector) -> None:
        sel.register(self.server, selectors.EVENT_READ, self)

    def handle(self, sel: selectors.BaseSelector, sock: socket.socket) -> None:
        if sock is self.server:
            try:
                c, _ = self.server.accept()
            except OSError:
                return
            c.setblocking(True)
            self.clients[c] = bytearray()
            sel.register(c, selectors.EVENT_READ, self)
            return
        try:
            data = sock.recv(4096)
        except OSError:
            data = b""
        if not data:
            self._close(sel, sock)
            return
        buf = self.clients[sock]
        buf += data
        while b"\n" in buf:
            line, _, rest = bytes(buf).partition(b"\n")
            buf[:] = rest
            reply = self.execute(line.decode("utf-8", "replace").strip())
            if reply is None:
                self._close(sel, sock)
                return
            try:
                sock.sendall((reply + "\n").encode())
            except OSError:
                self._close(sel, sock)
                return

    def _close(self, sel: selectors.BaseSelector, sock: socket.socket) -> None:
        try:
            sel.unregister(sock)
        except (KeyError, ValueError):
            pass
        self.clients.pop(sock, None)
        sock.close()

    def execute(self, line: str) -> str | None:
        """Run one command line; the reply ("OK …" / "ERR …"), None to close the connection."""
        if not line:
            return "ERR empty command; try help"
        targets = self.modules
        words = line.split()
        if words[0].startswith("@"):
            try:
                i = int(words[0][1:])
                targets = [self.modules[i]]
            except (ValueError, IndexError):
                return f"ERR no module {words[0]} (0..{len(self.modules) - 1})"
            words = words[1:]
            if not words:
                return "ERR missing command after the module"
        cmd, rest = words[0].lower(), words[1:]
        if cmd == "help":
            return CONTROL_HELP + "\nOK"
        if cmd == "quit":
            return None
        if cmd == "status":
            return "\n".join(f"m{m.index} {m.status_line()}" for m in targets) + "\nOK"
        try:
            action = self._action(cmd, rest)
        except ValueError as exc:
            return f"ERR {exc}"
        for m in targets:
            for link in m.links.values():
                m.pacer.call(lambda _mod, link=link: action(link)).result(timeout=5.0)
        return f"OK {' '.join(words)}"

    @staticmethod
    def _action(cmd: str, rest: list[str]):
        def number(kind: type) -> Any:
            if len(rest) != 1:
                raise ValueError(f"{cmd} takes one number")
            try:
                v = kind(rest[0])
            except ValueError:
                raise ValueError(f"{cmd}: {rest[0]!r} is not a number") from None
            if v < 0:
                raise ValueError(f"{cmd}: must be >= 0")
            return v

        if cmd == "disconnect" and not rest:
            return lambda link: link.disconnect()
        if cmd == "reconnect" and not rest:
            return lambda link: link.reconnect()
        if cmd == "stall":
            s = number(float)
            return lambda link: link.stall(s)
        if cmd == "corrupt":
            n = number(int)
            return lambda link: link.corrupt_next(n)
        if cmd == "drop":
            n = number(int)
            return lambda link: link.drop_next(n)
        raise ValueError(f"unknown command {' '.join([cmd, *rest])!r}; try help")

    def close(self) -> None:
        for c in list(self.clients):
            c.close()
        self.clients.clear()
        self.server.close()


# --------------------------------------------------------------------------- trace


class TraceWriter:
    """Moves each module's frame trace to a text file: ``cycles module interface dir note hex``."""

    def __init__(self, path: str, modules: list[ServedModule]):
        self.file = open(path, "w", encoding="utf-8")  # noqa: SIM115 - closed in close()
        self.modules = modules
        self.file.write("# cycles module interface direction note bytes\n")

    def flush(self, stopped: bool = False) -> None:
        """Write the frames traced so far; *stopped*: the pacers have ended, take them directly."""
        for m in self.modules:
            def swap(mod: Module) -> list:
                entries, mod.trace = mod.trace or [], []
                return entries

            if stopped:
                entries = swap(m.module)
            else:
                try:
                    entries = m.pacer.call(swap).result(timeout=5.0)
                except Exception:  # noqa: BLE001 - the pacer has stopped: take what is left directly
                    entries = swap(m.module)
            for e in entries:
                self.file.write(f"{e.cycles} m{m.index} {e.interface} {e.direction} {e.note} "
                                f"{e.data.hex(' ').upper()}\n")
        self.file.flush()

    def close(self) -> None:
        self.file.close()


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
    stop = stop if stop is not None else threading.Event()
    modules: list[ServedModule] = []
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
                modules.append(build_module(args, i))
            if args.control:
                control = ControlServer(modules, *args.control)
                control.register(sel)
            if args.trace:
                trace = TraceWriter(args.trace, modules)
        except (OSError, ValueError) as exc:
            print(f"openshoe-emu serve: {exc}", file=err)
            return 1
        for m in modules:
            m.pacer.start()
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
        for m in modules:
            try:
                m.pacer.stop()
            except RuntimeError as exc:
                print(f"openshoe-emu serve: {exc}", file=err)
                status = 1
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
          python: str = sys.executable) -> ServeProcess:
    """Start ``openshoe-emu serve *serve_args*`` and wait (at most *timeout* s) for its READY line."""
    proc = subprocess.Popen([python, "-m", "firmware_sim.cli", "serve", *serve_args],
                            stdout=subprocess.PIPE, stderr=stderr, stdin=subprocess.DEVNULL)
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
