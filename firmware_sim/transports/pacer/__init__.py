"""Real-time pacing: run modules' ticks against the wall clock and pump transports.

One loop (in one thread) owns the modules and every endpoint, so nothing needs
a lock except the control queues (:meth:`~.single.Pacer.call`), the waits on ticks
(:meth:`~.single.Pacer.wait_ticks`, below) and the status snapshots.
A :class:`Pacer` is one module with its endpoints; run alone it has a loop of
its own, and a :class:`MultiPacer` runs many of them — every module of a
``serve`` process — in one loop and one thread (one thread per module would
make them fight over the GIL).

Tick *n* is run at or after its wall-clock deadline ``t0 + n / (rate · speed)``
— never before, so no module is ever ahead of real time, except by the
*lookahead* of its links (below), which no host can see, and by the tick a host's
bytes arrived in (below). A multi-pacer wakes a
module once per *frame* of ``frame_ticks`` ticks (default 1) and runs the
frame's ticks back to back with :meth:`Module.advance
<firmware_sim.mcu.module.Module.advance>` — so the compiled path runs a quiet frame
in one call — at the deadline of its last tick; what they sent goes to the
hosts then. So a frame of F ticks lets output leave up to F − 1 ticks later
than tick by tick (a few ms, inside the Bluetooth link's own 0–20 ms jitter),
for a fraction of the CPU. A host's bytes do not wait for the frame: when an
endpoint's fd turns readable, its module at once runs the ticks already due, so
a command is answered as soon as tick by tick. A module that does not run ahead (no
lookahead: an ideal or a USB link) then also runs its next loop — the one that takes
the bytes on the module, whose receive_command() comes first — at once rather than at
its interrupt, if that interrupt is at most two ticks away (``COMMAND_LEAD_TICKS``;
two, so that a host's next command, sent in the same tick, is taken at once too): a
command is answered in the time of its own loop, not up to a tick later, and the
module is less than two ticks ahead until their deadlines (the bytes and the
module's time are those of tick by tick). In a multi-pacer each module
has a *phase*: ``phases`` groups (default: one per module) due evenly spread
over the frame, at ``t0 + (f + 1) · F · period + k · F · period / phases`` for
group *k* — like real modules, whose timers were started at different moments.
So the work is spread over the frame instead of a burst at its start, and a
module's lateness is its own, not the sum of the modules run before it. The modules
of one phase (a *phase group*: ``phases`` fewer than the modules) are advanced
together (:class:`~firmware_sim.nav.lockstep.Lockstep`: the same loops as one by one,
their quiet stretches in one compiled call), and share the group's lateness and busy time.

In real time a module behind link models (:class:`~firmware_sim.links.link.Link`)
runs *ahead* of the wall clock by its *lookahead*: the links' one-way latency
less one tick (19 ms behind Bluetooth, 0 behind USB or an ideal port, whose
links then stay on the module's clock as in virtual time). The pacer gives the
links of a module that runs ahead a host clock (the wall clock in module
cycles, on the module's own phase), so a host's bytes leave at the host's present and the
module's bytes reach the host when the wall clock passes their arrival time —
not earlier because the module is ahead, not later because it is late. No
host byte can arrive in the module's past while it is at most one latency
ahead. So a host sees the link model's timing exactly as long as every frame is
computed before its first tick's output is due at the host: a frame may start
up to lookahead + latency − one frame after its (early) deadline — 35 ms with
4-ms frames behind Bluetooth — and the machine's own hiccups (this VM stops a
process for 5–15 ms now and then) are absorbed. A frame that starts later than
that (``overrun_s``, if given; at least one frame) counts an *overrun* for its
module: a host could have seen the lateness. The links count what did reach a
host late (``late`` bytes and ``late_max_cycles`` in their counters; a delivery
up to one frame after its time still counts as on time). The ticks
still all run (virtual time never skips), back to back, until the loop has
caught up. If it falls more than ``max_lag_s`` behind, the schedule is moved
forward (counted in ``rebases``) instead of racing to catch up. ``speed`` = 1
is real time, 10 is ten times faster, 0 (or ``inf``) as fast as the CPU allows
(endpoints are then pumped every ``asap_pump_ticks`` ticks).

Endpoints (TCP server, pty, in-process queues) implement ``pump()`` (move bytes
between the host and their port, connect/disconnect the port as hosts come and go;
non-blocking), optional ``fds`` (file descriptors worth waking up for) and
``close()``. A lone pacer pumps every endpoint on every pass of its loop. A
multi-pacer pumps an endpoint only when one of its fds is readable, when its port
has bytes for the host (``port.host_pending()``; a port without it counts as always
pending), or when ``idle_pump_s`` passed since its last pump (to notice a host that
comes or goes without a readable fd: a pty nobody holds) — ten times that for an
endpoint whose fds are watched, since a host's bytes or its leaving wake the loop
through them — so a quiet module costs its tick and nothing else. Optionally
(``spin_load``, off by default) a multi-pacer whose steps take more than that
fraction of the period busy-waits between deadlines instead of sleeping: on this VM
a step after a sleep costs ~30 % more than back to back (cold caches), but a
spinning loop takes a whole core from the other processes, and measured end to end
it did not win. A lone pacer always sleeps.

Another thread waits on a running module's ticks, not on the clock:
:meth:`~.single.Pacer.wait_ticks` (*n* more ticks ran) and :meth:`~.single.Pacer.wait_until` (a
predicate of the module, tested in the loop's thread after each run of its
ticks) block on a condition the loop notifies, and return False on timeout or
once the loop stopped (:class:`MultiPacer` offers both per module index).

The parts: :mod:`.status` (:class:`PacerStatus`), :mod:`.endpoints` (what is
pumped, the links behind it), :mod:`.member` (:class:`PacedModule`: one module
of a loop, its counters, controls, waits and status), :mod:`.single`
(:class:`Pacer`: one with a loop of its own), :mod:`.group` (:class:`MultiPacer`:
the loop, its thread), :mod:`.run_loop` (one run of the loop, pass after pass),
:mod:`.schedule` (the deadlines), :mod:`.host_clock` (the wall clock in a
module's cycles), :mod:`.release` (bytes due at hosts), :mod:`.pumps` (the
endpoints and their fds), :mod:`.waits` (threads waiting on ticks).
"""

from __future__ import annotations

from .endpoints import Endpoint, links_of
from .group import MultiPacer
from .member import PacedModule
from .single import Pacer
from .status import LAG_BOUNDS_MS, LAG_LABELS, PacerStatus

__all__ = ["LAG_BOUNDS_MS", "LAG_LABELS", "Endpoint", "MultiPacer", "PacedModule", "Pacer", "PacerStatus",
           "links_of"]
