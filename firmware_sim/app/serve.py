"""`openshoe-emu serve`: emulated modules in real time on a pty and/or TCP, for any host app.

One module (or ``--modules N``, or ``--feet 2``: one on each foot of a walker) runs
paced to the wall clock (× ``--speed``):
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

``--feet 2`` walks ``--scenario`` with one walker: the left and the right foot each
wear a module with its own seed, errors and MCU serial number
(:mod:`firmware_sim.sensors.feet`), on ``PATH-left`` and ``PATH-right`` and TCP
``PORT`` and ``PORT + 1``, both in the one loop (one clock); the keys say which foot::

    READY left.bt-pty=/tmp/shoe-left right.bt-pty=/tmp/shoe-right

``--gps-pty PATH`` (with ``--scenario``) adds a simulated GPS receiver on the walker (on the body
with ``--feet 2``): GGA and RMC at 1 Hz on a pty of its own, written as the module's clock reaches
each fix (:mod:`.served_gps`; ``--origin``, ``--gps-outage`` as for a batch replay's ``--gps``);
its key is ``gps-pty``::

    READY bt-pty=/tmp/shoe gps-pty=/tmp/gps

Then a status line is kept up to date on stderr (with the receiver: the sentences it wrote and
those it dropped, with no reader or one that does not read). ``--control`` opens a line
protocol on TCP to drive faults at run time (:data:`~firmware_sim.app.control.CONTROL_HELP`). SIGINT and
SIGTERM stop the loop, close the endpoints (removing the pty symlinks) and
exit with status 0.

``--web [HOST:]PORT`` serves the modules' live panel in a browser (:mod:`.web.panel`: each module's
state, loop and link, the walker's truth beside what the module sent), on 127.0.0.1 unless a HOST is
given; its key is ``web``. ``--web-control`` turns its fault buttons on: they run the control
channel's lines (one is opened on 127.0.0.1 if ``--control`` is not given).

The options become :class:`ServeSettings` at the command line's edge
(:func:`settings_from_args`; a refused value exits with status 2 and says which
option); each module, its links and endpoints are built by
:func:`firmware_sim.transports.factory.build`.
"""

from __future__ import annotations

import argparse
import gc
import math
import os
import selectors
import signal
import sys
import threading
import time
from dataclasses import dataclass, field, replace
from typing import Any, TextIO

from firmware_sim.transports.factory import Address, EmulatorSettings, SettingsError, build
from firmware_sim.transports.pacer import MultiPacer, Pacer
from firmware_sim.transports.pacer.priority import allowed_cpus, check_level, pin_to_cpu, raise_priority
from hostlib.web.address import bind_refusal, web_address

from .batch import (
    MODULE_HELP,
    add_receiver_arguments,
    add_stance_sway_argument,
    module_number,
    seed_number,
    speed_factor,
)
from .control import ControlServer
from .frame_trace import TraceWriter
from .serve_process import ServeProcess, parse_ready, spawn
from .served_gps import GpsPtyEndpoint, GpsSettings, gps_settings, open_gps_pty
from .served_module import ServedModule

