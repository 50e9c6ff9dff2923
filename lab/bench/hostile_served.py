"""The serve processes of the ``hostile`` target (:mod:`lab.bench.hostile`) and their samples: where
each served module is reached (a READY line's ptys and TCP ports), and what was seen of a process
over the run (RSS, CPU time and open file descriptors from ``/proc``, every module's ``status json``,
the settings before the load, the clean host's checks, how it ended)."""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # pragma: no cover
    from firmware_sim.app.serve import ServeProcess

__all__ = ["ModuleEnds", "ServedGroup", "module_ends"]


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
