"""A snapshot of one module's real-time loop (:class:`PacerStatus`) and its lateness classes."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any

#: Upper bounds [ms of module time] of the lateness classes counted per frame (PacerStatus.lag_frames).
LAG_BOUNDS_MS = (1.0, 2.0, 5.0, 10.0, 20.0, 50.0, math.inf)
LAG_LABELS = tuple(f"<{b:g}ms" for b in LAG_BOUNDS_MS[:-1]) + (f">={LAG_BOUNDS_MS[-2]:g}ms",)


@dataclass
class PacerStatus:
    """A snapshot of one module's real-time loop, for a live status line."""

    running: bool
    speed: float
    ticks: int  #: module ticks run by this pacer
    virtual_s: float  #: the module's clock
    wall_s: float  #: wall time since start
    loop_us_mean: float  #: mean wall time of one tick (module.step)
    loop_us_max: float  #: longest wall time of one frame's ticks (in a phase group: its share)
    overruns: int  #: frames that started later than the overrun limit (see the package doc)
    rebases: int  #: times the schedule was moved forward after falling far behind
    lag_ms: float  #: how far the last frame ran behind its deadline
    lag_max_ms: float  #: the most a frame ran behind its deadline
    frame_ms: float  #: wall time of one frame (the ticks run back to back per wake-up)
    lookahead_ms: float = 0.0  #: how far ahead of the wall clock the module runs (its links' latency)
    overrun_limit_ms: float = 0.0  #: a frame starting later than this after its deadline is an overrun
    late_bytes: int = 0  #: bytes that reached a host or the module later than the link model says
    late_max_ms: float = 0.0  #: the largest such lateness (deliveries within one frame are on time)
    #: frames by how late they started, e.g. {"<1ms": 9000, "<2ms": 40, …, ">=50ms": 0}
    lag_frames: dict[str, int] = field(default_factory=dict)
    #: float states (navigation numbers) holding an inf or a NaN after the last frame, e.g. ["P"]
    nonfinite: list[str] = field(default_factory=list)
    nonfinite_frames: int = 0  #: frames after which some navigation number was not finite
    nonfinite_first_s: float | None = None  #: module time [s] of the first such frame (None: never)
    packets: dict[str, int] = field(default_factory=dict)  #: packets assembled per interface
    queue: dict[str, int] = field(default_factory=dict)  #: frames in each interface's queue
    endpoints: list[dict[str, Any]] = field(default_factory=list)
    #: the loop thread's scheduling, e.g. "SCHED_FIFO 10" or "normal" (:mod:`.priority`)
    priority: str = "normal"
    #: seconds the loop's thread (every module of the loop) was runnable but waited for a CPU
    #: since it started (None: not known, or the loop is not running)
    run_queue_wait_s: float | None = None
    gc_runs: int = 0  #: the garbage collector's runs while the loop ran (each stops the loop)
    gc_longest_ms: float = 0.0  #: the longest of them

    def line(self) -> str:
        """One status line, e.g. for a terminal."""
        ratio = self.virtual_s / self.wall_s if self.wall_s > 0 else 0.0
        pk = " ".join(f"{k}:{v}" for k, v in self.packets.items())
        q = " ".join(f"{k}:{v}" for k, v in self.queue.items())
        hosts = " ".join(f"{e.get('kind', '?')}={'on' if e.get('paired') else 'off'}" for e in self.endpoints)
        return (f"t={self.virtual_s:9.3f}s x{ratio:5.2f} "
                f"loop {self.loop_us_mean:6.1f}/{self.loop_us_max:6.1f} us "
                f"overruns {self.overruns} lag {self.lag_ms:5.1f}/{self.lag_max_ms:5.1f} ms "
                f"late {self.late_bytes} B "
                f"| packets {pk} | queue {q} | {hosts}{self.nonfinite_note()}")

    def nonfinite_note(self) -> str:
        """The status line's end once the navigation numbers were not all finite after a frame,
        e.g. ``| non-finite P QUATERNION (120 frames since t=12.345s)`` ("none now" when they are
        finite again); empty while they always were."""
        if not self.nonfinite_frames:
            return ""
        now = " ".join(self.nonfinite) or "none now"
        return f" | non-finite {now} ({self.nonfinite_frames} frames since t={self.nonfinite_first_s:.3f}s)"

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)
