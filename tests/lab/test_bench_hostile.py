"""The ``hostile`` target of `python -m lab.bench`: its load generator, its figures and a tiny run."""

from __future__ import annotations

import json
import os
import random
import re
import socket
import threading
import time
from pathlib import Path

import pytest

from lab.bench import DEFAULT_MODULES, TARGETS, main
from lab.bench.hostile import GROUPS
from lab.bench.hostile_figures import hostile_details, hostile_result, hostile_table, rss_trend
from lab.bench.hostile_load import CommandFuzzer, HostileClient, HostileConfig, LoadLoop
from lab.bench.hostile_plan import hostile_plan
from lab.bench.hostile_served import ServedGroup, module_ends
from protocol.commands import CURRENT
from protocol.frames import parse_command
from protocol.states import STATES

LINE = re.compile(r"^(\w+): ([\d.]+) (.+?) \(target ([\d.]+), ratio (\d+\.\d\d)\)")


def test_the_target_is_listed_with_its_own_module_count() -> None:
    from tests.test_layering import project_imports

    assert "hostile" in TARGETS and DEFAULT_MODULES["hostile"] == 10
    assert "lab.bench" not in project_imports("lab.bench.hostile")
    assert "lab.bench" not in project_imports("lab.bench.hostile_load")
    for part in ("hostile_plan", "hostile_served", "hostile_figures"):
        assert "lab.bench" not in project_imports(f"lab.bench.{part}")


@pytest.mark.parametrize("args, said", [(["--hostile-commands", "PING,NOPE"], "no command NOPE"),
                                        (["--modules", "0"], "--modules must be >= 1")])
def test_refused_values_stop_before_any_target_runs(args: list[str], said: str,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["batch", "hostile", *args])
    captured = capsys.readouterr()
    assert said in captured.err and "--- batch" not in captured.err


def test_fuzzed_frames_are_well_formed_seeded_and_cover_every_command() -> None:
    a, b = CommandFuzzer(random.Random(7)), CommandFuzzer(random.Random(7))
    seen = set()
    for _ in range(3000):
        spec, frame = a.frame()
        assert b.frame()[1] == frame, "the same seed gives the same bytes"
        assert len(frame) == spec.frame_len
        assert parse_command(frame, CURRENT).command_id == spec.wire_id  # checksum and length right
        seen.add(spec.wire_id)
    assert seen == set(CURRENT), "every command of the table"


def test_drawn_set_state_payloads_mostly_hit_a_state_that_fits() -> None:
    fz = CommandFuzzer(random.Random(3), raw_share=0.0)
    spec = CURRENT[0x14]  # SET_STATE_12
    hits = sum(1 for _ in range(500) if (sid := fz.payload(spec)[0]) in STATES and STATES[sid].size <= 12)
    assert hits > 350
    junk = [len(fz.garbage(1024)) for _ in range(500)]
    assert min(junk) >= 1 and max(junk) <= 1024


def test_a_hostile_client_comes_back_on_the_pty_and_the_tcp_port_and_stops_by_itself(tmp_path: Path) -> None:
    """Against a pty and a TCP listener of the test's own: it sends, leaves, comes back on both,
    and is closed when its time is up."""
    master, slave = os.openpty()
    link = tmp_path / "pty"
    link.symlink_to(os.ttyname(slave))
    os.close(slave)
    os.set_blocking(master, False)
    server = socket.create_server(("127.0.0.1", 0))
    server.settimeout(0.05)
    got = {"pty": 0, "tcp": 0}
    stop = threading.Event()

    def far_end() -> None:
        conns: list[socket.socket] = []
        while not stop.is_set():
            try:
                conns.append(server.accept()[0])
                conns[-1].setblocking(False)
            except TimeoutError:
                pass
            for c in conns:
                try:
                    got["tcp"] += len(c.recv(65536))
                except (BlockingIOError, OSError):
                    pass
            try:
                got["pty"] += len(os.read(master, 65536))
            except OSError:  # no host on the pty just now (EIO), or nothing to read
                pass
        for c in conns:
            c.close()

    thread = threading.Thread(target=far_end, daemon=True)
    thread.start()
    cfg = HostileConfig(rate_hz=200.0, session_s=0.15, away_s=(0.01, 0.03), deaf_s=(0.01, 0.05))
    client = HostileClient("m0", str(link), server.getsockname()[:2], seed=1, config=cfg)
    t = time.monotonic()
    try:
        LoadLoop([client]).run(1.5)
    finally:
        stop.set()
        thread.join(5)
        server.close()
        os.close(master)
    assert time.monotonic() - t < 5
    s = client.summary()
    assert s["commands"] > 50 and s["garbage_bytes"] > 0 and s["bytes_sent"] > 0
    assert s["sessions_pty"] >= 1 and s["sessions_tcp"] >= 1 and s["leaves"] >= 2
    assert got["pty"] > 0 and got["tcp"] > 0
    assert client.conn is None, "closed when its time was up"


def test_module_ends_from_ready_lines() -> None:
    one = module_ends({"bt-pty": "/tmp/a", "bt-tcp": "127.0.0.1:4000", "control": "127.0.0.1:4001"})
    assert [(e.index, e.pty, e.tcp) for e in one] == [(0, "/tmp/a", ("127.0.0.1", 4000))]
    two = module_ends({"m1.bt-pty": "/tmp/b1", "m0.bt-pty": "/tmp/b0", "m1.bt-tcp": "127.0.0.1:5",
                       "m0.bt-tcp": "127.0.0.1:6", "control": "127.0.0.1:7"})
    assert [(e.index, e.pty) for e in two] == [(0, "/tmp/b0"), (1, "/tmp/b1")]


