"""The ``hostile`` target of `python -m lab.bench`: served modules soaked under hostile clients.

``--modules`` (10) modules in one ``openshoe-emu serve`` process (Bluetooth link, each on a pty
and a TCP port on 127.0.0.1, a walk of ``stand:3+walk:100`` that starts when a module first
reads its sensors, then stands), each with a hostile client (:mod:`lab.bench.hostile_load`:
random well-formed commands of every kind, random bytes, a host that stops reading, leaving and
coming back on the pty or the TCP port) for ``--minutes`` (10). For comparison the same run
without them: a second serve process with the same modules (same seed) where a well-behaved
host on each module tracks and acknowledges every step — beside it, at the same time, so both
share whatever else the machine does (``--baseline side-by-side``, the default), or before it
(``--baseline before``: twice the time).

Every ~10 s (a 20th of a short run) each serve process is sampled: its RSS, CPU time and open
file descriptors (``/proc``), and every module's ``status json`` from its control channel
(overruns, the worst frame, late bytes, non-finite navigation states). When the load stops,
every module gets a clean host (:func:`check_module`, hostlib's Device on its pty): 257 zero
bytes (they close any frame the garbage left open), a first PING as the module was left (one
try: its ack may wait behind lossless packets nobody acknowledged), OUTPUT_ALL_OFF (outputs
off, the queue emptied), the clean PING (hostlib's retries), the settings a host relies on
read back (the detector's thresholds TH_ZUPT, TH_ZARU: those the hostile client changed are
named, then set to what the module had before the load) and the DLPF set to its power-on 0,
then step-wise dead reckoning (0x34) until ``CHECK_STEPS`` steps are summed.

The figure: hostile modules that answer the clean PING and track (target: all of them). It is
met when, besides, every serve process ran until stopped and exited 0, the hostile run has no
overrun beyond the baseline's and its RSS is flat (the end ≤ 5 MB above the lowest sample after
the first tenth of the run: a served walk frees memory once it starts). Printed: a table per
module and per process; the JSON has every figure and the samples over time.
``--hostile-commands`` sends only the commands named, to find which ones cost what.
"""

from __future__ import annotations

import concurrent.futures
import json
import logging
import os
import random
import tempfile
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from firmware_sim.app.progress import progress_bar
from protocol.ids import StateId
from protocol.states import STATES

from .hostile_load import CommandFuzzer, HostileClient, HostileConfig, LoadLoop, WellBehavedHost
from .result import Result

if TYPE_CHECKING:  # pragma: no cover
    from firmware_sim.app.serve import ServeProcess
    from hostlib import Device

__all__ = ["HOSTILE_MINUTES", "HOSTILE_MODULES", "HostilePlan", "bench_hostile", "check_module",
           "hostile_details", "hostile_plan", "hostile_result", "hostile_table", "rss_trend"]

Say = Callable[[str], None]

HOSTILE_MINUTES = 10.0
HOSTILE_MODULES = 10
HOSTILE_SCENARIO = "stand:3+walk:100"
#: RSS growth after the first tenth of the run that still counts as flat.
RSS_FLAT_MB = 5.0
#: Steps the clean host must get after 0x34.
CHECK_STEPS = 5
CHECK_TIMEOUT_S = 30.0
#: Zero bytes a clean host sends first: they complete any frame left open (the longest is 257
#: bytes after its header) and the rest are discarded (docs/protocol-extensions.md).
RESYNC_ZEROS = 257
#: The settings a host relies on for tracking (the detector's thresholds; the firmware never writes
#: them): read before the load, compared and restored after. THETA_INIT and THETA_GROUND are
#: settable too, but every alignment and stance writes them.
SETTINGS = (StateId.TH_ZUPT, StateId.TH_ZARU)
POWER_ON_DLPF = 0
GROUPS = ("hostile", "baseline")


# ---------------------------------------------------------------------------------------------
# the plan


@dataclass(frozen=True)
class HostilePlan:
    """How the hostile target runs."""

    modules: int
    minutes: float
    baseline: str = "side-by-side"  #: or "before"
    scenario: str = HOSTILE_SCENARIO
    seed: int = 0
    config: HostileConfig = field(default_factory=HostileConfig)
    check_steps: int = CHECK_STEPS

    @property
    def short(self) -> bool:
        return self.minutes < HOSTILE_MINUTES or self.modules < HOSTILE_MODULES

    @property
    def sample_s(self) -> float:
        """Seconds between two samples of the serve processes (10, or a 20th of a short run)."""
        return max(0.5, min(10.0, self.minutes * 60 / 20))


