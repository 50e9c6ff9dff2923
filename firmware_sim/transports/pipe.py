"""In-process byte pipes between a host and one interface of an emulated module.

:class:`VirtualPipe` — deterministic, no threads: a serial-like object whose
``read`` runs the module's ticks in virtual time while the host "waits". The
same host calls give the same bytes, as fast as the CPU allows::

    pipe = VirtualPipe(build_module(), "usb")
    pipe.write(bytes.fromhex("030003"))     # PING
    pipe.read(4, timeout=0.1)                # b'\\xa0\\x03\\x00\\xa3' after a tick or two

:class:`QueueEndpoint` — the real-time counterpart: a thread-safe pair of byte
queues that a :class:`~firmware_sim.transports.pacer.Pacer` pumps into the port
from its own loop, for hosts in the same process (pyserial ``openshoe://`` with
``speed`` > 0).
"""

from __future__ import annotations

import threading
import time

from firmware_sim.mcu.module import Module
from firmware_sim.mcu.port import Port
from protocol.ids import Interface

#: A blocking read (timeout None) in virtual time gives up after this much virtual time.
MAX_VIRTUAL_WAIT_S = 600.0


def interface_of(module: Module, interface: str | int | Interface):
    """The module's USB or Bluetooth interface, by ``"usb"``/``"bt"``/``Interface``."""
    if isinstance(interface, str):
        key = interface.strip().lower()
        if key in ("usb", "1"):
            return module.usb
        if key in ("bt", "bluetooth", "2"):
            return module.bt
        raise ValueError(f"unknown interface {interface!r}; use 'usb' or 'bt'")
    return module.interfaces[Interface(interface)]


class VirtualPipe:
    """A host's serial-like view of one module interface, advancing virtual time as it waits.

    ``timeout`` (seconds of *virtual* time, as pyserial's): ``None`` blocks until
    enough bytes came (at most :data:`MAX_VIRTUAL_WAIT_S`), ``0`` never runs a
    tick, ``t`` runs at most ``t`` seconds of module ticks.
    """

    def __init__(self, module: Module, interface: str | int | Interface = "usb",
                 timeout: float | None = None):
        self.module = module
        self.interface = interface_of(module, interface)
        self.port: Port = self.interface.port
        self.timeout = timeout
        self._buf = bytearray()
        self.closed = False
        self.bytes_written = 0
        self.bytes_refused = 0

    @property
    def rate_hz(self) -> float:
        return self.module.clock.rate_hz

    def _fill(self) -> None:
        self._buf += self.port.host_read()

    def run_for(self, seconds: float) -> None:
        """Let *seconds* of virtual time pass (module ticks) without reading."""
        self.module.run(max(0, round(seconds * self.rate_hz)))

    def write(self, data: bytes) -> int:
        """Send bytes to the module now; returns how many the link accepted."""
        self._check_open()
        n = self.port.host_write(bytes(data))
        self.bytes_written += n
        self.bytes_refused += len(data) - n
        return n

    def read(self, size: int = 1, timeout: float | None | str = "default") -> bytes:
        """Up to *size* bytes; runs ticks until they arrived or the (virtual) timeout passed."""
        self._check_open()
        if timeout == "default":
            timeout = self.timeout
        self._fill()
        if len(self._buf) < size and timeout != 0:
            limit = MAX_VIRTUAL_WAIT_S if timeout is None else float(timeout)
            ticks = max(1, round(limit * self.rate_hz))
            step = self.module.step
            for _ in range(ticks):
                step()
                self._fill()
                if len(self._buf) >= size:
                    break
        data = bytes(self._buf[:size])
        del self._buf[:size]
        return data

    def read_all(self) -> bytes:
        """Everything received so far, without running ticks."""
        self._fill()
        data = bytes(self._buf)
        self._buf.clear()
        return data

    @property
    def in_waiting(self) -> int:
        """Bytes ready to read; when none are, one tick passes (a host polling this waits)."""
        self._fill()
        if not self._buf and not self.closed:
            self.module.step()
            self._fill()
        return len(self._buf)

    def reset_input_buffer(self) -> None:
        self._fill()
        self._buf.clear()

    def close(self) -> None:
        self.closed = True

    def _check_open(self) -> None:
        if self.closed:
            raise ValueError("pipe is closed")

    def __repr__(self) -> str:
        return (f"VirtualPipe({self.interface.name}, t={self.module.clock.time_s:.3f} s, "
                f"{len(self._buf)} B buffered, {'closed' if self.closed else 'open'})")


class QueueEndpoint:
    """Thread-safe byte queues between an in-process host and a port, pumped by a pacer.

    The host thread calls :meth:`write`, :meth:`read`; the pacer's loop calls
    :meth:`pump`, the only place the port is touched. The port is connected
    while the endpoint is open.
    """

    fds: tuple[int, ...] = ()

    def __init__(self, port: Port, max_buffer: int = 1 << 20):
        self.port = port
        self.max_buffer = max_buffer
        self._to_port = bytearray()
        self._from_port = bytearray()
        self._cond = threading.Condition()
        self.closed = False
        self.dropped = 0  #: bytes from the module dropped because the host did not read
        self.refused = 0  #: bytes the link did not accept from the host
        self._pump_thread: int | None = None
        port.connect()

    # pacer side
    def pump(self) -> None:
        self._pump_thread = threading.get_ident()
        with self._cond:
            out = bytes(self._to_port)
            self._to_port.clear()
        if self.closed:
            if self.port.connected:
                self.port.disconnect()
            return
        if out:
            n = self.port.host_write(out)
            self.refused += len(out) - n
        got = self.port.host_read()
        if got:
            with self._cond:
                room = self.max_buffer - len(self._from_port)
                if len(got) > room:
                    self.dropped += len(got) - room
                    got = got[:room]
                self._from_port += got
                self._cond.notify_all()

    # host side
    def write(self, data: bytes) -> int:
        if self.closed:
            raise ValueError("endpoint is closed")
        with self._cond:
            self._to_port += data
        return len(data)

    def read(self, size: int = 1, timeout: float | None = None) -> bytes:
        deadline = None if timeout is None else time.monotonic() + timeout
        with self._cond:
            while len(self._from_port) < size and not self.closed:
                left = None if deadline is None else deadline - time.monotonic()
                if left is not None and left <= 0:
                    break
                self._cond.wait(left)
            data = bytes(self._from_port[:size])
            del self._from_port[:size]
            return data

    @property
    def in_waiting(self) -> int:
        with self._cond:
            return len(self._from_port)

    def reset_input_buffer(self) -> None:
        with self._cond:
            self._from_port.clear()

    def close(self) -> None:
        """Close the host's side; the port is disconnected at the next pump (or now, when
        called from the pumping thread — the pacer closes its endpoints when it stops)."""
        with self._cond:
            self.closed = True
            self._cond.notify_all()
        if self._pump_thread in (None, threading.get_ident()) and self.port.connected:
            self.port.disconnect()

    def status(self) -> dict[str, object]:
        return {"kind": "inproc", "paired": not self.closed, "dropped": self.dropped, "refused": self.refused}

    def __repr__(self) -> str:
        return f"QueueEndpoint({'closed' if self.closed else 'open'}, {self.in_waiting} B to read)"
