"""The four benchmark targets of `python -m lab.bench` (see :mod:`lab.bench`)."""

from __future__ import annotations

import json
import os
import random
import resource
import selectors
import socket
import statistics
import time
import tty
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from firmware_sim.app.progress import progress_bar
from firmware_sim.mcu.imu_bus import RawSample
from firmware_sim.mcu.module import ModuleConfig
from firmware_sim.nav import fastpath
from firmware_sim.nav.firmware import build_module
from firmware_sim.nav.warmup import prepare_module
from firmware_sim.sensors.imu_array import make_source
from protocol.frames import StatePacket, build_packet_ack, build_state_packet, build_state_packet_declared
from protocol.stream import StreamDecoder

from .driver import START_STEPWISE, run_session
from .result import Result

if TYPE_CHECKING:  # pragma: no cover
    from firmware_sim.app.serve import ServeProcess

Say = Callable[[str], None]

BATCH_TARGET = 340_000.0
REALTIME_MINUTES = 10.0
LATENCY_TARGET_MS = 1.0
MEMORY_GROWTH_TARGET_MB = 5.0
#: PING in the current numbering (protocol.md §3) and its ack.
PING = bytes.fromhex("030003")
PING_ACK = bytes.fromhex("a00300a3")


def _per_call_us(fn: Callable[[], Any], n: int) -> float:
    t = time.perf_counter()
    for _ in range(n):
        fn()
    return (time.perf_counter() - t) / n * 1e6


# ---------------------------------------------------------------------------------------------
# batch


def bench_batch(walk_s: float, say: Say) -> Result:
    """The step-wise session on a simulated walk, compiled and pure, same input, one core."""
    recipe = f"stand:3+walk:{walk_s:g}"
    source = make_source(recipe, seed=0)
    n = len(source)
    say(f"batch: {recipe} at 1 kHz, 4 IMUs: {n} samples")
    details: dict[str, Any] = {"input": recipe, "samples": n}
    # the frame builder, per 64-byte step packet
    payload = bytes(range(58))
    details["state_packet_fast_us"] = round(_per_call_us(lambda: build_state_packet(7, payload), 20000), 2)
    details["state_packet_construct_us"] = round(
        _per_call_us(lambda: build_state_packet_declared(7, payload), 2000), 2)
    t = time.perf_counter()
    pure = run_session(source, compiled=False)
    pure_s = time.perf_counter() - t
    pure_rate = pure.ticks / pure_s
    details.update(pure_samples_per_s=round(pure_rate), pure_us_per_loop=round(1e6 / pure_rate, 1),
                   packets=pure.packets)
    say(f"batch: pure Python {pure_rate:,.0f} samples/s ({1e6 / pure_rate:.0f} µs per loop), "
        f"{pure.packets} step packets")
    if not fastpath.available():
        say(f"batch: compiled path unavailable: {fastpath.reason_unavailable()}")
        details["compiled"] = False
        return Result("batch", pure_rate, "samples/s", BATCH_TARGET, passed=pure_rate >= BATCH_TARGET,
                      details=details)
    t = time.perf_counter()
    run_session(make_source("stand:2+walk:1", seed=1), compiled=True)
    details["jit_or_cache_load_s"] = round(time.perf_counter() - t, 2)
    rates = []
    fast = None
    t_all = time.perf_counter()
    while len(rates) < 5 or (time.perf_counter() - t_all < 3 and len(rates) < 50):
        t = time.perf_counter()
        fast = run_session(source, compiled=True)
        rates.append(fast.ticks / (time.perf_counter() - t))
    assert fast is not None
    rate = statistics.median(rates)
    identical = fast.wire == pure.wire
    details.update(compiled=True, runs=len(rates), best_samples_per_s=round(max(rates)),
                   speedup=round(rate / pure_rate, 1), identical_bytes=identical,
                   compiled_loop_share=round(fast.ticks_compiled / fast.ticks, 4), wire_bytes=len(fast.wire))
    say(f"batch: compiled {rate:,.0f} samples/s (median of {len(rates)}; best {max(rates):,.0f}), "
        f"{rate / pure_rate:.0f}× pure; wire bytes identical: {identical}; "
        f"JIT/cache load {details['jit_or_cache_load_s']} s")
    return Result("batch", rate, "samples/s", BATCH_TARGET, passed=rate >= BATCH_TARGET and identical,
                  details=details)