def hostile_plan(modules: int, minutes: float, baseline: str = "side-by-side", seed: int = 0,
                 rate_hz: float = 10.0, check_steps: int = CHECK_STEPS,
                 commands: tuple[str, ...] = ()) -> HostilePlan:
    """The plan of a run; ValueError for a value it cannot run (*commands*: only these, by name)."""
    if modules < 1 or minutes <= 0 or rate_hz <= 0:
        raise ValueError("hostile: --modules must be >= 1, --minutes and --hostile-rate > 0")
    if baseline not in ("side-by-side", "before"):
        raise ValueError(f"hostile: unknown baseline {baseline!r}")
    config = HostileConfig(rate_hz=rate_hz, commands=tuple(commands))
    CommandFuzzer(random.Random(0), only=config.commands)  # refuses an unknown name now
    return HostilePlan(modules, minutes, baseline, seed=seed, config=config, check_steps=check_steps)


# ---------------------------------------------------------------------------------------------
# the serve processes and their samples


@dataclass
class ModuleEnds:
    """Where one served module is reached."""

    index: int
    pty: str
    tcp: tuple[str, int] | None


def module_ends(ready: dict[str, str]) -> list[ModuleEnds]:
    """The modules of a READY line (``m<i>.bt-pty``, ``m<i>.bt-tcp``; no prefix for one module)."""
    by_label: dict[str, dict[str, str]] = {}
    for key, value in ready.items():
        label, _, kind = key.rpartition(".")
        if kind in ("bt-pty", "bt-tcp"):
            by_label.setdefault(label, {})[kind] = value
    ends = []
    for label, kinds in by_label.items():
        index = int(label[1:]) if label.startswith("m") and label[1:].isdigit() else 0
        tcp = None
        if "bt-tcp" in kinds:
            host, port = kinds["bt-tcp"].rsplit(":", 1)
            tcp = (host, int(port))
        ends.append(ModuleEnds(index, kinds["bt-pty"], tcp))
    return sorted(ends, key=lambda e: e.index)


