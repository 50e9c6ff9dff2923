"""Pumps: the endpoints of a loop, pumped when worth it, their fds watched by one selector."""

from __future__ import annotations

import selectors
from collections.abc import Callable

from .endpoints import Endpoint
from .member import PacedModule

#: How many times *poll* frames pass between two pumps of a quiet endpoint whose fds are watched: a
#: host's bytes or its leaving wake the loop through them, so such a pump only catches what else an
#: endpoint keeps (a TCP host's bytes the socket did not take yet).
WATCHED_POLL = 10


class Pumps:
    """Every endpoint of the modules of a loop, numbered in the modules' order.

    :meth:`pump` pumps one and keeps its fds registered with the selector (whose
    key data is the endpoint's number). An endpoint of a module is pumped after the
    module's frame (:meth:`pump_owned`) only if its port has bytes for the host, or
    *poll* frames passed since its last pump (:data:`WATCHED_POLL` times that for one whose fds
    are watched; see the package doc); *idle_pump_s* 0: always."""

    def __init__(self, members: list[PacedModule], idle_pump_s: float, poll: int):
        self.members = members
        self.eps: list[Endpoint] = [ep for p in members for ep in p.endpoints]
        self.owner: list[int] = [j for j, p in enumerate(members) for _ in p.endpoints]
        self.pending: list[Callable[[], int] | None] = [
            None if idle_pump_s == 0 else getattr(getattr(ep, "port", None), "host_pending", None)
            for ep in self.eps]
        self.poll = poll
        self.last = [0 for _ in self.eps]  # the frame of each endpoint's last pump
        self._registered: list[tuple[int, ...]] = [() for _ in self.eps]
        self._lo: list[int] = []  # module k's endpoints are lo[k] … hi[k] - 1
        self._hi: list[int] = []
        for p in members:
            self._lo.append(self._hi[-1] if self._hi else 0)
            self._hi.append(self._lo[-1] + len(p.endpoints))
        # select(2) sleeps to the microsecond; epoll and poll round a timeout up to a millisecond
        self._sel: selectors.BaseSelector = selectors.SelectSelector()

    def pump(self, i: int, f: int) -> None:
        """Pump endpoint *i* in frame *f* (what it raises is its module's error)."""
        ep = self.eps[i]
        try:
            ep.pump()
        except BaseException as e:
            p = self.members[self.owner[i]]
            p.error = p.error or e
            raise
        self.last[i] = f
        self._sync(i)

    def refresh(self) -> None:
        """Watch every endpoint's fds as they are now, where something other than a pump changed
        them (a control call that hung a host up): the selector must never hold a closed fd, or
        the next select fails."""
        for i in range(len(self.eps)):
            self._sync(i)

    def _sync(self, i: int) -> None:
        fds = getattr(self.eps[i], "fds", ())
        if fds != self._registered[i]:
            self._register(i, fds)

    def _register(self, i: int, fds: tuple[int, ...]) -> None:
        old = self._registered[i]
        for fd in old:
            if fd not in fds:
                try:
                    self._sel.unregister(fd)
                except (KeyError, ValueError, OSError):
                    pass
        ok = []
        for fd in fds:
            if fd in old:
                ok.append(fd)
                continue
            try:
                self._sel.register(fd, selectors.EVENT_READ, i)
                ok.append(fd)
            except (KeyError, ValueError, OSError):
                continue
        self._registered[i] = tuple(ok)

    def pump_all(self, f: int) -> None:
        for i in range(len(self.eps)):
            self.pump(i, f)

    def pump_owned(self, k: int, force: bool, f: int) -> None:
        """Pump module *k*'s endpoints that are worth it in frame *f* (*force*: all of them)."""
        pending, last, registered = self.pending, self.last, self._registered
        poll, watched = self.poll, self.poll * WATCHED_POLL
        for i in range(self._lo[k], self._hi[k]):
            has = pending[i]
            if force or has is None or has() or f - last[i] >= (watched if registered[i] else poll):
                self.pump(i, f)

    def select(self, timeout: float) -> list[int] | None:
        """The endpoints whose fds turn readable within *timeout* [s]; None (at once) if none has an fd."""
        if not self._sel.get_map():
            return None
        return [key.data for key, _ in self._sel.select(timeout)]

    def close(self) -> None:
        """Close the selector, then every endpoint (one that fails does not keep the others open)."""
        self._sel.close()
        for ep in self.eps:
            try:
                ep.close()
            except Exception:  # noqa: BLE001 - closing must go on for the others
                pass
