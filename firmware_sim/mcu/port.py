"""The module-facing side of a link (docs/design.md "Ports") and the ideal link.

A :class:`Port` is what the µC's USB or Bluetooth driver sees: a receive ring it
reads command bytes from, a transmit ring it writes packets into, and a
"connected" line (USB attached / Bluetooth paired). The host-facing methods
(``host_write``, ``host_read``, ``connect``, ``disconnect``) are what a
transport or a test uses on the other end. Link models with finite rates and
fault injection live in :mod:`firmware_sim.links.link`; :class:`IdealPort` here has no
limits at all and is the default for tests.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

#: What :meth:`IdealPort.tx_free` reports: practically unlimited.
UNLIMITED = 1 << 30


@runtime_checkable
class Port(Protocol):
    """One link between the module and a host, seen from both ends."""

    connected: bool

    # module side
    def advance(self, now_cycles: int) -> None:
        """Move the link to virtual time *now_cycles* (called once per tick, before receive)."""
        ...

    def rx_read(self, max_n: int) -> bytes:
        """Up to *max_n* bytes from the µC's receive ring."""
        ...

    def tx_free(self) -> int:
        """Bytes the µC's transmit ring accepts now."""
        ...

    def tx_write(self, data: bytes) -> None:
        """Put *data* (at most :meth:`tx_free` bytes) into the transmit ring."""
        ...

    # host side
    def host_write(self, data: bytes) -> int:
        """Host sends *data*; returns the bytes accepted (the rest is lost and counted)."""
        ...

    def host_read(self, max_n: int = -1) -> bytes:
        """Bytes the module sent that reached the host (all of them with -1)."""
        ...

    def connect(self) -> None: ...

    def disconnect(self) -> None: ...

    # optional: ``quiet_until() -> int | None`` and ``idle() -> bool`` (see IdealPort). A
    # port that has them lets the compiled path run quiet stretches of loops in one call.


class IdealPort:
    """An unbounded, instantaneous, lossless link (connected at start by default).

    While disconnected, bytes written by the host are lost (counted in
    ``host_bytes_lost``), as on a cable that is not plugged in.
    """

    def __init__(self, connected: bool = True):
        self.connected = connected
        self._rx = bytearray()  # host → module
        self._tx = bytearray()  # module → host
        self.now_cycles = 0
        self.host_bytes_lost = 0
        self.bytes_to_module = 0
        self.bytes_to_host = 0

    # module side ------------------------------------------------------------
    def advance(self, now_cycles: int) -> None:
        self.now_cycles = now_cycles

    def quiet_until(self) -> int | None:
        """A lower bound of the first cycle at which :meth:`advance` changes what the module
        or the host sees, if the host writes nothing: None = never; the current time or
        earlier = not quiet now. An ideal port is quiet while its receive ring is empty."""
        return self.now_cycles if self._rx else None

    def idle(self) -> bool:
        """Whether advancing once to a later time equals advancing tick by tick (always)."""
        return True

    def rx_read(self, max_n: int) -> bytes:
        if not self._rx:
            return b""
        data = bytes(self._rx[:max_n])
        del self._rx[:max_n]
        return data

    def rx_pending(self) -> int:
        """Bytes waiting in the receive ring."""
        return len(self._rx)

    def tx_free(self) -> int:
        return UNLIMITED

    def tx_write(self, data: bytes) -> None:
        self._tx += data
        self.bytes_to_host += len(data)

    # host side --------------------------------------------------------------
    def host_write(self, data: bytes) -> int:
        if not self.connected:
            self.host_bytes_lost += len(data)
            return 0
        self._rx += data
        self.bytes_to_module += len(data)
        return len(data)

    def host_read(self, max_n: int = -1) -> bytes:
        if max_n < 0 or max_n >= len(self._tx):
            data = bytes(self._tx)
            self._tx.clear()
            return data
        data = bytes(self._tx[:max_n])
        del self._tx[:max_n]
        return data

    def connect(self) -> None:
        self.connected = True

    def disconnect(self) -> None:
        self.connected = False

    def __repr__(self) -> str:
        state = "connected" if self.connected else "disconnected"
        return f"IdealPort({state}, rx pending {len(self._rx)} B, tx pending {len(self._tx)} B)"
