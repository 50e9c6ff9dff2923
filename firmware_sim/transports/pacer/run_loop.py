"""One run of a pacer loop, pass after pass: the frames due, the bytes due at hosts, the waits between."""

from __future__ import annotations

import math
import threading
import time
from typing import Protocol

from firmware_sim.nav.lockstep import Lockstep

from .endpoints import links_of, lookahead_cycles
from .host_clock import HostClock
from .member import PacedModule, lag_class
from .priority import lower_priority, raise_priority
from .pumps import Pumps
from .release import Releases
from .schedule import Schedule
from .stalls import GcPauses
from .status import LAG_BOUNDS_MS

#: How far [ticks] past its last timer interrupt a module that does not run ahead (no link latency)
#: may run the loop that takes a host's bytes, at once rather than at that loop's interrupt.
COMMAND_LEAD_TICKS = 2


class RunOwner(Protocol):
    """What a run reads of the loop it runs (a :class:`~.group.MultiPacer`), and reports there."""

    pacers: list[PacedModule]
    speed: float
    max_lag_s: float
    asap_pump_ticks: int
    idle_pump_s: float
    spin_load: float | None
    phases: int | None
    frame_ticks: int
    overrun_s: float | None
    rt_priority: int | None
    priority: str
    thread_id: int | None
    gc_pauses: GcPauses
    running: bool
    t_start: float
    error: BaseException | None