def _proc_figures(pid: int) -> dict[str, float]:
    """RSS [MB], CPU time [s] and open file descriptors of process *pid* (Linux /proc)."""
    page = os.sysconf("SC_PAGE_SIZE")
    with open(f"/proc/{pid}/statm") as f:
        rss = int(f.read().split()[1]) * page / 2**20
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    cpu = (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    fds = len(os.listdir(f"/proc/{pid}/fd"))
    return {"rss_mb": round(rss, 2), "cpu_s": round(cpu, 2), "fds": fds}


@dataclass
class ServedGroup:
    """One serve process (the hostile run's or the baseline's) and what was seen of it."""

    group: str
    proc: ServeProcess | None = None
    log: Path | None = None
    ends: list[ModuleEnds] = field(default_factory=list)
    samples: list[dict[str, Any]] = field(default_factory=list)
    before: dict[int, dict[int, bytes] | None] = field(default_factory=dict)  #: settings before the load
    checks: list[dict[str, Any]] = field(default_factory=list)
    final_status: list[dict[str, Any]] = field(default_factory=list)
    exit_code: int | None = None  #: None: it ran until stopped and exited 0; else how it ended
    log_tail: str = ""
    t0: float = 0.0

    def status(self) -> list[dict[str, Any]] | None:
        from .targets import _control

        if self.proc is None or self.proc.proc.poll() is not None:
            return None
        try:
            reply = _control(self.proc.ready["control"], "status json")
        except OSError:
            return None
        return [json.loads(line) for line in reply.splitlines() if line.startswith("{")]

    def sample(self, now: float) -> None:
        """RSS, CPU, fds and every module's status now (nothing once the process is gone)."""
        if self.proc is None:
            return
        if self.proc.proc.poll() is not None:
            self.exit_code = self.proc.proc.returncode
            return
        try:
            figures = _proc_figures(self.proc.proc.pid)
        except OSError:
            return
        self.samples.append({"t": round(now - self.t0, 2), **figures, "status": self.status()})


def _spawn(group: ServedGroup, plan: HostilePlan, tmp: Path) -> None:
    from firmware_sim.app.serve import spawn

    group.log = tmp / f"serve-{group.group}.log"
    with group.log.open("wb") as log:
        group.proc = spawn("--modules", str(plan.modules), "--pty", str(tmp / f"{group.group}-"),
                           "--tcp", "127.0.0.1:0", "--control", "127.0.0.1:0", "--scenario", plan.scenario,
                           "--seed", str(plan.seed), "--status-interval", "0", timeout=600, stderr=log)
    group.ends = module_ends(group.proc.ready)


def _stop(group: ServedGroup) -> None:
    if group.proc is None:
        return
    died = group.proc.proc.poll()
    code = group.proc.stop()
    group.exit_code = died if died is not None else (None if code == 0 else code)
    if group.exit_code is not None and group.log is not None:
        group.log_tail = group.log.read_text(errors="replace")[-3000:]


# ---------------------------------------------------------------------------------------------
# a clean host


def _read_settings(dev: Device, timeout: float = 3.0) -> dict[int, bytes] | None:
    """The raw bytes of :data:`SETTINGS` (one pulled packet), None when no such packet came."""
    ids = sorted(SETTINGS)
    sizes = [STATES[i].size for i in ids]
    dev.output_multiple_states(ids + [0] * (8 - len(ids)), 0x20)
    deadline = time.monotonic() + timeout
    while (left := deadline - time.monotonic()) > 0:
        p = dev.recv_packet(left)
        if p is None:
            break
        dev.ack_packet(p.number)  # in case the hostile client left the interface lossless
        if len(p.payload) == sum(sizes):
            out, at = {}, 0
            for sid, n in zip(ids, sizes, strict=True):
                out[sid] = bytes(p.payload[at:at + n])
                at += n
            return out
    return None


def read_settings(pty: str) -> dict[int, bytes] | None:
    """:data:`SETTINGS` of a module nobody disturbed yet (what the clean host restores later)."""
    from hostlib import Device
    from hostlib.errors import HostError

    try:
        with Device(pty, reconnect=False) as dev:
            dev.ping()
            return _read_settings(dev)
    except (HostError, OSError):
        return None


def check_module(pty: str, before: dict[int, bytes] | None, steps: int = CHECK_STEPS,
                 timeout: float = CHECK_TIMEOUT_S) -> dict[str, Any]:
    """A clean host on a module after the load (the module docstring): does it answer, does it track?"""
    from hostlib import Device
    from hostlib.errors import AckTimeout, HostError

    out: dict[str, Any] = {"ping_as_left_ms": None, "ping": False, "ping_ms": None,
                           "changed_settings": [], "restored": False, "steps": 0, "summed": 0,
                           "rejected": 0, "distance_m": None, "first_step_s": None, "error": None}
    try:
        with Device(pty, reconnect=False) as dev:
            dev.send_raw(bytes(RESYNC_ZEROS))
            t = time.monotonic()
            try:  # as the hostile client left it: the ack may wait behind unacknowledged packets
                dev.ping(timeout=1.0, retries=0)
                out["ping_as_left_ms"] = round((time.monotonic() - t) * 1e3, 1)
            except AckTimeout:
                pass
            dev.output_all_off()  # outputs off, the queue emptied: nothing left before an ack
            t = time.monotonic()
            try:
                dev.ping()
                out["ping"] = True
                out["ping_ms"] = round((time.monotonic() - t) * 1e3, 1)
            except AckTimeout:
                pass
            now = _read_settings(dev)
            if before is not None:
                changed = [sid for sid, raw in before.items() if now is None or now.get(sid) != raw]
                out["changed_settings"] = [STATES[sid].name for sid in changed]
                for sid in changed:
                    dev.set_state(sid, before[sid])
                out["restored"] = True
            dev.set_imu_bandwidth(POWER_ON_DLPF)
            while dev.recv_step(0) is not None:
                pass
            t = time.monotonic()
            dev.start_stepwise_dead_reckoning()
            for ev in dev.steps(timeout):
                out["steps"] += 1
                if out["first_step_s"] is None:
                    out["first_step_s"] = round(time.monotonic() - t, 2)
                out["summed"] += ev.outcome.summed
                out["rejected"] += ev.outcome.name == "REJECTED"
                if out["summed"] >= steps:
                    break
            out["distance_m"] = round(dev.track.distance, 2)
            out["gaps"] = len(dev.gap_events)
    except (HostError, OSError) as exc:
        out["error"] = f"{type(exc).__name__}: {exc}"
    out["answers"] = out["ping"]
    out["tracks"] = out["summed"] >= steps
    out["ok"] = out["answers"] and out["tracks"]
    return out


def _for_every_module(groups: list[ServedGroup],
                      fn: Callable[[ServedGroup, ModuleEnds], Any]) -> list[list[Any]]:
    """*fn* on every module of *groups* at once (a thread each); results per group, by module."""
    jobs = [(g, e) for g in groups for e in g.ends]
    with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, len(jobs))) as pool:
        results = list(pool.map(lambda job: fn(*job), jobs))
    out: list[list[Any]] = [[] for _ in groups]
    for (g, _), r in zip(jobs, results, strict=True):
        out[groups.index(g)].append(r)
    return out