__all__ = ["ServeProcess", "ServeSettings", "add_arguments", "main", "parse_ready", "serve",
           "settings_from_args", "spawn"]

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
    g.add_argument("--feet", type=int, choices=(1, 2), default=1,
                   help="2: a module on each foot of one walker walking --scenario (each its own seed, "
                        "errors and serial number; --module N: modules 2N and 2N+1), on PATH-left and "
                        "PATH-right, TCP PORT and PORT+1; READY keys left.… and right.… (default 1)")
    m = p.add_argument_group("the module")
    src = m.add_mutually_exclusive_group()
    src.add_argument("--scenario", default=None,
                     help="motion scenario or recipe (default: the built-in route 'default'); it starts "
                     "when the module first reads its sensors (a host starts tracking), then stands still")
    src.add_argument("--replay", metavar="FILE", help="replay a recording (OpenShoe text or CSV) instead")
    m.add_argument("--seed", type=seed_number, default=0, help="seed of the sensors and the link (default 0)")
    m.add_argument("--module", type=module_number, metavar="N", default=None,
                   help=MODULE_HELP + "; with --modules K, module i is N + i")
    add_stance_sway_argument(m)
    m.add_argument("--command-set", choices=["2014", "2015"], default="2015",
                   help="command numbering (default 2015; 2014 for old vendor apps)")
    m.add_argument("--speed", type=speed_factor, default=1.0,
                   help="module time per wall time (default 1 = real time; 0 or inf = as fast as possible)")
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
    gps = p.add_argument_group("a GPS receiver on the walker (with --scenario)")
    gps.add_argument("--gps-pty", metavar="PATH",
                     help="a simulated GPS receiver on the walker (--feet 2: on the body) on a pty of its "
                          "own: GGA and RMC at 1 Hz, as replay's --gps writes them, each when the module's "
                          "clock reaches it")
    add_receiver_arguments(gps)
    w = p.add_argument_group("a live panel in a browser")
    w.add_argument("--web", metavar="[HOST:]PORT", type=web_address,
                   help="serve the modules' live panel (state, loop, link, the walker's truth beside what "
                        "each module sent) on this port, on 127.0.0.1 unless HOST is given (0: a free port); "
                        "READY names it (web=HOST:PORT); needs aiohttp (the web extra)")
    w.add_argument("--web-control", action="store_true",
                   help="turn the panel's fault buttons on (disconnect, reconnect, stall, corrupt, drop per "
                        "module): they run the control channel's commands (without --control, one is opened "
                        "on 127.0.0.1 and named in READY)")
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
    o.add_argument("--rt-priority", type=_rt_level, metavar="LEVEL",
                   help="run the modules' loop and the control channel under the real-time policy "
                        "SCHED_FIFO at LEVEL (1-99), ahead of every ordinary process: frames on time on a "
                        "busy machine; needs root or ulimit -r >= LEVEL, else said and run at the ordinary "
                        "priority (default: ordinary; never with --speed 0)")
    o.add_argument("--cpu", type=_cpu_number, metavar="N",
                   help="keep the process on CPU N (0 = the first): with --rt-priority, one serve "
                        "process per CPU, so that no two real-time loops fill one CPU (the kernel then "
                        "stops both for 50 ms to run the other processes; default: any CPU)")


def _rt_level(text: str) -> int:
    try:
        level = int(text)
        check_level(level)
    except ValueError:
        raise argparse.ArgumentTypeError(f"a real-time level from 1 to 99, not {text!r}") from None
    return level


def _cpu_number(text: str) -> int:
    allowed = allowed_cpus()
    try:
        cpu = int(text)
    except ValueError:
        cpu = -1
    if cpu not in allowed:
        cpus = ", ".join(map(str, sorted(allowed)))
        raise argparse.ArgumentTypeError(f"a CPU this process may run on ({cpus}), not {text!r}")
    return cpu


#: The default frame of a process with several modules (see --frame-ms, docs/design.md).
MANY_MODULES_FRAME_MS = 4.0
#: The most modules one ``serve`` runs (all in one loop and one thread; run more processes for more).
MAX_MODULES = 64
#: Modules per phase of the frame at most, advanced in one call (:mod:`~firmware_sim.nav.lockstep`):
#: all of them, one wake-up a frame. Four phases of 12-13 (at most 16 a phase) cost 8.7-8.9 µs of CPU
#: per module and tick, one phase of 50 6.3-6.9 (each wake-up after a sleep starts on cold caches).
GROUP_MODULES = MAX_MODULES
#: The longest frame a module runs per wake-up [ms] (--frame-ms).
MAX_FRAME_MS = 1000.0


