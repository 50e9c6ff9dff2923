"""The scheduling priority of a real-time loop's thread: the wall clock's deadlines before other work.

On a machine shared with other busy processes a loop at the ordinary priority waits in the
kernel's run queue: measured on the 2-core VM under load 3–6, a serve process of 50 modules
spent a quarter of its wall time runnable but not running, and its frames started up to 250 ms
late, each wait a multiple of the other processes' time slices (4 ms). A thread under the
real-time policy ``SCHED_FIFO`` runs as soon as it is runnable, before every ordinary process,
which still have the CPU time the loop leaves (it sleeps between frames; the kernel keeps 5 %
of each core for ordinary processes even from a real-time thread that never sleeps).

Two such loops that the kernel keeps on one core (each wakes where it ran last, and each sleeps
while the other runs) can fill it: the kernel then gives the ordinary processes there 50 ms of each
second at once (its fair server; on older kernels, real-time throttling), and both loops stop for
those 50 ms. Measured with two serve processes of 50 modules each at SCHED_FIFO 10: some 18 frames
of every module over 35 ms late, the worst 51-59 ms, in 1 and in 10 minutes alike. Each loop on a
core of its own (:func:`pin_to_cpu`) leaves every core half free.

Linux lets a process ask for it with ``CAP_SYS_NICE`` (root) or an ``RLIMIT_RTPRIO`` of at least the
level (``ulimit -r``; e.g. ``@audio - rtprio 20`` in ``/etc/security/limits.conf``). Where it may not,
the thread keeps its ordinary priority and :func:`raise_priority` says why. The threads and the
processes it starts run at the ordinary priority (``SCHED_RESET_ON_FORK``: a web panel's thread, a
child process), so a loop raises itself when it starts.
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


def allowed_cpus() -> set[int]:
    """The CPUs this process may run on (all of them where the system does not say)."""
    getter = getattr(os, "sched_getaffinity", None)
    return set(getter(0)) if getter is not None else set(range(os.cpu_count() or 1))


def pin_to_cpu(cpu: int | None) -> str:
    """Keep the calling thread (and the threads it starts from now on) on CPU *cpu* (None: leave
    it where the kernel puts it); where it runs now, e.g. ``"CPU 1"``, or ``"any CPU (…)"``."""
    if cpu is None:
        return "any CPU"
    setter = getattr(os, "sched_setaffinity", None)
    if setter is None:
        return "any CPU (no CPU affinity on this system)"
    try:
        setter(0, {cpu})
    except OSError as exc:
        return f"any CPU (CPU {cpu} refused: {exc.strerror or exc})"
    return f"CPU {cpu}"


def lower_priority() -> None:
    """The calling thread back under the ordinary policy (always allowed)."""
    setter = getattr(os, "sched_setscheduler", None)
    if setter is not None:
        try:
            setter(0, os.SCHED_OTHER, os.sched_param(0))
        except OSError:
            pass
