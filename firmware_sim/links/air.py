"""What travels on a link's air (:class:`~firmware_sim.links.link.Link`): chunks of bytes with the
cycle they arrive at, and the stall windows in which a direction delivers nothing."""

from __future__ import annotations

__all__ = ["Chunk", "Stall"]


class Chunk:
    """Bytes travelling together, with the cycle at which they arrive."""

    __slots__ = ("at", "data")

    def __init__(self, at: int, data: bytearray):
        self.at = at
        self.data = data

    def __repr__(self) -> str:
        return f"Chunk(at={self.at}, {self.data.hex(' ')})"


class Stall:
    """A window [start, end) of virtual time in which one direction delivers nothing."""

    __slots__ = ("start", "end")

    def __init__(self) -> None:
        self.start = 0
        self.end = 0

    def hold(self, t: int) -> int:
        """Arrival time of something due at *t*, pushed past the stall if it falls inside."""
        return self.end if self.start <= t < self.end else t