# ---------------------------------------------------------------------------------------------
# running


def _load(groups: list[ServedGroup], plan: HostilePlan, say: Say, quiet: bool) -> dict[str, list[dict]]:
    """The load on *groups* for the plan's minutes (hostile clients or well-behaved hosts); what
    the hosts did, by group."""
    hosts: dict[str, list[Any]] = {}
    for g in groups:
        if g.group == "hostile":
            hosts[g.group] = [HostileClient(f"m{e.index}", e.pty, e.tcp, seed=plan.seed * 1000 + e.index,
                                            config=plan.config) for e in g.ends]
        else:
            hosts[g.group] = [WellBehavedHost(f"m{e.index}", e.pty) for e in g.ends]
    seconds = plan.minutes * 60
    names = " and ".join(f"{g.group} ({len(g.ends)} modules)" for g in groups)
    say(f"hostile: {seconds:g} s of load on {names}")
    bar = progress_bar(round(seconds), "hostile", "s", quiet=quiet,
                       bar_format="{desc} {percentage:3.0f}%|{bar}| {n:.0f}/{total:.0f} s "
                                  "[{elapsed}<{remaining}]")
    start = time.monotonic()
    for g in groups:
        g.t0 = start
    last_say = start

    def tick(now: float) -> None:
        nonlocal last_say
        for g in groups:
            g.sample(now)
        bar.update(min(seconds, now - start) - bar.n)
        if now - last_say >= 60:
            last_say = now
            say(f"hostile: {now - start:.0f} s: " + "; ".join(_progress_note(g) for g in groups))

    LoadLoop([h for hs in hosts.values() for h in hs]).run(seconds, tick, plan.sample_s)
    for g in groups:
        g.sample(time.monotonic())
    bar.close()
    return {k: [h.summary() for h in hs] for k, hs in hosts.items()}


def _progress_note(g: ServedGroup) -> str:
    if not g.samples or not g.samples[-1]["status"]:
        return f"{g.group}: no status" + (f" (exited {g.exit_code})" if g.exit_code is not None else "")
    st = g.samples[-1]["status"]
    return (f"{g.group}: RSS {g.samples[-1]['rss_mb']:.0f} MB, overruns {sum(s['overruns'] for s in st)}, "
            f"non-finite in {sum(1 for s in st if s['nonfinite_frames'])} modules")


def _settle(groups: list[ServedGroup], plan: HostilePlan, say: Say) -> None:
    """After the load: the clean host on every module, then the status once more."""
    say(f"hostile: a clean host on every module: PING, then 0x34 until {plan.check_steps} steps")
    # a baseline module's last step before 0x34 reads as a gap to a new host: said, not logged
    device_log = logging.getLogger("hostlib.link.device")
    level = device_log.level
    device_log.setLevel(logging.ERROR)
    try:
        results = _for_every_module(groups, lambda g, e: check_module(e.pty, g.before.get(e.index),
                                                                       plan.check_steps))
    finally:
        device_log.setLevel(level)
    for g, checks in zip(groups, results, strict=True):
        g.checks = checks
        g.final_status = g.status() or []


