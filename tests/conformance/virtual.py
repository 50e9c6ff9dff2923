"""An in-process, virtual-time serial port onto an emulated module's interface (test helper).

It has the pyserial methods the conformance driver uses. Reading steps the
module tick by tick until bytes arrive or the read timeout has passed in
*virtual* time, so a whole conformance run is deterministic and takes only as
long as the emulator needs to compute. :meth:`now` is the driver's clock.
"""

from __future__ import annotations

from firmware_sim.module import Module


class VirtualSerial:
    """pyserial-like ``read``/``write`` on one interface of a :class:`Module`, in virtual time."""

    def __init__(self, module: Module, interface: str = "usb", timeout: float = 0.005):
        self.module = module
        self.iface = getattr(module, interface)
        self.port = self.iface.port
        self.timeout = timeout
        self._buf = bytearray()
        self.is_open = True

    def now(self) -> float:
        """Virtual seconds since boot."""
        return self.module.clock.ticks / self.module.config.rate_hz

    def _take(self) -> None:
        self._buf += self.port.host_read()

    @property
    def in_waiting(self) -> int:
        self._take()
        return len(self._buf)

    def write(self, data: bytes) -> int:
        return self.port.host_write(bytes(data))

    def flush(self) -> None:
        pass

    def read(self, n: int = 1) -> bytes:
        self._take()
        ticks = max(1, round((self.timeout or 0) * self.module.config.rate_hz))
        while len(self._buf) < n and ticks > 0:
            self.module.step()
            ticks -= 1
            self._take()
        out = bytes(self._buf[:n])
        del self._buf[:n]
        return out

    def close(self) -> None:
        self.is_open = False

    def __repr__(self) -> str:
        return f"VirtualSerial({self.module!r}, buffered {len(self._buf)} B)"