class RunLoop:
    """One run of *owner*'s loop (in the loop's thread, until *stop* is set or *duration_s* passed).

    A pass (``_pass()``) runs the controls, hands over the bytes due at hosts, runs every
    module whose frame is due, in turn, then waits (sleeps in select, or spins) for the
    next deadline, the next bytes due at a host or a host's bytes (see the package doc)."""

    def __init__(self, owner: RunOwner, stop: threading.Event, duration_s: float | None = None):
        members = owner.pacers
        self.owner = owner
        self.members = members
        self.n_mod = len(members)
        self.duration_s = duration_s
        self._stop = stop
        self._advances = [p.module.advance for p in members]
        sched = self.sched = Schedule(self.n_mod, members[0].module.clock.rate_hz, owner.speed,
                                      owner.frame_ticks, owner.phases)
        # real time: each module runs ahead by its lookahead, its links on the host's clock
        # (see the package doc); as fast as possible, the host lives on the module's clock
        self.ahead = sched.run_ahead([0.0 if sched.asap else lookahead_cycles(p.module, p.endpoints)
                                      / p.module.clock.cycles_per_tick for p in members])
        self.limits = sched.overrun_limits(self.ahead, owner.overrun_s)
        for p, a, lim in zip(members, self.ahead, self.limits, strict=True):
            p.lookahead_s, p.overrun_limit_s = a, lim
        self.bounds = [ms / 1000.0 / (1.0 if sched.asap else owner.speed) for ms in LAG_BOUNDS_MS[:-1]]
        #: Per module, the module after its phase group's last; each group of two or more is
        #: advanced together (``_run_group``).
        self.group_end = sched.phase_groups()
        # all in this thread: a frame never waits on a helper thread, which the machine's other
        # processes could hold up (at its ordinary priority, or at the loop's own)
        self.locksteps = {j: Lockstep([p.module for p in members[j:end]], helper=False)
                          for j, end in enumerate(self.group_end)
                          if end - j > 1 and (j == 0 or self.group_end[j - 1] != end)}
        self.spin_busy = None if owner.spin_load is None or sched.asap else owner.spin_load * sched.frame
        self.spinning = False
        self.polled = -1  # the frame whose hosts a spinning loop looked at last
        self.round_busy = 0.0
        self.ran = 0  # whole rounds of frames run back to back
        self.done = [0] * self.n_mod  # ticks each module ran since t0
        idle = owner.idle_pump_s
        self.pumps = Pumps(members, idle, 0 if idle == 0 or sched.asap
                           else max(1, math.ceil(idle / sched.frame - 1e-9)))
        self.releases = Releases(self.n_mod)
        self.perf = time.perf_counter
        self.end: float | None = None

    # ------------------------------------------------------------------ start and end
    def run(self) -> None:
        """Start the clock, then pass after pass until stopped; always closes the endpoints."""
        self._start()
        try:
            self.pumps.pump_all(self.sched.f)
            while not self._stop.is_set():
                if not self._pass():
                    break
        except BaseException as e:  # surfaced through status/error, never silently lost
            self._fail(e)
            raise
        finally:
            self._close()

    def _start(self) -> None:
        t0 = self.sched.t0 = self.owner.t_start = self.perf()
        self.end = None if self.duration_s is None else t0 + self.duration_s
        self.owner.running = True
        self.owner.thread_id = threading.get_native_id()
        self.owner.gc_pauses.watch()
        for p in self.members:
            p.waits.begin()
        if not self.sched.asap:
            # real time only: a loop as fast as possible never sleeps, and would keep a core from
            # every other process
            self.owner.priority = raise_priority(self.owner.rt_priority)
            self._clock_links()

    def _clock_links(self) -> None:
        """The links of each module that runs ahead on the host's clock, on its own phase."""
        sched = self.sched
        for k, p in enumerate(self.members):
            if self.ahead[k] <= 0:
                # never ahead: its links stay on its clock, and a host's bytes reach it at its
                # next loop, however late that loop runs (the fastest answer to a command)
                continue
            clk = p.module.clock
            cpt = clk.cycles_per_tick
            c0 = clk.now_cycles + clk.cycles_until_next_tick() - cpt  # the cycle of tick 0
            clock = HostClock(c0, cpt / sched.period, sched.offs[k], sched, self.perf)
            self.releases.attach(k, clock, links_of(p.endpoints), sched.frame_ticks * cpt)

    def _fail(self, e: BaseException) -> None:
        self.owner.error = e
        if not any(p.error is not None for p in self.members):
            for p in self.members:
                p.error = e

    def _close(self) -> None:
        self.owner.running = False
        self.owner.thread_id = None
        self.owner.gc_pauses.unwatch()
        if self.owner.priority.startswith("SCHED_FIFO"):
            lower_priority()  # the thread may be the caller's (run() blocks in it)
        self.releases.detach()  # back on the module's clock
        self.pumps.close()
        for p in self.members:
            p.waits.end()  # wakes the threads still waiting on ticks

    # ------------------------------------------------------------------ one pass
    def _pass(self) -> bool:
        """One pass of the loop; False when its time is up."""
        if any([p.run_controls() for p in self.members]):  # every member's, then the fds once
            self.pumps.refresh()  # a call may have hung a host up or closed an endpoint
        now = self.perf()
        if self.end is not None and now >= self.end:
            return False
        self._release_due(now)
        if self.sched.asap:
            self._asap_round()
        else:
            self._run_due_frames(now)
            self._wait()
        return True

    def _asap_round(self) -> None:
        """As fast as possible: a few ticks of every module, then pump every endpoint."""
        for k in range(self.n_mod):
            self._run_to(k, self.done[k] + self.owner.asap_pump_ticks)
        self.sched.f += 1
        self.pumps.pump_all(self.sched.f)

    def _run_due_frames(self, now: float) -> None:
        """Run every module whose frame is due, in turn (up to 8 rounds while catching up)."""
        sched = self.sched
        stepped = False
        while True:
            # bytes due at a host go first: they have no slack, a frame has its lookahead
            self._release_due(now)
            deadline = sched.deadline()
            if now < deadline:
                break
            if now - deadline > self.owner.max_lag_s:
                for p in self.members:
                    p.rebases += 1
                sched.rebase(now)
                deadline = now
            end = self.group_end[sched.j]
            if end - sched.j > 1:
                self._run_group(sched.j, end, now - deadline)
            else:
                self._run_frame(now - deadline)
            now = self.perf()
            stepped = True
            if sched.next_module(end) and self._end_round():
                break  # look at the hosts now and then while catching up
        if not stepped:
            self.ran = 0

    def _run_frame(self, late: float) -> None:
        """Module ``j``'s frame, which starts *late* [s] after its deadline."""
        j = self.sched.j
        self.members[j].count_frame_start(late, self.limits[j], self.bounds)
        self.round_busy += self._run_to(j, self.sched.frame_end())
        # what the frame sent leaves now, not a frame later
        self._pump_module(j, False)

    def _run_group(self, j0: int, j1: int, late: float) -> None:
        """The frames of modules *j0* … *j1* − 1 (a phase group), which start *late* [s] after
        their deadline, advanced together (:class:`~firmware_sim.nav.lockstep.Lockstep`: the same
        loops as one by one, the quiet stretches of all in one compiled call); each module's busy
        time is its share of the group's."""
        members, done, over = self.members, self.done, self.limits
        ks = range(j0, j1)
        lag = lag_class(late, self.bounds)
        for k in ks:
            members[k].count_frame(late, late > over[k], lag)
        target = self.sched.frame_end()
        lock = self.locksteps[j0]
        s = self.perf()
        try:
            while True:
                limits = [target - done[k] for k in ks]
                if max(limits) <= 0:
                    break
                for k, n in zip(ks, lock.advance(limits), strict=True):
                    done[k] += n
                    members[k].ticks += n
        except BaseException as e:  # not known which of the group's modules raised: all stop
            for k in ks:
                members[k].error = members[k].error or e
            raise
        dt = self.perf() - s
        self.round_busy += dt
        share = dt / len(ks)
        for k in ks:
            members[k].after_frame(share)
            # what the frame sent leaves now, not a frame later
            self._pump_module(k, False)

    def _end_round(self) -> bool:
        """Every module ran its frame; True after 8 such rounds back to back."""
        # spin through the idle time if the frames take most of the period (see the package doc)
        self.spinning = self.spin_busy is not None and self.round_busy > self.spin_busy
        self.round_busy = 0.0
        self.ran += 1
        if self.ran >= 8:
            self.ran = 0
            return True
        return False

    # ------------------------------------------------------------------ between frames
    def _wait(self) -> None:
        """Until the next deadline or bytes due at a host: spin, or sleep in select (a host's
        bytes wake it: :meth:`_serve_hosts`)."""
        wait = min(self.sched.deadline(), self.releases.earliest()) - self.perf()
        if self.spinning and wait > 0:
            self._spin(wait)
            return
        ready = self.pumps.select(max(wait, 0.0))
        if ready:
            self._serve_hosts(ready)
        elif ready is None and wait > 0:
            self._stop.wait(wait)

    def _spin(self, wait: float) -> None:
        # busy-wait without system calls (a kernel entry leaves the next step with
        # cold caches and branch predictors); look at the hosts once per frame
        perf = self.perf
        target = perf() + wait
        f = self.sched.f
        if f != self.polled:
            self.polled = f
            for i in self.pumps.select(0) or ():
                self.pumps.pump(i, f)
        while perf() < target:
            pass

    def _serve_hosts(self, ready: list[int]) -> None:
        """Pump the endpoints whose fds turned readable."""
        now = self.perf()
        sched = self.sched
        for i in ready:
            self.pumps.pump(i, sched.f)
            k = self.pumps.owner[i]
            if self.releases.links[k]:
                self.releases.update(k)
            on_time = self.ahead[k] <= 0
            if sched.frame_ticks > 1 or on_time:
                # a host wrote: its module catches up with the wall clock now (the ticks already
                # due), so the command is not held to the frame's end; a module that does not run
                # ahead also runs its next loop, which takes the bytes, up to COMMAND_LEAD_TICKS
                # ahead of its last interrupt (the package doc)
                due = (sched.taking_bytes(k, now, self.done[k], COMMAND_LEAD_TICKS) if on_time
                       else sched.ticks_due(k, now))
                if due > self.done[k]:
                    self._run_to(k, due)
                    self._pump_module(k, True)

    # ------------------------------------------------------------------ ticks and pumps
    def _run_to(self, k: int, target: int) -> float:
        """Run module k until it has run *target* ticks; returns the wall time it took."""
        p = self.members[k]
        adv = self._advances[k]
        s = self.perf()
        d = self.done[k]
        try:
            while d < target:
                d += adv(target - d)
        except BaseException as e:
            p.error = p.error or e
            raise
        finally:
            p.ticks += d - self.done[k]
            self.done[k] = d
        dt = self.perf() - s
        p.after_frame(dt)
        return dt

    def _pump_module(self, k: int, force: bool) -> None:
        """Pump module *k*'s endpoints (see :meth:`Pumps.pump_owned`), then look again at its releases."""
        self.pumps.pump_owned(k, force, self.sched.f)
        if self.releases.links[k]:
            self.releases.update(k)

    def _release_due(self, now: float) -> None:
        self.releases.release_due(now, self._hand_over)

    def _hand_over(self, k: int) -> None:
        self._pump_module(k, True)