def _run_groups(groups: list[ServedGroup], plan: HostilePlan, tmp: Path, say: Say,
                quiet: bool) -> dict[str, list[dict]]:
    """Spawn *groups*' serve processes (at once), note their settings, load, check, stop."""
    t = time.monotonic()
    try:
        with concurrent.futures.ThreadPoolExecutor(max_workers=len(groups)) as pool:
            list(pool.map(lambda g: _spawn(g, plan, tmp), groups))
        say(f"hostile: {', '.join(g.group for g in groups)} serve ready in {time.monotonic() - t:.0f} s")
        befores = _for_every_module(groups, lambda g, e: read_settings(e.pty))
        for g, values in zip(groups, befores, strict=True):
            g.before = {e.index: v for e, v in zip(g.ends, values, strict=True)}
        activity = _load(groups, plan, say, quiet)
        _settle(groups, plan, say)
    finally:
        for g in groups:
            _stop(g)
    return activity


def bench_hostile(plan: HostilePlan, say: Say, quiet: bool = False) -> Result:
    """The hostile soak (the module docstring)."""
    only = f" (commands {','.join(plan.config.commands)} only)" if plan.config.commands else ""
    say(f"hostile: {plan.modules} modules, {plan.minutes:g} min, baseline {plan.baseline}, scenario "
        f"{plan.scenario}, seed {plan.seed}, about {plan.config.rate_hz:g} hostile actions/s per "
        f"module{only}")
    groups = {name: ServedGroup(name) for name in GROUPS}
    activity: dict[str, list[dict]] = {}
    with tempfile.TemporaryDirectory(prefix="openshoe-hostile-") as tmpdir:
        tmp = Path(tmpdir)
        if plan.baseline == "before":
            activity.update(_run_groups([groups["baseline"]], plan, tmp, say, quiet))
            activity.update(_run_groups([groups["hostile"]], plan, tmp, say, quiet))
        else:
            activity.update(_run_groups([groups["hostile"], groups["baseline"]], plan, tmp, say, quiet))
    details = hostile_details(plan, groups, activity)
    result = hostile_result(plan, details)
    result.table = hostile_table(details)
    return result


# ---------------------------------------------------------------------------------------------
# the figures


