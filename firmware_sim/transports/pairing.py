"""Waiting for a host to pair or leave, for endpoints driven by the pacer's loop."""

from __future__ import annotations

import threading


class PairingEvents:
    """Mixin: :meth:`wait_paired` for other threads, ``_notify()`` from the pacer's loop.

    The endpoint provides a ``paired`` attribute or property and calls
    ``_notify()`` whenever it changes.
    """

    paired: bool

    def _init_pairing(self) -> None:
        self._changed = threading.Condition()

    def wait_paired(self, paired: bool = True, timeout: float | None = None) -> bool:
        """Block until a host is (``paired=True``) or is no longer (False) connected;
        False on timeout. Thread-safe: the pacer's loop notifies every change."""
        with self._changed:
            return self._changed.wait_for(lambda: self.paired == paired, timeout)

    def _notify(self) -> None:
        with self._changed:
            self._changed.notify_all()
