"""Seeded fault injection on a link (:class:`~firmware_sim.links.link.Link`): per direction byte
loss, corruption and stalls, and link-wide disconnects with or without a reconnect.

The faults (:class:`LinkFaults`, per direction) add seeded byte loss, corruption, stalls and
disconnects on top of the link's own losses; the link's runtime controls (``disconnect``,
``reconnect``, ``stall``, ``corrupt_next``, ``drop_next``) let a control channel drive them. Every
lost or corrupted byte is counted in the link's ``counters``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np

__all__ = ["DIRECTIONS", "Direction", "DirectionFaults", "LinkFaults", "random_byte_faults"]

Direction = Literal["to_module", "to_host"]
DIRECTIONS: tuple[Direction, Direction] = ("to_module", "to_host")

#: The most random stalls or disconnects a second a link takes. A stall lasts 0.1–2 s and a link
#: comes back 0.5–2 s after a disconnect, so far below this a link is down all the time; above it a
#: module's 1-ms tick would have more than one event to play, and an infinite rate one every cycle
#: (a loop that never ends).
MAX_EVENT_RATE_HZ = 100.0


def rate_refusal(name: str, rate: float) -> str | None:
    """Why *rate* [events a second] is refused for the fault *name*, or None."""
    if 0.0 <= rate <= MAX_EVENT_RATE_HZ:  # NaN and inf too
        return None
    return f"{name} must be a rate from 0 to {MAX_EVENT_RATE_HZ:g} a second, got {rate}"


@dataclass(frozen=True)
class DirectionFaults:
    """Faults injected on one direction of a link (all off by default).

    ``byte_loss`` and ``corrupt`` are per-byte probabilities (a corrupted byte is
    XORed with a random non-zero value); ``stall_rate_hz`` is the mean number of
    stalls per second of virtual time (Poisson), each lasting a uniform draw
    from :attr:`LinkFaults.stall_s`.
    """

    byte_loss: float = 0.0
    corrupt: float = 0.0
    stall_rate_hz: float = 0.0

    def __post_init__(self) -> None:
        for name in ("byte_loss", "corrupt"):
            p = getattr(self, name)
            if not 0.0 <= p <= 1.0:
                raise ValueError(f"{name} must be a probability in [0, 1], got {p}")
        refusal = rate_refusal("stall_rate_hz", self.stall_rate_hz)
        if refusal is not None:
            raise ValueError(refusal)

    @property
    def any(self) -> bool:
        return bool(self.byte_loss or self.corrupt or self.stall_rate_hz)


@dataclass(frozen=True)
class LinkFaults:
    """Seeded fault injection for a link, per direction plus link-wide disconnects.

    ``disconnect_rate_hz``: mean disconnects per second (Poisson); after one the
    link reconnects by itself after a uniform draw from ``reconnect_s``
    (``None``: it stays down until :meth:`.Link.reconnect`).
    """

    to_module: DirectionFaults = field(default_factory=DirectionFaults)
    to_host: DirectionFaults = field(default_factory=DirectionFaults)
    stall_s: tuple[float, float] = (0.1, 2.0)
    disconnect_rate_hz: float = 0.0
    reconnect_s: tuple[float, float] | None = (0.5, 2.0)

    def __post_init__(self) -> None:
        lo, hi = self.stall_s
        if not 0 <= lo <= hi:
            raise ValueError(f"stall_s must be (min, max) with 0 <= min <= max, got {self.stall_s}")
        refusal = rate_refusal("disconnect_rate_hz", self.disconnect_rate_hz)
        if refusal is not None:
            raise ValueError(refusal)
        if self.reconnect_s is not None and not 0 <= self.reconnect_s[0] <= self.reconnect_s[1]:
            raise ValueError(f"reconnect_s must be (min, max) or None, got {self.reconnect_s}")

    @classmethod
    def both(cls, byte_loss: float = 0.0, corrupt: float = 0.0, stall_rate_hz: float = 0.0,
             **kw: object) -> LinkFaults:
        """The same per-direction faults on both directions."""
        d = DirectionFaults(byte_loss=byte_loss, corrupt=corrupt, stall_rate_hz=stall_rate_hz)
        return cls(to_module=d, to_host=d, **kw)  # type: ignore[arg-type]

    def direction(self, d: Direction) -> DirectionFaults:
        return self.to_module if d == "to_module" else self.to_host


def random_byte_faults(data: bytearray, f: DirectionFaults,
                       rng: np.random.Generator) -> tuple[bytearray, int, int]:
    """*f*'s random corruption, then its random loss, on *data* (bytes being delivered), drawn from
    *rng*: the bytes left, how many were corrupted and how many lost."""
    corrupted = lost = 0
    n = len(data)
    if f.corrupt:
        hit = np.flatnonzero(rng.random(n) < f.corrupt)
        if hit.size:
            flips = rng.integers(1, 256, size=hit.size)
            for i, x in zip(hit.tolist(), flips.tolist(), strict=True):
                data[i] ^= x
            corrupted = int(hit.size)
    if f.byte_loss:
        keep = rng.random(n) >= f.byte_loss
        lost = n - int(keep.sum())
        if lost:
            data = bytearray(np.frombuffer(bytes(data), dtype=np.uint8)[keep].tobytes())
    return data, corrupted, lost