def test_rss_flat_or_growing() -> None:
    # a walk's start frees memory, then flat
    flat = rss_trend([(0, 300.0), (1, 300.0), (2, 180.0), (3, 181.0), (4, 180.5), (5, 181.0)])
    assert flat["verdict"] == "flat" and flat["low_mb"] == 180.0 and flat["growth_mb"] == 1.0
    growing = rss_trend([(t * 60.0, 100.0 + 2 * t) for t in range(11)])
    assert growing["verdict"] == "growing" and growing["slope_mb_per_min"] == pytest.approx(2.0)
    assert rss_trend([])["verdict"] == "unknown"


def _status(module: int, overruns: int, nonfinite: list[str], frames: int) -> dict:
    return {"module": module, "overruns": overruns, "loop_us_max": 500.0 + overruns, "loop_us_mean": 20.0,
            "lag_max_ms": 3.0, "late_bytes": 2 * overruns, "late_max_ms": 1.0, "nonfinite": nonfinite,
            "nonfinite_frames": frames, "nonfinite_first_s": 1.5 if frames else None,
            "lag_frames": {"<1ms": 100 + overruns},
            "endpoints": [{"kind": "pty", "connects": 3, "dropped": 0}]}


def _check(ok: bool) -> dict:
    return {"ping": ok, "ping_ms": 90.0 if ok else None, "ping_as_left_ms": 1200.0 if ok else None,
            "changed_settings": ["TH_ZUPT"] if ok else [], "restored": True, "steps": 5 * ok,
            "summed": 5 * ok, "rejected": 0, "distance_m": 3.0, "first_step_s": 1.3, "error": None,
            "answers": ok, "tracks": ok, "ok": ok}


def test_the_figures_and_the_table_from_samples() -> None:
    plan = hostile_plan(2, 0.5)
    groups = {name: ServedGroup(name) for name in GROUPS}
    h, b = groups["hostile"], groups["baseline"]
    for t, (o0, o1) in enumerate(((0, 0), (1, 4), (2, 9))):
        h.samples.append({"t": float(t), "rss_mb": 200.0 + t, "cpu_s": t * 0.5, "fds": 9,
                          "status": [_status(0, o0, ["P"] if t == 1 else [], t), _status(1, o1, [], 0)]})
        b.samples.append({"t": float(t), "rss_mb": 210.0, "cpu_s": t * 0.2, "fds": 9,
                          "status": [_status(0, 0, [], 0), _status(1, t, [], 0)]})
    h.checks, b.checks = [_check(True), _check(False)], [_check(True), _check(True)]
    h.final_status = [_status(0, 2, [], 2), _status(1, 9, [], 0)]
    clients = [{"name": "m0", "commands": 10, "acks": 4, "packets": 1, "bytes_read": 9, "garbage_bytes": 100,
                "sessions": 2, "by_command": {"PING": 3, "ACK": 7}}]
    d = hostile_details(plan, groups, {"hostile": clients, "baseline": []})
    json.dumps(d)  # JSON-ready
    assert (d["overruns_hostile"], d["overruns_baseline"], d["overruns_beyond_baseline"]) == (11, 2, 9)
    assert d["late_bytes_hostile"] == 22 and d["loop_us_max_hostile"] == 509.0
    assert d["nonfinite_modules"] == 1 and d["nonfinite_names"] == ["P"]
    assert d["rss_verdict_hostile"] == "flat" and d["hostile"]["cpu_percent"] == 50.0
    assert d["modules_ok"] == 1 and d["baseline_modules_ok"] == 2 and d["serve_failed"] == []
    assert d["commands_by_name"] == {"ACK": 7, "PING": 3}
    r = hostile_result(plan, d)
    assert (r.figure, r.target, r.passed, r.short) == (1.0, 2.0, False, True)
    table = hostile_table(d)
    assert "overruns h/b" in table and re.search(r"^m1 .* NO ", table, re.M)
    assert re.search(r"^hostile\s+200\.0", table, re.M) and "beyond the baseline 9" in table


@pytest.mark.slow
def test_the_target_runs_and_reports_its_fields(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """One module for a few seconds, beside its baseline: the line, the table and the JSON."""
    out = tmp_path / "bench.json"
    main(["hostile", "--modules", "1", "--minutes", "0.05", "--json", str(out), "-q"])
    lines = capsys.readouterr().out.strip().splitlines()
    mo = LINE.match(lines[-1])
    assert mo and mo.group(1) == "hostile" and mo.group(4) == "1"
    assert any(line.startswith("m0 ") for line in lines)
    assert any(line.startswith("baseline ") for line in lines)
    (res,) = json.loads(out.read_text())["results"]
    d = res["details"]
    for key in ("loop_us_max_hostile", "overruns_hostile", "overruns_baseline", "overruns_beyond_baseline",
                "late_bytes_hostile", "rss_growth_mb_hostile", "rss_verdict_hostile", "nonfinite_modules",
                "modules_ok", "commands_sent"):
        assert key in d, key
    assert d["serve_failed"] == [] and d["commands_sent"] > 0
    assert d["hostile"]["timeline"] and d["hostile"]["checks"][0]["answers"] is True
    assert d["baseline_run"]["checks"][0]["ok"] is True
