"""What holds a loop's thread up besides its own work: CPU taken by other processes, the garbage collector.

Two causes of a late frame that the loop's own timing cannot tell apart from slow ticks, measured
so that a status (and ``python -m lab.bench realtime``) can say which one it was:

* the *run queue*: the thread was runnable but another process had the CPU (Linux's
  ``/proc/self/task/<id>/schedstat``: :func:`run_queue_wait_s`); the remedy is the real-time
  priority (:mod:`.priority`);
* the *cyclic garbage collector*: a collection stops every thread of the process while it runs
  (:class:`GcPauses` counts those that ran while the loop did, and the longest); ``serve``
  freezes what exists before its loop starts (``gc.freeze``), so a collection only looks at what
  the loop made since.
"""

from __future__ import annotations

import gc
import time
from typing import Any


def run_queue_wait_s(thread_id: int | None) -> float | None:
    """Seconds thread *thread_id* (a native id) of this process was runnable but waited for a CPU,
    from Linux's ``/proc/self/task/<id>/schedstat``; None where that is not known."""
    if thread_id is None:
        return None
    try:
        with open(f"/proc/self/task/{thread_id}/schedstat") as f:
            return int(f.read().split()[1]) / 1e9
    except (OSError, ValueError, IndexError):
        return None


class GcPauses:
    """The garbage collector's runs while a loop runs (:meth:`watch` … :meth:`unwatch`): how many,
    and the longest [s] with its generation."""

    def __init__(self) -> None:
        self.count = 0
        self.longest = 0.0
        self.longest_generation = -1
        self._began = 0.0

    def _note(self, phase: str, info: dict[str, Any]) -> None:
        now = time.perf_counter()
        if phase == "start":
            self._began = now
            return
        self.count += 1
        took = now - self._began
        if took > self.longest:
            self.longest = took
            self.longest_generation = info.get("generation", -1)

    def watch(self) -> None:
        if self._note not in gc.callbacks:
            gc.callbacks.append(self._note)

    def unwatch(self) -> None:
        if self._note in gc.callbacks:
            gc.callbacks.remove(self._note)