def _path_refusal(args: argparse.Namespace) -> None:
    """Refuse a pty's stable path that is a directory or a file of its own (the symlink made there
    would replace it, and be removed at the end), and a trace file that could not be written
    (SettingsError naming the option)."""
    from hostlib.inputs import output_refusal

    for name in ("pty", "usb_pty", "gps_pty"):
        path = getattr(args, name, None)
        if path and os.path.lexists(path) and not os.path.islink(path):
            what = "a directory" if os.path.isdir(path) else "a file"
            raise SettingsError("{} " + _braces(path) + f" is {what}: a pty's path is a symlink serve makes "
                                "(and removes at the end); name a path where there is nothing", name)
    refusal = output_refusal(getattr(args, "trace", None), "{}")
    if refusal is not None:
        raise SettingsError(_braces(refusal).replace("{{}}", "{}", 1), "trace")


def _braces(text: str) -> str:
    """*text* safe inside a SettingsError template."""
    return str(text).replace("{", "{{").replace("}", "}}")


# --------------------------------------------------------------------------- settings


@dataclass(frozen=True)
class ServeSettings:
    """What ``serve`` runs: its modules and where hosts connect (*emulator*), and how it runs.

    Checked when made (:class:`~firmware_sim.transports.factory.SettingsError`). *trace*: a
    file for every frame in and out (the modules record frames only then). *frame_ms*,
    *overrun_ms*, *rt_priority*, *cpu*: see ``--frame-ms``, ``--overrun-ms``, ``--rt-priority``, ``--cpu``
    (None: the default).
    """

    emulator: EmulatorSettings
    control: Address | None = None
    trace: str = ""
    duration: float | None = None
    status_interval: float = 1.0
    frame_ms: float | None = None
    overrun_ms: float | None = None
    gps: GpsSettings | None = None  #: a GPS receiver on the walker (:mod:`.served_gps`)
    web: Address | None = None  #: where the live panel listens (:mod:`.web.panel`; None: no panel)
    web_control: bool = False  #: the panel's fault buttons on (through the control channel)
    rt_priority: int | None = None
    cpu: int | None = None

    def __post_init__(self) -> None:
        if not self.emulator.endpoint_requests():
            raise SettingsError("say where hosts connect: {} PATH and/or {} [HOST:]PORT", "pty", "tcp")
        if self.gps is not None and self.emulator.replay:
            raise SettingsError("{} follows a simulated walk: it goes with {} NAME, not {} FILE", "gps_pty",
                                "scenario", "replay")
        if self.gps is not None and self.emulator.modules > 1:
            raise SettingsError("{} is on one walker: not with {} N (a walker's two feet: {} 2)", "gps_pty",
                                "modules", "feet")
        if self.web_control and self.web is None:
            raise SettingsError("{} turns the buttons of the panel on: it goes with {} [HOST:]PORT",
                                "web_control", "web")
        for name in ("frame_ms", "overrun_ms"):
            value = getattr(self, name)
            if value is not None and not value >= 0:
                raise SettingsError("{} must be >= 0", name, got=value)
            if value is not None and not value <= (MAX_FRAME_MS if name == "frame_ms" else 1e9):
                most = f", at most {MAX_FRAME_MS:g}" if name == "frame_ms" else ""
                raise SettingsError("{} must be a finite number of milliseconds" + most, name, got=value)
        if self.emulator.modules > MAX_MODULES:
            raise SettingsError("{} must be <= " + f"{MAX_MODULES} (one process's loop paces them all; run "
                                "more processes for more)", "modules", got=self.emulator.modules)
        if self.duration is not None and not (math.isfinite(self.duration) and self.duration > 0):
            raise SettingsError("{} is a number of seconds > 0 (without it: until SIGINT or SIGTERM)",
                                "duration", got=self.duration)
        if not (math.isfinite(self.status_interval) and self.status_interval >= 0):
            raise SettingsError("{} is a number of seconds >= 0 (0: no status line)", "status_interval",
                                got=self.status_interval)
        try:
            check_level(self.rt_priority)
        except ValueError:
            raise SettingsError("{} is a real-time level from 1 to 99", "rt_priority",
                                got=self.rt_priority) from None
        self.emulator.check_scenario()


