"""Waiting on a running module's ticks: threads block until a condition holds after ticks ran."""

from __future__ import annotations

import threading
from collections.abc import Callable


class _Waiter:
    """One waiting thread's condition, tested in the loop's thread."""

    __slots__ = ("test", "met", "error")

    def __init__(self, test: Callable[[], object]):
        self.test = test
        self.met = False
        self.error: Exception | None = None

    def settle(self) -> None:
        try:
            self.met = bool(self.test())
        except Exception as e:  # noqa: BLE001 - handed to the waiting thread
            self.error = e
            self.met = True


class TickWaits:
    """Threads waiting until a condition holds after a module's ticks.

    :meth:`wait` blocks its caller on a :class:`threading.Condition`; the loop that
    runs the module calls :meth:`check` after every run of ticks (in its own thread,
    where the module may be read), which tests the waiting conditions and wakes the
    threads whose condition holds, and :meth:`end` when it stops, which wakes them all.
    Without waiters :meth:`check` costs one test of an empty list."""

    def __init__(self) -> None:
        self._cond = threading.Condition()
        self._waiters: list[_Waiter] = []
        self._ended = False

    def wait(self, test: Callable[[], object], timeout: float | None = None) -> bool:
        """Block until *test()*, run in the loop's thread after ticks, is true: True; or False
        after *timeout* seconds (None: no limit), or once the loop has stopped. What *test*
        raises is raised here."""
        waiter = _Waiter(test)
        with self._cond:
            if self._ended:
                return False
            self._waiters.append(waiter)
            try:
                self._cond.wait_for(lambda: waiter.met or self._ended, timeout)
            finally:
                self._waiters.remove(waiter)
        if waiter.error is not None:
            raise waiter.error
        return waiter.met

    def check(self) -> None:
        """In the loop's thread, after ticks: test the waiting conditions, wake those met."""
        if not self._waiters:
            return
        with self._cond:
            woke = False
            for waiter in self._waiters:
                if not waiter.met:
                    waiter.settle()
                    woke = woke or waiter.met
            if woke:
                self._cond.notify_all()

    def begin(self) -> None:
        """The loop (re)starts: waits block again."""
        with self._cond:
            self._ended = False

    def end(self) -> None:
        """The loop stopped: every wait returns (False, unless its condition was met)."""
        with self._cond:
            self._ended = True
            self._cond.notify_all()
