"""An RFC 2217 endpoint (pyserial's PortManager) for hosts that need modem lines over TCP.

Clients open it with pyserial's ``rfc2217://HOST:PORT``; line settings are
accepted and reported back but change nothing (the emulated UART has no baud
rate of its own on this side of the link).
"""

from __future__ import annotations

import socket
from typing import Any

from ..port import Port


class _EmulatedLineSettings:
    """What an RFC 2217 client may read or set on the "serial port": a UART at 115200 8N1.

    The emulated link ignores the settings (its rate is the link model's); CD
    is the link's connected line.
    """

    def __init__(self, port: Port):
        self._port = port
        self.baudrate = 115200
        self.bytesize = 8
        self.parity = "N"
        self.stopbits = 1
        self.xonxoff = False
        self.rtscts = False
        self.break_condition = False
        self.dtr = True
        self.rts = True
        self.cts = True
        self.dsr = True
        self.ri = False

    @property
    def cd(self) -> bool:
        return bool(self._port.connected)

    def reset_input_buffer(self) -> None:
        pass

    def reset_output_buffer(self) -> None:
        pass


class Rfc2217Endpoint:
    """Serve *port* over RFC 2217 (telnet COM-port control) to one TCP host at a time.

    Hosts open it with pyserial as ``rfc2217://HOST:PORT``. Telnet negotiation
    and escaping are pyserial's :class:`serial.rfc2217.PortManager`.
    """

    def __init__(self, port: Port, host: str = "127.0.0.1", tcp_port: int = 0):
        self.port = port
        self.server = socket.create_server((host, tcp_port), backlog=4)
        self.server.setblocking(False)
        self.address: tuple[str, int] = self.server.getsockname()[:2]
        self.client: socket.socket | None = None
        self.manager: Any = None
        self._out = bytearray()
        self.connects = 0
        self.closed = False
        if port.connected:
            port.disconnect()

    @property
    def paired(self) -> bool:
        return self.client is not None

    @property
    def fds(self) -> tuple[int, ...]:
        if self.closed:
            return ()
        return (self.server.fileno(),) + ((self.client.fileno(),) if self.client is not None else ())

    def write(self, data: bytes) -> None:
        """The PortManager's "connection": bytes for the network."""
        self._out += data

    def pump(self) -> None:
        if self.closed:
            return
        self._accept()
        c = self.client
        if c is None:
            return
        while True:
            try:
                data = c.recv(4096)
            except (BlockingIOError, InterruptedError):
                break
            except OSError:
                self._hangup()
                return
            if not data:
                self._hangup()
                return
            payload = b"".join(self.manager.filter(data))
            if payload:
                self.port.host_write(payload)
        out = self.port.host_read()
        if out:
            self._out += b"".join(self.manager.escape(out))
        if self._out:
            try:
                sent = c.send(self._out)
            except (BlockingIOError, InterruptedError):
                sent = 0
            except OSError:
                self._hangup()
                return
            del self._out[:sent]

    def _accept(self) -> None:
        from serial.rfc2217 import PortManager

        while True:
            try:
                sock, _ = self.server.accept()
            except (BlockingIOError, InterruptedError, OSError):
                return
            if self.client is not None:
                sock.close()
                continue
            sock.setblocking(False)
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            self.client = sock
            self._out.clear()
            self.port.host_read()
            self.port.connect()
            self.connects += 1
            self.manager = PortManager(_EmulatedLineSettings(self.port), self)

    def _hangup(self) -> None:
        if self.client is not None:
            self.client.close()
            self.client = None
        self._out.clear()
        self.port.disconnect()

    def close(self) -> None:
        if self.closed:
            return
        self._hangup()
        self.server.close()
        self.closed = True

    def status(self) -> dict[str, object]:
        return {"kind": "rfc2217", "address": f"{self.address[0]}:{self.address[1]}", "paired": self.paired,
                "connects": self.connects}

    def __repr__(self) -> str:
        return f"Rfc2217Endpoint({self.address[0]}:{self.address[1]}, {'host' if self.paired else 'no host'})"
