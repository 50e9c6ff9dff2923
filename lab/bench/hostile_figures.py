"""The figures of the ``hostile`` target (:mod:`lab.bench.hostile`): per module and per serve process
(overruns, the worst loop and frame lag, late bytes, non-finite states, RSS over time, CPU, fds, the
clean host's checks), the hostile run beside its baseline, the result and its table."""

from __future__ import annotations

from dataclasses import asdict
from typing import Any

from protocol.states import STATES

from .hostile_plan import HostilePlan
from .hostile_served import ServedGroup
from .result import Result

__all__ = ["RSS_FLAT_MB", "hostile_details", "hostile_result", "hostile_table", "rss_trend"]

#: RSS growth after the first tenth of the run that still counts as flat.
RSS_FLAT_MB = 5.0


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