def rss_trend(samples: list[tuple[float, float]]) -> dict[str, Any]:
    """RSS [MB] at the start, its lowest after the first tenth of the samples (warm-up: the walk's
    start frees memory), at the end and its peak; the growth from that low to the end, the slope
    over the second half [MB/min], and "flat" (growth ≤ :data:`RSS_FLAT_MB`) or "growing"."""
    if not samples:
        return {"verdict": "unknown"}
    later = samples[min(len(samples) - 1, len(samples) // 10):]
    ref = min(later, key=lambda s: s[1])
    end = samples[-1]
    half = samples[len(samples) // 2:]
    slope = None
    if len(half) >= 3:
        n = len(half)
        mt = sum(t for t, _ in half) / n
        mr = sum(r for _, r in half) / n
        var = sum((t - mt) ** 2 for t, _ in half)
        if var > 0:
            slope = sum((t - mt) * (r - mr) for t, r in half) / var * 60
    growth = end[1] - ref[1]
    return {"start_mb": samples[0][1], "low_mb": ref[1], "low_t_s": ref[0], "end_mb": end[1],
            "peak_mb": max(r for _, r in samples), "growth_mb": round(growth, 2),
            "slope_mb_per_min": None if slope is None else round(slope, 3),
            "verdict": "flat" if growth <= RSS_FLAT_MB else "growing"}


def _module_figures(g: ServedGroup) -> list[dict[str, Any]]:
    """Per module: the load's counters (end − start), the worst frame, non-finite states."""
    with_status = [s for s in g.samples if s.get("status")]
    if not with_status:
        return []
    first, last = with_status[0]["status"], with_status[-1]["status"]
    seen: dict[int, set[str]] = {}
    for s in with_status:
        for st in s["status"]:
            seen.setdefault(st["module"], set()).update(st["nonfinite"])
    final = {st["module"]: st for st in g.final_status}
    out = []
    for a, b in zip(first, last, strict=True):
        m = b["module"]
        endpoints = b.get("endpoints", [])
        out.append({
            "module": m, "overruns": b["overruns"] - a["overruns"], "overruns_since_start": b["overruns"],
            "loop_us_max": round(b["loop_us_max"], 1), "loop_us_mean": round(b["loop_us_mean"], 1),
            "lag_max_ms": round(b["lag_max_ms"], 2), "late_bytes": b["late_bytes"] - a["late_bytes"],
            "late_max_ms": round(b["late_max_ms"], 2), "nonfinite_frames": b["nonfinite_frames"],
            "nonfinite_first_s": b["nonfinite_first_s"], "nonfinite_seen": sorted(seen.get(m, ())),
            "nonfinite_after_check": final.get(m, {}).get("nonfinite"),
            "host_connects": sum(e.get("connects", 0) for e in endpoints),
            "dropped_to_host": sum(e.get("dropped", 0) for e in endpoints),
            "lag_frames": {k: v - a["lag_frames"].get(k, 0) for k, v in b["lag_frames"].items()},
        })
    return out


def _group_details(g: ServedGroup) -> dict[str, Any]:
    mods = _module_figures(g)
    rss = rss_trend([(s["t"], s["rss_mb"]) for s in g.samples])
    cpu = None
    if len(g.samples) >= 2 and g.samples[-1]["t"] > g.samples[0]["t"]:
        cpu = round(100 * (g.samples[-1]["cpu_s"] - g.samples[0]["cpu_s"])
                    / (g.samples[-1]["t"] - g.samples[0]["t"]), 1)
    timeline = [{"t": s["t"], "rss_mb": s["rss_mb"], "cpu_s": s["cpu_s"], "fds": s["fds"],
                 "overruns": sum(st["overruns"] for st in s["status"]) if s["status"] else None,
                 "late_bytes": sum(st["late_bytes"] for st in s["status"]) if s["status"] else None,
                 "nonfinite_now": sum(1 for st in s["status"] if st["nonfinite"]) if s["status"] else None}
                for s in g.samples]
    checks = g.checks
    return {
        "modules": mods, "rss": rss, "cpu_percent": cpu,
        "fds_start": g.samples[0]["fds"] if g.samples else None,
        "fds_end": g.samples[-1]["fds"] if g.samples else None,
        "exit_code": g.exit_code, "log_tail": g.log_tail,
        "overruns_total": sum(m["overruns"] for m in mods),
        "late_bytes_total": sum(m["late_bytes"] for m in mods),
        "loop_us_max": max((m["loop_us_max"] for m in mods), default=None),
        "tick_us_mean": round(sum(m["loop_us_mean"] for m in mods) / len(mods), 1) if mods else None,
        "lag_max_ms": max((m["lag_max_ms"] for m in mods), default=None),
        "late_max_ms": max((m["late_max_ms"] for m in mods), default=None),
        "nonfinite_modules": sum(1 for m in mods if m["nonfinite_frames"]),
        "nonfinite_frames_total": sum(m["nonfinite_frames"] for m in mods),
        "nonfinite_names": sorted({n for m in mods for n in m["nonfinite_seen"]}),
        "checks": checks, "modules_ok": sum(1 for c in checks if c["ok"]),
        "modules_answering": sum(1 for c in checks if c["answers"]),
        "modules_tracking": sum(1 for c in checks if c["tracks"]),
        "settings_before": {str(k): None if v is None else {STATES[s].name: v[s].hex() for s in v}
                            for k, v in g.before.items()},
        "timeline": timeline[:: max(1, len(timeline) // 60)] + timeline[-1:] if timeline else [],
    }


def hostile_details(plan: HostilePlan, groups: dict[str, ServedGroup],
                    activity: dict[str, list[dict]]) -> dict[str, Any]:
    """Every figure of the run, for the JSON report (and :func:`hostile_table`)."""
    per = {name: _group_details(g) for name, g in groups.items()}
    h, b = per["hostile"], per["baseline"]
    clients = activity.get("hostile", [])
    by_command: dict[str, int] = {}
    for c in clients:
        for k, v in c["by_command"].items():
            by_command[k] = by_command.get(k, 0) + v
    return {
        "modules": plan.modules, "minutes": plan.minutes, "baseline": plan.baseline,
        "scenario": plan.scenario, "seed": plan.seed, "load": asdict(plan.config),
        "check_steps": plan.check_steps, "sample_s": plan.sample_s,
        "hostile": h, "baseline_run": b,
        "overruns_hostile": h["overruns_total"], "overruns_baseline": b["overruns_total"],
        "overruns_beyond_baseline": max(0, h["overruns_total"] - b["overruns_total"]),
        "late_bytes_hostile": h["late_bytes_total"], "late_bytes_baseline": b["late_bytes_total"],
        "loop_us_max_hostile": h["loop_us_max"], "loop_us_max_baseline": b["loop_us_max"],
        "tick_us_mean_hostile": h["tick_us_mean"], "tick_us_mean_baseline": b["tick_us_mean"],
        "lag_max_ms_hostile": h["lag_max_ms"], "lag_max_ms_baseline": b["lag_max_ms"],
        "rss_growth_mb_hostile": h["rss"].get("growth_mb"), "rss_verdict_hostile": h["rss"]["verdict"],
        "rss_growth_mb_baseline": b["rss"].get("growth_mb"), "rss_verdict_baseline": b["rss"]["verdict"],
        "nonfinite_modules": h["nonfinite_modules"], "nonfinite_names": h["nonfinite_names"],
        "modules_ok": h["modules_ok"], "baseline_modules_ok": b["modules_ok"],
        "serve_failed": [name for name, d in per.items() if d["exit_code"] is not None],
        "commands_sent": sum(c["commands"] for c in clients),
        "commands_acked": sum(c["acks"] for c in clients),
        "commands_by_name": dict(sorted(by_command.items())),
        "garbage_bytes": sum(c.get("garbage_bytes", 0) for c in clients),
        "sessions": sum(c["sessions"] for c in clients),
        "clients": [{k: v for k, v in c.items() if k != "by_command"} for c in clients],
        "baseline_hosts": activity.get("baseline", []),
        "overrun_means": "a frame starting so late that its output could reach a host after the link "
                         "model's arrival time (serve's overrun limit); counted during the load",
        "loop_us_max_means": "the longest wall time of one frame's ticks of a module, since serve started",
        "tick_us_mean_means": "the mean wall time of a module tick (serve's loop_us_mean), over the modules",
    }


def hostile_result(plan: HostilePlan, d: dict[str, Any]) -> Result:
    """The figure: hostile modules that answer and track; met with nothing beyond the baseline."""
    ok = d["modules_ok"]
    passed = (ok == plan.modules and not d["serve_failed"] and d["overruns_beyond_baseline"] == 0
              and d["rss_verdict_hostile"] == "flat")
    note = (f"overruns {d['overruns_hostile']} vs {d['overruns_baseline']} baseline, RSS "
            f"{_num(d['rss_growth_mb_hostile'], '+.1f')} MB ({d['rss_verdict_hostile']}), non-finite in "
            f"{d['nonfinite_modules']}/{plan.modules} modules, worst loop "
            f"{_num(d['loop_us_max_hostile'], '.0f')} vs {_num(d['loop_us_max_baseline'], '.0f')} µs")
    if d["serve_failed"]:
        note += f"; serve FAILED: {', '.join(d['serve_failed'])}"
    return Result("hostile", float(ok), "modules answering and tracking after the load", float(plan.modules),
                  passed=passed, short=plan.short, details=d, note=note)


def _num(v: Any, fmt: str) -> str:
    return "-" if v is None else format(v, fmt)


def _pair(a: Any, b: Any, fmt: str = "") -> str:
    return f"{_num(a, fmt)}/{_num(b, fmt)}"


def hostile_table(d: dict[str, Any]) -> str:
    """The run as text: one row per module (hostile / baseline side by side), one per process."""
    h, b = d["hostile"], d["baseline_run"]
    hm = {m["module"]: m for m in h["modules"]}
    bm = {m["module"]: m for m in b["modules"]}
    clients = {c["name"]: c for c in d["clients"]}
    head = (f"{'module':<7}{'cmds':>6}{'acked':>6}{'junk kB':>8}{'sess':>5}  {'overruns h/b':>12}  "
            f"{'loop max µs h/b':>15}  {'lag max ms h/b':>14}  {'late B h/b':>11}  "
            f"{'non-finite frames':>17}  {'PING 1st':>8}  {'PING':>8}  {'steps':>5}  {'m':>5}  "
            "settings changed")
    rows = [head, "-" * len(head)]
    for i in range(d["modules"]):
        m, n = hm.get(i, {}), bm.get(i, {})
        c = clients.get(f"m{i}", {})
        chk = h["checks"][i] if i < len(h["checks"]) else {}
        ping = "-" if not chk else f"{chk['ping_ms']:.0f} ms" if chk["ping"] else "NO"
        first = chk.get("ping_as_left_ms")
        left = "-" if not chk else "NO" if first is None else f"{first:.0f} ms"
        nf = m.get("nonfinite_frames")
        nf_text = "-" if nf is None else (f"{nf} ({len(m['nonfinite_seen'])} st)" if nf else "0")
        rows.append(
            f"{'m' + str(i):<7}{c.get('commands', 0):>6}{c.get('acks', 0):>6}"
            f"{c.get('garbage_bytes', 0) / 1000:>8.1f}{c.get('sessions', 0):>5}  "
            f"{_pair(m.get('overruns'), n.get('overruns')):>12}  "
            f"{_pair(m.get('loop_us_max'), n.get('loop_us_max'), '.0f'):>15}  "
            f"{_pair(m.get('lag_max_ms'), n.get('lag_max_ms'), '.1f'):>14}  "
            f"{_pair(m.get('late_bytes'), n.get('late_bytes')):>11}  {nf_text:>17}  {left:>8}  {ping:>8}  "
            f"{chk.get('summed', '-'):>5}  {_num(chk.get('distance_m'), '.1f'):>5}  "
            f"{' '.join(chk.get('changed_settings', [])) or '-'}"
            + (f"  ERROR {chk['error']}" if chk.get("error") else ""))
    rows.append("")
    phead = (f"{'process':<9}{'RSS start':>10}{'low':>8}{'end':>8}{'peak':>8}{'growth':>8}"
             f"{'MB/min':>8}  {'verdict':<8}{'CPU %':>6}{'fds':>10}  {'ok':>6}  exit")
    rows += [phead, "-" * len(phead)]
    for name, g in (("hostile", h), ("baseline", b)):
        r = g["rss"]
        rows.append(
            f"{name:<9}{_num(r.get('start_mb'), '.1f'):>10}{_num(r.get('low_mb'), '.1f'):>8}"
            f"{_num(r.get('end_mb'), '.1f'):>8}{_num(r.get('peak_mb'), '.1f'):>8}"
            f"{_num(r.get('growth_mb'), '+.1f'):>8}{_num(r.get('slope_mb_per_min'), '+.2f'):>8}  "
            f"{r['verdict']:<8}{_num(g['cpu_percent'], '.0f'):>6}"
            f"{_pair(g['fds_start'], g['fds_end']):>10}  {g['modules_ok']:>3}/{len(g['checks']):<2}  "
            f"{'ok' if g['exit_code'] is None else g['exit_code']}")
    rows.append("")
    rows.append(f"overruns during the load: hostile {d['overruns_hostile']}, baseline "
                f"{d['overruns_baseline']}, beyond the baseline {d['overruns_beyond_baseline']}; late bytes "
                f"{d['late_bytes_hostile']} vs {d['late_bytes_baseline']}; worst loop "
                f"{_num(d['loop_us_max_hostile'], '.0f')} vs {_num(d['loop_us_max_baseline'], '.0f')} µs, "
                f"worst frame lag "
                f"{_num(d['lag_max_ms_hostile'], '.1f')} vs {_num(d['lag_max_ms_baseline'], '.1f')} ms; "
                f"a module's tick {_num(d['tick_us_mean_hostile'], '.0f')} vs "
                f"{_num(d['tick_us_mean_baseline'], '.0f')} µs (mean, wall time)")
    names = " ".join(d["nonfinite_names"]) or "none"
    rows.append(f"non-finite navigation states in {d['nonfinite_modules']} of {d['modules']} hostile "
                f"modules ({h['nonfinite_frames_total']} frames): {names}; after the clean host's 0x34: "
                + (", ".join(f"m{m['module']} {' '.join(m['nonfinite_after_check'])}" for m in h["modules"]
                             if m["nonfinite_after_check"]) or "none"))
    rows.append(f"hostile clients: {d['commands_sent']} commands ({d['commands_acked']} acked, "
                f"{len(d['commands_by_name'])} kinds), {d['garbage_bytes'] / 1000:.1f} kB of random bytes, "
                f"{d['sessions']} sessions")
    return "\n".join(rows)
