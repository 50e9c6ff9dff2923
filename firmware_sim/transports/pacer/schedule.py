"""When each module's frames are due: the deadlines of a loop, frame after frame."""

from __future__ import annotations

import math


class Schedule:
    """The deadlines of a loop of *n_mod* modules at *rate_hz* × *speed*, *frame_ticks* ticks a frame.

    Module *j*'s frame *f* (its ticks f·F+1 … (f+1)·F) is due at
    ``t0 + (f + 1)·F·period + offs[j] − ahead[j]``: *phases* groups of modules spread
    evenly over the frame (None: one per module), each early by its lookahead
    (see the package doc). ``f`` is the frame being run, ``j`` the next module to
    run of it; ``t0`` moves forward when the loop rebases. At *speed* 0 or ``inf``
    (as fast as possible) there are no deadlines: period and frame are 0."""

    def __init__(self, n_mod: int, rate_hz: float, speed: float, frame_ticks: int, phases: int | None):
        self.n_mod = n_mod
        self.asap = speed == 0 or math.isinf(speed)
        self.speed = speed
        self.frame_ticks = frame_ticks
        self.period = 0.0 if self.asap else 1.0 / (rate_hz * speed)
        self.frame = frame_ticks * self.period
        groups = max(1, min(phases or n_mod, n_mod))
        self.offs = [(j * groups // n_mod) * self.frame / groups for j in range(n_mod)]
        self.due_offs = list(self.offs)
        self.t0 = 0.0
        self.f = 0
        self.j = 0

    def run_ahead(self, lookahead_ticks: list[float]) -> list[float]:
        """Let each module run ahead by its lookahead [ticks]; returns the lookaheads [s]."""
        ahead = [0.0 if self.asap else t * self.period for t in lookahead_ticks]
        self.due_offs = [o - a for o, a in zip(self.offs, ahead, strict=True)]
        return ahead

    def overrun_limits(self, ahead: list[float], overrun_s: float | None) -> list[float]:
        """How late [s] each module's frame may start before it counts an overrun: *overrun_s*
        of module time, or else as late as no host could see (at least one frame)."""
        frame, period = self.frame, self.period
        return [frame if self.asap else (overrun_s / self.speed if overrun_s is not None
                                         else max(frame, 2 * a + period - frame)) for a in ahead]

    def deadline(self) -> float:
        """When the next frame (module ``j``'s frame ``f``) is due."""
        return self.t0 + (self.f + 1) * self.frame + self.due_offs[self.j]

    def rebase(self, now: float) -> None:
        """Move the schedule forward so that the next frame is due *now*."""
        self.t0 = now - (self.f + 1) * self.frame - self.due_offs[self.j]

    def frame_end(self) -> int:
        """The ticks a module has run by the end of frame ``f``."""
        return (self.f + 1) * self.frame_ticks

    def phase_groups(self) -> list[int]:
        """For each module j, the module after the last one of its *phase group*: the modules
        from j on whose frames are due at the same time (the same phase and lookahead)."""
        ends = [self.n_mod] * self.n_mod
        due = self.due_offs
        for j in range(self.n_mod - 2, -1, -1):
            ends[j] = ends[j + 1] if due[j + 1] == due[j] else j + 1
        return ends

    def next_module(self, after: int | None = None) -> bool:
        """On to the next module of the frame (*after*: on to that one, past a group run together);
        True when that ends a round (on to the next frame)."""
        self.j = self.j + 1 if after is None else after
        if self.j == self.n_mod:
            self.j = 0
            self.f += 1
            return True
        return False

    def ticks_due(self, k: int, now: float) -> int:
        """The ticks module *k* should have run by *now* (at most to the end of its next frame)."""
        return min(self.interrupts(k, now), (self.f + (1 if k >= self.j else 2)) * self.frame_ticks)

    def interrupts(self, k: int, now: float) -> int:
        """The timer interrupts of module *k* by *now* (the ticks whose loops may have started)."""
        return int((now - self.t0 - self.due_offs[k]) / self.period)

    def taking_bytes(self, k: int, now: float, done: int, lead: int) -> int:
        """The ticks module *k*, which has run *done*, runs when a host's bytes arrive at *now*: those
        due, and its next loop (which takes the bytes) if that is at most *lead* ticks past its
        last interrupt."""
        return max(self.ticks_due(k, now), min(done + 1, self.interrupts(k, now) + lead))
