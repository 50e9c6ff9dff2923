"""One link shared by several host endpoints (a pty and a TCP port on one interface).

The module's bytes go to every connected host; any host's bytes go to the
module; the link counts as connected while at least one host is attached.
"""

from __future__ import annotations

from firmware_sim.mcu.port import Port


class HostTap:
    """One endpoint's view of a shared link: the host-facing half of :class:`Port`.

    The module's bytes are copied to every tap whose host is connected; host
    bytes from any tap go into the link. The link is connected while at least
    one tap is.
    """

    def __init__(self, hub: HostHub, name: str):
        self.hub = hub
        self.name = name
        self.connected = False
        self._buf = bytearray()

    def host_write(self, data: bytes) -> int:
        return self.hub.port.host_write(data)

    def host_read(self, max_n: int = -1) -> bytes:
        self.hub.distribute()
        if max_n < 0 or max_n >= len(self._buf):
            out = bytes(self._buf)
            self._buf.clear()
        else:
            out = bytes(self._buf[:max_n])
            del self._buf[:max_n]
        return out

    def connect(self) -> None:
        self.hub.distribute()  # bytes sent before this host came belong to the others
        self.connected = True
        self._buf.clear()
        self.hub.update()

    def disconnect(self) -> None:
        self.connected = False
        self._buf.clear()
        self.hub.update()

    def __repr__(self) -> str:
        return f"HostTap({self.name}, {'connected' if self.connected else 'no host'}, {len(self._buf)} B)"


class HostHub:
    """Fans one link's host side out to several endpoints (a pty and a TCP port)."""

    def __init__(self, port: Port):
        self.port = port
        self.taps: list[HostTap] = []
        if port.connected:
            port.disconnect()

    def tap(self, name: str) -> HostTap:
        t = HostTap(self, name)
        self.taps.append(t)
        return t

    def distribute(self) -> None:
        data = self.port.host_read()
        if data:
            for t in self.taps:
                if t.connected:
                    t._buf += data

    def update(self) -> None:
        want = any(t.connected for t in self.taps)
        if want and not self.port.connected:
            self.port.connect()
        elif not want and self.port.connected:
            self.port.disconnect()
