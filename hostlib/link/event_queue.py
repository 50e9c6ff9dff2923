"""The bounded queues a :class:`~hostlib.link.device.Device` hands its packets and steps out of.

The reader thread puts events in; user calls take them out with deadlines. A full queue drops the new
event, counts it and warns once per episode; the close marker :data:`CLOSED` always fits, so a reader
blocked on a full queue still learns that the device closed.
"""

from __future__ import annotations

import queue
import time
import warnings
from typing import Any

from ..errors import QueueFullWarning

__all__ = ["CLOSED", "BoundedQueue"]

#: The marker put in the queues on close, to wake their iterators.
CLOSED = object()


class BoundedQueue:
    """A bounded FIFO of events; a full queue drops the new event, counts it and warns once per episode.
    The bound applies to events only: the close marker always fits, so a reader blocked on a full
    queue still learns that the device closed."""

    def __init__(self, name: str, maxsize: int):
        if maxsize < 1:
            raise ValueError(f"queue_size must be >= 1, got {maxsize}")
        self.name = name
        self.maxsize = maxsize
        self.q: queue.Queue = queue.Queue()  # bounded by hand in put()
        self.dropped = 0
        self._warned = False

    def put(self, item: Any) -> None:
        if self.q.qsize() >= self.maxsize:
            self.dropped += 1
            if not self._warned:
                self._warned = True
                warnings.warn(
                    f"the {self.name} queue is full ({self.maxsize}); events are being dropped "
                    f"(counted in dropped_{self.name}); read them faster or raise queue_size",
                    QueueFullWarning,
                    stacklevel=2,
                )
            return
        self.q.put_nowait(item)
        self._warned = False

    def close(self) -> None:
        self.q.put_nowait(CLOSED)

    def get(self, deadline: float | None) -> Any:
        """The next item, or None when the deadline passes (None = wait forever)."""
        if deadline is None:
            return self.q.get()
        remaining = deadline - time.monotonic()
        try:
            return self.q.get(timeout=remaining) if remaining > 0 else self.q.get_nowait()
        except queue.Empty:
            return None