def settings_from_args(args: argparse.Namespace) -> ServeSettings:
    """The options of :func:`add_arguments` as settings; SettingsError for a refused value."""
    _path_refusal(args)
    gps = None
    if args.gps_pty:
        if args.scenario is None and not args.replay:
            raise SettingsError("{} follows a simulated walk: give {} NAME", "gps_pty", "scenario")
        gps = gps_settings(args.gps_pty, args.origin, args.gps_outage)
    elif args.origin is not None or args.gps_outage:
        raise SettingsError("{} and {} go with {} PATH", "origin", "gps_outage", "gps_pty")
    emulator = EmulatorSettings(
        scenario=args.scenario or "default", replay=args.replay or "", seed=args.seed, module=args.module,
        stance_sway=args.stance_sway, command_set=args.command_set,
        speed=args.speed, interface=args.interface, link=args.link or args.interface,
        loss=args.loss, corrupt=args.corrupt, stall_rate=args.stall_rate,
        disconnect_rate=args.disconnect_rate, pty=args.pty or "", tcp=args.tcp, rfc2217=args.rfc2217,
        usb_pty=args.usb_pty or "", usb_tcp=args.usb_tcp, modules=args.modules, feet=args.feet)
    return ServeSettings(emulator, control=args.control, trace=args.trace or "", duration=args.duration,
                         status_interval=args.status_interval, frame_ms=args.frame_ms,
                         overrun_ms=args.overrun_ms, gps=gps, web=getattr(args, "web", None),
                         web_control=getattr(args, "web_control", False),
                         rt_priority=getattr(args, "rt_priority", None), cpu=getattr(args, "cpu", None))


def cli_option(name: str) -> str:
    """A setting's name as the command line spells it: ``usb_pty`` → ``--usb-pty``."""
    return "--" + name.replace("_", "-")


def frame_ticks(settings: ServeSettings, rate_hz: float) -> int:
    """Ticks per frame from ``frame_ms`` (at least one tick)."""
    ms = settings.frame_ms
    if ms is None:
        ms = MANY_MODULES_FRAME_MS if settings.emulator.module_count > 1 else 0.0
    return max(1, round(ms * rate_hz / 1000.0))


# --------------------------------------------------------------------------- building


def build_served_module(settings: EmulatorSettings, index: int) -> ServedModule:
    """Module *index* of *settings* (:func:`~firmware_sim.transports.factory.build`) with its pacer."""
    built = build(settings, index)
    pacer = Pacer(built.module, built.endpoints, speed=settings.speed)
    return ServedModule(index, built.module, built.links, built.endpoints, pacer, built.ready, built.label)


@dataclass
class _Served:
    """What a run of ``serve`` holds open (closed by :func:`_shut_down`)."""

    modules: list[ServedModule] = field(default_factory=list)
    control: ControlServer | None = None
    trace: TraceWriter | None = None
    loop: MultiPacer | None = None
    gps: GpsPtyEndpoint | None = None
    panel: Any = None  #: the live panel (:class:`.web.panel.EmulatorPanel`), with --web
    sel: selectors.BaseSelector = field(default_factory=selectors.DefaultSelector)


def _open(served: _Served, settings: ServeSettings) -> None:
    """Build every module, then open the control channel and the trace file, each into *served*."""
    emulator = replace(settings.emulator, trace=bool(settings.trace))
    if emulator.replay:
        from hostlib.inputs import check_input

        check_input(emulator.replay, "walk recording", pipes=False)  # a device (/dev/zero): never read whole
    for i in range(emulator.module_count):
        served.modules.append(build_served_module(emulator, i))
    if settings.gps is not None:
        # pumped by the first module's pacer: on its clock, in its loop's thread
        served.gps = open_gps_pty(settings.gps, [m.module for m in served.modules], emulator.scenario,
                                  emulator.seed)
        served.modules[0].pacer.endpoints.append(served.gps)
    if settings.control or settings.web_control:
        served.control = ControlServer(served.modules, *(settings.control or ("127.0.0.1", 0)))
        served.control.register(served.sel)
    if settings.trace:
        served.trace = TraceWriter(settings.trace, served.modules)


