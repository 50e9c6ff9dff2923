"""What a link (:class:`~firmware_sim.links.link.Link`) counts: bytes per direction (sent, on the wire,
delivered, lost by cause, corrupted, late), stalls and connection changes."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

from .faults import Direction

__all__ = ["DirectionCounters", "LinkCounters"]


@dataclass
class DirectionCounters:
    """Byte counts of one direction. ``lost`` is the sum of every ``lost_*``."""

    sent: int = 0  #: bytes that entered the link (host_write accepted / tx_write)
    wire: int = 0  #: bytes that crossed the UART / USB wire
    delivered: int = 0  #: bytes that reached the far end (read by the µC / in the host's buffer)
    lost_overflow: int = 0  #: a buffer on the way was full (receive ring, radio, host buffer)
    lost_refused: int = 0  #: host_write could not take them (disconnected or too much in flight)
    lost_fault: int = 0  #: dropped by injected byte loss
    lost_disconnect: int = 0  #: in flight when the link went down
    corrupted: int = 0  #: delivered with injected corruption
    #: real time only: bytes that reached the far end more than ``late_tolerance_cycles`` after
    #: their arrival time, and the largest lateness seen [cycles] (0 in virtual time)
    late: int = 0
    late_max_cycles: int = 0

    @property
    def lost(self) -> int:
        return self.lost_overflow + self.lost_refused + self.lost_fault + self.lost_disconnect


@dataclass
class LinkCounters:
    """Everything a link counts: per direction, plus stalls and connection changes."""

    to_module: DirectionCounters = field(default_factory=DirectionCounters)
    to_host: DirectionCounters = field(default_factory=DirectionCounters)
    stalls: int = 0
    disconnects: int = 0
    connects: int = 0

    def direction(self, d: Direction) -> DirectionCounters:
        return self.to_module if d == "to_module" else self.to_host

    def as_dict(self) -> dict[str, object]:
        out = asdict(self)
        out["to_module"]["lost"] = self.to_module.lost
        out["to_host"]["lost"] = self.to_host.lost
        return out
