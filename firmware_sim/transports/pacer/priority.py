"""The scheduling priority of a real-time loop's thread: the wall clock's deadlines before other work.

On a machine shared with other busy processes a loop at the ordinary priority waits in the
kernel's run queue: measured on the 2-core VM under load 3–6, a serve process of 50 modules
spent a quarter of its wall time runnable but not running, and its frames started up to 250 ms
late, each wait a multiple of the other processes' time slices (4 ms). A thread under the
real-time policy ``SCHED_FIFO`` runs as soon as it is runnable, before every ordinary process,
which still have the CPU time the loop leaves (it sleeps between frames; the kernel keeps 5 %
of each core for ordinary processes even from a real-time thread that never sleeps).

Linux lets a process ask for it with ``CAP_SYS_NICE`` (root) or an ``RLIMIT_RTPRIO`` of at least the
level (``ulimit -r``; e.g. ``@audio - rtprio 20`` in ``/etc/security/limits.conf``). Where it may not,
the thread keeps its ordinary priority and :func:`raise_priority` says why. Children forked by the
thread start at the ordinary priority (``SCHED_RESET_ON_FORK``).
"""

from __future__ import annotations

import os

#: The real-time levels a loop may ask for (Linux: 1 … 99; the kernel's own threads use 50 and 99).
LEVELS = range(1, 100)


def check_level(level: int | None) -> None:
    """Refuse a level that is not None or in :data:`LEVELS` (ValueError)."""
    if level is not None and level not in LEVELS:
        raise ValueError(f"a real-time priority is a level from 1 to 99 (or none), got {level!r}")


def raise_priority(level: int | None) -> str:
    """Run the calling thread under ``SCHED_FIFO`` at *level* (None: leave it as it is); what it runs
    under now, e.g. ``"SCHED_FIFO 10"``, or ``"normal (…)"`` with the reason it stayed there."""
    check_level(level)
    if level is None:
        return "normal"
    setter = getattr(os, "sched_setscheduler", None)
    if setter is None:
        return "normal (no real-time scheduling on this system)"
    try:
        setter(0, os.SCHED_FIFO | getattr(os, "SCHED_RESET_ON_FORK", 0), os.sched_param(level))
    except OSError as exc:
        why = exc.strerror or str(exc)
        return f"normal (SCHED_FIFO {level} refused: {why}; needs CAP_SYS_NICE or ulimit -r >= {level})"
    return f"SCHED_FIFO {level}"


def lower_priority() -> None:
    """The calling thread back under the ordinary policy (always allowed)."""
    setter = getattr(os, "sched_setscheduler", None)
    if setter is not None:
        try:
            setter(0, os.SCHED_OTHER, os.sched_param(0))
        except OSError:
            pass
