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

Here: running the two serve processes, the load and the clean host; the plan is
:mod:`lab.bench.hostile_plan`, the processes' samples :mod:`lab.bench.hostile_served`, the figures
:mod:`lab.bench.hostile_figures`, the hostile clients :mod:`lab.bench.hostile_load`.
"""

from __future__ import annotations

import concurrent.futures
import logging
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from firmware_sim.app.progress import progress_bar
from protocol.ids import StateId
from protocol.states import STATES

from .hostile_figures import hostile_details, hostile_result, hostile_table
from .hostile_load import HostileClient, LoadLoop, WellBehavedHost
from .hostile_plan import CHECK_STEPS, HostilePlan
from .hostile_served import ModuleEnds, ServedGroup, module_ends
from .result import Result

if TYPE_CHECKING:  # pragma: no cover
    from hostlib import Device

__all__ = ["GROUPS", "bench_hostile", "check_module", "read_settings"]

Say = Callable[[str], None]

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