def _start_loop(served: _Served, settings: ServeSettings, err: TextIO) -> None:
    """One loop for every module's pacer, prepared (compiled path) and started."""
    rate_hz = served.modules[0].module.clock.rate_hz
    served.loop = MultiPacer([m.pacer for m in served.modules], frame_ticks=frame_ticks(settings, rate_hz),
                             overrun_s=None if settings.overrun_ms is None else settings.overrun_ms / 1000.0,
                             phases=-(-len(served.modules) // GROUP_MODULES),
                             rt_priority=settings.rt_priority)
    served.loop.prepare(announce=lambda text: print(text, file=err, flush=True))
    gc.collect()
    gc.freeze()  # what exists now is never scanned again: no long collections in the loop
    anywhere = allowed_cpus()
    if settings.cpu is not None:  # before the loop's thread starts: it stays there
        print(f"openshoe-emu serve: loop on {pin_to_cpu(settings.cpu)}", file=err, flush=True)
    if settings.rt_priority is not None and settings.emulator.speed not in (0, math.inf):
        # this thread (control channel, status lines) takes the interpreter's lock between the
        # loop's frames: at the ordinary priority another process could stop it while it holds it
        said = raise_priority(settings.rt_priority)
        print(f"openshoe-emu serve: loop and control at {said}", file=err, flush=True)
    # the status line and the control channel run in this thread: hand the interpreter
    # back to the loop within 0.2 ms, not the default 5 ms (a dozen missed ticks)
    sys.setswitchinterval(2e-4)
    served.loop.start()
    if settings.cpu is not None and hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, anywhere)  # this thread (status lines, control) beside it, on any CPU


def ready_line(modules: list[ServedModule], control: ControlServer | None,
               gps: GpsPtyEndpoint | None = None, web: str | None = None) -> str:
    """``READY key=value …``: every module's endpoints, the GPS receiver's, the live panel's
    (``web=HOST:PORT``), then the control channel."""
    fields = [f"{k}={v}" for m in modules for k, v in m.ready]
    if gps is not None:
        fields.append(f"gps-pty={gps.link_path}")
    if web is not None:
        fields.append(f"web={web}")
    if control is not None:
        fields.append(f"control={control.address[0]}:{control.address[1]}")
    return "READY " + " ".join(fields)


# --------------------------------------------------------------------------- running


def status_text(modules: list[ServedModule], gps: GpsPtyEndpoint | None = None) -> str:
    """Every module's status, prefixed with its label when there are several (``m0``, ``left``),
    then the GPS receiver's."""
    text = modules[0].status_line() if len(modules) == 1 else \
        " || ".join(f"{m.label} {m.status_line()}" for m in modules)
    return text if gps is None else f"{text} || {gps.status_line()}"


class _StatusLines:
    """The status on *err* every *interval* s (0: never); on a terminal, kept on one line."""

    def __init__(self, modules: list[ServedModule], interval: float, err: TextIO,
                 gps: GpsPtyEndpoint | None = None):
        self.modules = modules
        self.gps = gps
        self.interval = interval
        self.err = err
        self.next = time.monotonic() + interval if interval > 0 else None
        self.is_tty = getattr(err, "isatty", lambda: False)()

    def when_due(self) -> None:
        if self.next is None or time.monotonic() < self.next:
            return
        self.next += self.interval
        text = status_text(self.modules, self.gps)
        if self.is_tty:
            print("\r" + text, end="", file=self.err, flush=True)
        else:
            print(text, file=self.err, flush=True)


def _stopped_module(served: _Served, err: TextIO) -> bool:
    """Whether a module's loop failed (each one said on *err*)."""
    broken = [m for m in served.modules if m.pacer.error is not None]
    for m in broken:
        print(f"\nopenshoe-emu serve: module {m.index} stopped: {m.pacer.error!r}", file=err)
    return bool(broken)