# ---------------------------------------------------------------------------------------------
# memory


class RepeatingWalk:
    """A simulated walk repeated end to end, *length* samples in all (a long batch input
    without holding it in memory); ``imu_block`` gives the compiled path views of it."""

    def __init__(self, length: int, recipe: str = "stand:3+walk:57", seed: int = 0):
        self.base = make_source(recipe, seed=seed)
        self.rate_hz = self.base.rate_hz
        self.length = int(length)
        self._n = len(self.base.imu)

    def __len__(self) -> int:
        return self.length

    def read(self, index: int) -> RawSample | None:
        if index >= self.length:
            return None
        i = index % self._n
        b = self.base
        return RawSample(b.imu[i], b.temp[i], b.mag[i])

    def imu_block(self, start: int, n: int) -> np.ndarray:
        i = start % self._n
        n = min(n, self.length - start, self._n - i)
        return self.base.imu[i:i + max(n, 0)]

    def set_dlpf(self, cfg: int) -> None:
        pass


def _rss_mb() -> float:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def bench_memory(cycles: int, say: Say, quiet: bool = False) -> Result:
    """A long batch session (compiled when available): RSS along the way, peak and growth."""
    short = cycles < 86_400_000
    source = RepeatingWalk(cycles)
    module = build_module(ModuleConfig(rate_hz=1000.0), sensors=source)
    prepare_module(module, say)  # the compile (or cache load) is not part of the run
    port = module.bt.port
    decoder = StreamDecoder()
    port.host_write(START_STEPWISE)
    packets = 0
    wire = 0
    samples: list[tuple[int, float]] = []
    every = max(cycles // 200, 10_000)
    next_sample = 0
    clock = module.clock
    t0 = time.perf_counter()
    say(f"memory: {cycles:,} loop cycles ({cycles / 3.6e6:.2f} h at 1 kHz), compiled={module.compiled}")
    bar = progress_bar(cycles, "memory", "cycles", quiet=quiet, unit_scale=True)
    while clock.ticks < cycles:
        bar.update(module.advance(min(cycles - clock.ticks, 1_000_000)))
        data = port.host_read()
        if data:
            wire += len(data)
            for frame in decoder.feed(data):
                if isinstance(frame, StatePacket):
                    port.host_write(build_packet_ack(frame.number))
                    packets += 1
        if clock.ticks >= next_sample:
            samples.append((clock.ticks, _rss_mb()))
            next_sample += every
            if len(samples) % 20 == 0:
                el = time.perf_counter() - t0
                say(f"memory: {clock.ticks:,} cycles, {clock.ticks / el:,.0f}/s, "
                    f"RSS {samples[-1][1]:.1f} MB, {packets} steps")
    bar.close()
    elapsed = time.perf_counter() - t0
    samples.append((clock.ticks, _rss_mb()))
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    ref_i = max(1, len(samples) // 10)  # after warm-up (JIT, first allocations)
    growth = samples[-1][1] - samples[ref_i][1]
    details = {"cycles": clock.ticks, "steps": packets, "wire_bytes": wire, "elapsed_s": round(elapsed, 1),
               "cycles_per_s": round(clock.ticks / elapsed), "peak_rss_mb": round(peak, 1),
               "rss_start_mb": round(samples[ref_i][1], 1), "rss_end_mb": round(samples[-1][1], 1),
               "compiled": module.compiled, "samples": samples[:: max(1, len(samples) // 20)]}
    say(f"memory: {clock.ticks:,} cycles in {elapsed:.0f} s, {packets} steps, RSS {samples[ref_i][1]:.1f} → "
        f"{samples[-1][1]:.1f} MB, peak {peak:.1f} MB")
    return Result("memory", growth, "MB RSS growth", MEMORY_GROWTH_TARGET_MB, higher=False,
                  passed=growth <= MEMORY_GROWTH_TARGET_MB, short=short,
                  details=details, note=f"peak RSS {peak:.0f} MB")


# ---------------------------------------------------------------------------------------------
# real time: serve processes and a host per pty


def _open_pty(path: str) -> int:
    fd = os.open(path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
    tty.setraw(fd)
    return fd


def _control(addr: str, line: str, timeout: float = 10.0) -> str:
    host, port = addr.rsplit(":", 1)
    with socket.create_connection((host, int(port)), timeout=timeout) as s:
        s.sendall(line.encode() + b"\n")
        buf = b""
        deadline = time.monotonic() + timeout
        while not buf.rstrip().endswith(b"OK") and time.monotonic() < deadline:
            chunk = s.recv(65536)
            if not chunk:
                break
            buf += chunk
    return buf.decode(errors="replace")


def single_loop_cost_us(modules: int = 10, ticks: int = 2000) -> float:
    """µs of one module's loop when one thread steps *modules* walking modules on Bluetooth
    links and acks their steps (the CPU a real-time process needs per module and tick)."""
    from firmware_sim.links.link import make_link

    src = make_source("stand:3+walk:5", seed=0)
    mods = [build_module(ModuleConfig(), sensors=src, bt_port=make_link("bt", seed=i))
            for i in range(modules)]
    decs = [StreamDecoder() for _ in mods]
    for m in mods:
        m.bt.port.host_write(START_STEPWISE)

    def tick() -> None:
        for m, d in zip(mods, decs, strict=True):
            m.step()
            data = m.bt.port.host_read()
            if data:
                for f in d.feed(data):
                    if isinstance(f, StatePacket):
                        m.bt.port.host_write(build_packet_ack(f.number))

    for _ in range(3500):  # through the alignment into walking
        tick()
    t = time.perf_counter()
    for _ in range(ticks):
        tick()
    return (time.perf_counter() - t) / ticks / modules * 1e6


@dataclass
class _RealtimePlan:
    """How the real-time target runs: modules per serve process, frame length, scenario."""

    modules: int
    minutes: float
    per: list[int]  #: modules in each serve process
    frame_len: float  #: serve's --frame-ms
    scenario: str
    short: bool  #: shorter or smaller than the full target
    rt_priority: int | None = None  #: serve's --rt-priority (None: the ordinary priority)


def _realtime_plan(modules: int, processes: int, minutes: float, frame_ms: float | None,
                   rt_priority: int | None = None) -> _RealtimePlan:
    from firmware_sim.app.serve import MANY_MODULES_FRAME_MS

    frame_len = frame_ms if frame_ms is not None else (MANY_MODULES_FRAME_MS if modules > processes else 1.0)
    per = [modules // processes + (1 if i < modules % processes else 0) for i in range(processes)]
    walk_s = minutes * 60 + 30
    scenario = f"stand:3+walk:{walk_s:g}" if walk_s <= 180 else "stand:3+walk:177"
    short = minutes < REALTIME_MINUTES or modules < 50
    return _RealtimePlan(modules, minutes, per, frame_len, scenario, short, rt_priority)


def _spawn_serves(plan: _RealtimePlan, procs: list[ServeProcess], say: Say) -> None:
    """One serve process per entry of ``plan.per``, started together (each builds its modules on a
    core of its own, and the first ready runs its clock alone for less time), appended to *procs* in
    order once all are READY."""
    from concurrent.futures import ThreadPoolExecutor

    from firmware_sim.app.serve import spawn

    tag = f"/tmp/openshoe-bench-{os.getpid()}"
    priority = () if plan.rt_priority is None else ("--rt-priority", str(plan.rt_priority))
    t = time.monotonic()

    cpus = sorted(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else []

    def one(k: int, m: int) -> ServeProcess:
        # at real-time priority each on a CPU of its own, if there are enough (serve --cpu)
        cpu = ("--cpu", str(cpus[k])) if priority and len(cpus) >= len(plan.per) else ()
        sp = spawn("--modules", str(m), "--pty", f"{tag}-{k}-", "--scenario", plan.scenario,
                   "--control", "127.0.0.1:0", "--status-interval", "10",
                   "--frame-ms", f"{plan.frame_len:g}", *priority, *cpu, timeout=600)
        say(f"realtime: serve {k} ready in {time.monotonic() - t:.0f} s")
        return sp

    with ThreadPoolExecutor(len(plan.per)) as pool:
        futures = [pool.submit(one, k, m) for k, m in enumerate(plan.per)]
        errors = []
        for fut in futures:  # every one kept, to be stopped, when another failed
            try:
                procs.append(fut.result())
            except Exception as exc:  # noqa: BLE001 - raised below
                errors.append(exc)
    if errors:
        raise errors[0]


def _cpu_s(pid: int) -> float:
    """CPU seconds process *pid* used so far (all its threads, user and system)."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


@dataclass
class _Host:
    """A host on one module's pty: it started step-wise dead reckoning and acks every step."""

    proc: int  #: which serve process
    name: str  #: the READY key of the pty
    dec: StreamDecoder = field(default_factory=StreamDecoder)
    steps: int = 0


def _open_hosts(procs: list[ServeProcess], hosts: dict[int, _Host]) -> None:
    """A host on every module's Bluetooth pty (into *hosts*, by file descriptor), tracking started."""
    for k, sp in enumerate(procs):
        for key, path in sp.ready.items():
            if key.endswith("bt-pty"):
                fd = _open_pty(path)
                hosts[fd] = _Host(k, key)
                os.write(fd, START_STEPWISE)


def _ack_steps(fd: int, host: _Host) -> None:
    """Read what the module sent; ack each step packet."""
    try:
        data = os.read(fd, 65536)
    except BlockingIOError:
        return
    for frame in host.dec.feed(data):
        if isinstance(frame, StatePacket):
            os.write(fd, build_packet_ack(frame.number))
            host.steps += 1


def _drive_hosts(hosts: dict[int, _Host], minutes: float, say: Say, quiet: bool) -> None:
    """Every host acks its module's steps for *minutes*; the steps so far said every minute."""
    sel = selectors.DefaultSelector()
    for fd in hosts:
        sel.register(fd, selectors.EVENT_READ)
    end = time.monotonic() + minutes * 60
    last = time.monotonic()
    bar = progress_bar(round(minutes * 60), "realtime", "s", quiet=quiet,
                       bar_format="{desc} {percentage:3.0f}%|{bar}| {n:.0f}/{total:.0f} s "
                                  "[{elapsed}<{remaining}]")
    while time.monotonic() < end:
        bar.update(min(minutes * 60, minutes * 60 - (end - time.monotonic())) - bar.n)
        for key, _ in sel.select(0.5):
            _ack_steps(key.fd, hosts[key.fd])
        if time.monotonic() - last > 60:
            last = time.monotonic()
            say(f"realtime: {sum(h.steps for h in hosts.values())} steps so far")
    bar.close()
    sel.close()


@dataclass
class _ServeStatus:
    """What the serve processes' control channels report, per module (``p<process>.m<index>``)."""

    overruns: dict[str, int] = field(default_factory=dict)
    late_bytes: dict[str, int] = field(default_factory=dict)
    late_max: dict[str, float] = field(default_factory=dict)
    limits: set[tuple[float, float]] = field(default_factory=set)  #: (lookahead, overrun limit) in ms
    lag_max: dict[str, float] = field(default_factory=dict)
    lag_frames: dict[str, int] = field(default_factory=dict)  #: frames by lateness class, all modules
    loop_us: list[float] = field(default_factory=list)
    #: per process: its loop's priority, seconds it waited for a CPU, the GC's runs and longest [ms]
    stalls: dict[int, dict[str, Any]] = field(default_factory=dict)

    def add(self, process: int, st: dict[str, Any]) -> None:
        """One module's ``status json`` line from serve process *process*."""
        name = f"p{process}.m{st['module']}"
        self.overruns[name] = st["overruns"]
        self.late_bytes[name] = st["late_bytes"]
        self.late_max[name] = st["late_max_ms"]
        self.limits.add((st["lookahead_ms"], st["overrun_limit_ms"]))
        self.lag_max[name] = st["lag_max_ms"]
        self.loop_us.append(st["loop_us_mean"])
        for cls, n in st["lag_frames"].items():
            self.lag_frames[cls] = self.lag_frames.get(cls, 0) + n
        self.stalls[process] = {"priority": st.get("priority", "?"), "cpu_wait_s": st.get("run_queue_wait_s"),
                                "gc_runs": st.get("gc_runs"), "gc_longest_ms": st.get("gc_longest_ms")}


def _serve_status(procs: list[ServeProcess]) -> _ServeStatus:
    status = _ServeStatus()
    for k, sp in enumerate(procs):
        for line in _control(sp.ready["control"], "status json").splitlines():
            if line.startswith("{"):
                status.add(k, json.loads(line))
    return status


def _realtime_details(plan: _RealtimePlan, status: _ServeStatus, steps: dict[str, int],
                      per_tick: float) -> dict[str, Any]:
    """The real-time target's figures for the JSON report."""
    ahead, limit = max(status.limits) if status.limits else (0.0, plan.frame_len)
    overruns = status.overruns
    return {"processes": plan.per, "minutes": plan.minutes, "scenario": plan.scenario,
            "frame_ms": plan.frame_len, "lookahead_ms": ahead, "overrun_limit_ms": limit,
            "overrun_means": f"a frame (the {plan.frame_len:g} ms of ticks a module runs per wake-up, "
                             f"{ahead:g} ms ahead of the wall clock behind the Bluetooth link) "
                             f"starting more than {limit:g} ms after its deadline, so late that a host "
                             "could see it",
            "late_bytes_total": sum(status.late_bytes.values()),
            "late_max_ms": round(max(status.late_max.values(), default=0.0), 2),
            "late_bytes_mean": "bytes that reached a host (or the module) more than one frame after the "
                               "link model's arrival time (any cause: a late frame, or the loop not "
                               "running when they were due)",
            "lag_max_ms": max(status.lag_max.values(), default=float("nan")),
            "lag_max_ms_per_module": status.lag_max, "frames_by_lateness": status.lag_frames,
            "overruns_total": sum(overruns.values()),
            "modules_without_overrun": sum(1 for n in overruns.values() if n == 0),
            "modules_with_steps": sum(1 for n in steps.values() if n > 0),
            "steps_total": sum(steps.values()), "single_loop_us_per_module_tick": round(per_tick, 1),
            "loop_us_mean": round(statistics.mean(status.loop_us), 1) if status.loop_us else None,
            "overruns": overruns, "late_bytes": status.late_bytes, "steps": steps,
            "loops": {f"p{k}": v for k, v in sorted(status.stalls.items())}}


def _realtime_result(plan: _RealtimePlan, status: _ServeStatus, details: dict[str, Any], say: Say) -> Result:
    """Say the real-time figures; the result: modules without overrun that sent steps."""
    d = details
    ok, stepping = d["modules_without_overrun"], d["modules_with_steps"]
    say(f"realtime: {ok}/{plan.modules} modules without overrun, {stepping} sent steps "
        f"({d['steps_total']} in all), total overruns {d['overruns_total']}, "
        f"worst frame lateness {d['lag_max_ms']:.1f} ms (modules {d['lookahead_ms']:g} ms ahead; "
        f"overrun: more than {d['overrun_limit_ms']:g} ms)")
    say(f"realtime: bytes that reached a host later than the link model says (by more than one frame): "
        f"{d['late_bytes_total']}, worst {max(status.late_max.values(), default=0.0):.1f} ms late")
    say(f"realtime: frames by lateness: {' '.join(f'{k} {v}' for k, v in status.lag_frames.items())}")
    for name, loop in d.get("loops", {}).items():
        wait, cpu = loop.get("cpu_wait_s"), loop.get("cpu_us_per_module_tick")
        waited = "?" if wait is None else f"{wait:.2f}"
        used = "?" if cpu is None else f"{cpu:.1f}"
        say(f"realtime: {name}: loop at {loop['priority']}, waited {waited} s for a CPU, GC ran "
            f"{loop['gc_runs']} times (longest {loop['gc_longest_ms'] or 0:.1f} ms), {used} µs of CPU per "
            "module and tick")
    figure = min(ok, stepping)
    return Result("realtime", figure, "modules without overrun", float(plan.modules), passed=figure >= 50,
                  short=plan.short, details=details)


def bench_realtime(modules: int, processes: int, minutes: float, say: Say,
                   frame_ms: float | None = None, quiet: bool = False,
                   rt_priority: int | None = None) -> Result:
    """*modules* in *processes* serve processes at 1 kHz, each stepping over its own pty (their loops
    at real-time priority *rt_priority*, if given and allowed)."""
    plan = _realtime_plan(modules, processes, minutes, frame_ms, rt_priority)
    say(f"realtime: {modules} modules in {processes} serve processes {plan.per}, {minutes:g} min, "
        f"frames of {plan.frame_len:g} ms, scenario {plan.scenario} (after it the last sample is held), "
        f"loops at {'the ordinary priority' if rt_priority is None else f'real-time priority {rt_priority}'}")
    procs: list[ServeProcess] = []
    hosts: dict[int, _Host] = {}
    load = [os.getloadavg()[0]]
    try:
        _spawn_serves(plan, procs, say)
        _open_hosts(procs, hosts)
        cpu0, t0 = [_cpu_s(sp.proc.pid) for sp in procs], time.monotonic()
        _drive_hosts(hosts, minutes, say, quiet)
        cpu1, t1 = [_cpu_s(sp.proc.pid) for sp in procs], time.monotonic()
        load.append(os.getloadavg()[0])
        status = _serve_status(procs)
    finally:
        for fd in hosts:
            os.close(fd)
        for sp in procs:
            sp.stop()
    steps = {f"p{h.proc}.{h.name}": h.steps for h in hosts.values()}
    for k, m in enumerate(plan.per):  # the serve process's CPU over the run, whatever else the machine ran
        loop = status.stalls.setdefault(k, {"priority": "?", "cpu_wait_s": None, "gc_runs": None,
                                            "gc_longest_ms": None})
        loop["cpu_us_per_module_tick"] = round((cpu1[k] - cpu0[k]) / ((t1 - t0) * 1000 * m) * 1e6, 2)
    say(f"realtime: machine load (1-min average) {load[0]:.1f} before the serve processes, "
        f"{load[1]:.1f} at the end")
    per_tick = single_loop_cost_us()
    say(f"realtime: one thread stepping modules needs {per_tick:.1f} µs per module and tick "
        f"(≈ {1000 / per_tick:.0f} modules per core at 1 kHz, before pacing and pty I/O)")
    details = _realtime_details(plan, status, steps, per_tick)
    details["load_1min"] = [round(x, 2) for x in load]
    return _realtime_result(plan, status, details, say)


def bench_latency(pings: int, say: Say, quiet: bool = False) -> Result:
    """PING written on a pty → its ack read back, one module served in real time (ideal link)."""
    from firmware_sim.app.serve import spawn

    path = f"/tmp/openshoe-bench-lat-{os.getpid()}"
    sp = spawn("--pty", path, "--scenario", "stand:5", "--link", "ideal", timeout=120)
    lat: list[float] = []
    try:
        fd = _open_pty(sp.ready["bt-pty"])
        sel = selectors.DefaultSelector()
        sel.register(fd, selectors.EVENT_READ)
        rng = random.Random(1)
        lost = 0
        bar = progress_bar(pings, "latency", "pings", quiet=quiet)
        for _ in range(pings):
            bar.update(1)
            buf = b""
            t0 = time.perf_counter()
            os.write(fd, PING)
            deadline = t0 + 0.5
            while PING_ACK not in buf and time.perf_counter() < deadline:
                if sel.select(max(deadline - time.perf_counter(), 0)):
                    buf += os.read(fd, 4096)
            if PING_ACK in buf:
                lat.append((time.perf_counter() - t0) * 1e3)
            else:
                lost += 1
            time.sleep(rng.uniform(0, 0.003))  # arrive at any phase of the 1 ms tick
        bar.close()
        os.close(fd)
    finally:
        sp.stop()
    lat.sort()
    p99 = lat[min(len(lat) - 1, int(0.99 * len(lat)))] if lat else float("inf")
    details = {"pings": pings, "acks": len(lat), "lost": lost, "p50_ms": round(statistics.median(lat), 3),
               "p99_ms": round(p99, 3), "max_ms": round(lat[-1], 3), "link": "ideal",
               "measured": "host write on the pty → ack read on the pty (includes the pty both ways)"}
    say(f"latency: {len(lat)} acks, p50 {details['p50_ms']} ms, p99 {p99:.3f} ms, max {lat[-1]:.3f} ms")
    return Result("latency", p99, "ms p99", LATENCY_TARGET_MS, higher=False,
                  passed=p99 <= LATENCY_TARGET_MS and lost == 0, details=details)