def _run(served: _Served, settings: ServeSettings, stop: threading.Event, err: TextIO) -> int:
    """Serve until *stop* is set or the duration ends (0), or a module fails (1).

    Meanwhile the control channel is answered, the status line kept and the trace written.
    """
    t_end = None if settings.duration is None else time.monotonic() + settings.duration
    status = _StatusLines(served.modules, settings.status_interval, err, served.gps)
    sel = served.sel
    while not stop.is_set():
        if t_end is not None and time.monotonic() >= t_end:
            break
        if _stopped_module(served, err):
            return 1
        for key, _ in sel.select(timeout=0.1) if sel.get_map() else []:
            key.data.handle(sel, key.fileobj)
        if not sel.get_map():
            stop.wait(0.1)
        status.when_due()
        if served.trace is not None:
            served.trace.flush()
    return 0


def _shut_down(served: _Served, err: TextIO) -> bool:
    """Stop the loop and close what *served* holds; False if the loop would not stop."""
    stopped = True
    if served.panel is not None:
        served.panel.close()
    if served.loop is not None:
        try:
            served.loop.stop()
        except RuntimeError as exc:
            print(f"openshoe-emu serve: {exc}", file=err)
            stopped = False
    for m in served.modules:
        for ep in m.endpoints:  # the pacer closes them when its loop ends; never started → here
            ep.close()
    if served.gps is not None:
        served.gps.close()
    if served.control is not None:
        served.control.close()
    if served.trace is not None:
        served.trace.flush(stopped=True)
        served.trace.close()
    served.sel.close()
    return stopped


def _stop_on_signals(stop: threading.Event) -> dict[int, Any]:
    """SIGINT and SIGTERM set *stop* (in the main thread only); returns the handlers they had."""
    old: dict[int, Any] = {}
    if threading.current_thread() is threading.main_thread():
        for sig in (signal.SIGINT, signal.SIGTERM):
            old[sig] = signal.signal(sig, lambda *_: stop.set())
    return old


def serve(settings: ServeSettings, out: TextIO = sys.stdout, err: TextIO = sys.stderr,
          stop: threading.Event | None = None) -> int:
    """Run ``serve`` until *stop* is set, SIGINT/SIGTERM, or the duration; returns the exit status.

    1 when a module cannot be built or an endpoint opened (said on *err*), or a module fails.
    """
    stop = stop if stop is not None else threading.Event()
    served = _Served()
    old_handlers = _stop_on_signals(stop)
    status = 0
    try:
        try:
            _open(served, settings)
        except (OSError, ValueError) as exc:  # an endpoint's error names its option: --tcp 127.0.0.1:5000
            print(f"openshoe-emu serve: {exc.spelled(cli_option) if hasattr(exc, 'spelled') else exc}",
                  file=err)
            return 1
        _start_loop(served, settings, err)
        if settings.web is not None:
            from .web.panel import open_panel  # the web stack only for a panel

            try:
                served.panel = open_panel(served.modules, settings.web, served.control, served.gps,
                                          settings.web_control, err)
            except (OSError, RuntimeError) as exc:
                print(f"openshoe-emu serve: {bind_refusal('--web', settings.web, exc)}", file=err)
                return 1
        web = None if served.panel is None else served.panel.address
        print(ready_line(served.modules, served.control, served.gps, web), file=out, flush=True)
        status = _run(served, settings, stop, err)
    finally:
        if not _shut_down(served, err):
            status = 1
        for sig, handler in old_handlers.items():
            signal.signal(sig, handler)
    print("\nSTOPPED" if getattr(err, "isatty", lambda: False)() else "STOPPED", file=err, flush=True)
    return status


def main(args: argparse.Namespace) -> int:
    """Entry point of the ``serve`` subcommand (argparse namespace from :func:`add_arguments`).

    Refused options end here: the message on stderr, exit status 2.
    """
    try:
        settings = settings_from_args(args)
    except SettingsError as exc:
        print(f"openshoe-emu serve: {exc.spelled(cli_option, with_value=False)}", file=sys.stderr)
        return 2
    return serve(settings)
